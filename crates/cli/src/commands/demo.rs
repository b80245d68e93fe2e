//! `keycomp demo`: the whole product on a collection generated in code, so it runs anywhere
//! with no files: generate the shapes, index them, query the index with held-out shapes and
//! with fragments cut from indexed shapes, print a table and write an HTML report.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use keycomp_fragment::{PartialKind, cut_fragment};
use keycomp_mesh::geometry;
use keycomp_retrieval::Ranked;
use keycomp_shapes::{Class, GenerateParams, Shape};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::args::DetectArgs;
use crate::progress::{Bar, progress};
use crate::{output, report};
use keycomp::Analysed;
use keycomp::Profile;
use keycomp::collection::{self, AddOptions, Units};
use keycomp::search::Searcher;

pub const EXAMPLES: &str = "Examples:
  keycomp demo                         # ./demo-out (meshes, queries, report) and ./index
  keycomp demo --out /tmp/kc --index /tmp/kc/index
  keycomp demo --per-class 3 --vertices 8000    # a smaller, faster run";

/// Arguments of `keycomp demo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Work folder: the generated meshes go to DIR/collection, the queries to DIR/queries,
    /// the HTML report to DIR/report.
    #[arg(long, default_value = "demo-out", value_name = "DIR")]
    pub out: PathBuf,
    /// Index directory the collection is added to (shapes already there are kept; files
    /// indexed before with the same content are skipped).
    #[arg(long, default_value = "index", value_name = "DIR")]
    pub index: PathBuf,
    /// Indexed shapes per class (the collection has 7 classes).
    #[arg(long, default_value_t = 6, value_name = "N")]
    pub per_class: usize,
    /// Vertices per generated shape (approximately; at least 4000). The default keeps the
    /// whole demo under a minute on two cores.
    #[arg(long, default_value_t = 15_000, value_name = "N")]
    pub vertices: usize,
    /// Seed of the generated collection and of the cuts (`--seed` is SMACOF's, as elsewhere).
    #[arg(long, default_value_t = 2013, value_name = "S")]
    pub shape_seed: u64,
    /// Results shown per query.
    #[arg(short = 'k', long = "top", default_value_t = 3, value_parser = crate::args::at_least_one)]
    pub k: usize,
    #[command(flatten)]
    pub detect: DetectArgs,
}

/// How a query was made.
#[derive(Debug, Clone, Copy)]
enum Kind {
    /// A held-out instance of a class, not in the index.
    Whole,
    /// The part of an indexed shape on one side of a plane.
    Plane,
    /// A geodesic ball around a vertex of an indexed shape.
    Ball,
}

struct Query {
    name: String,
    class: Class,
    kind: Kind,
    /// Indexed shape the fragment was cut from.
    source: Option<String>,
    /// Kept fraction of the source's area.
    kept: f64,
    path: PathBuf,
}

/// The class of a collection file, from its name (`bird-03.off` → bird).
fn class_of(path: &Path) -> Option<Class> {
    let stem = path.file_stem()?.to_str()?;
    Class::from_name(stem.rsplit_once('-')?.0)
}

/// Indexes `files` into `index` as `keycomp index add` does ([`collection::add`], which
/// refuses an index made with other parameters and skips files already indexed with the same
/// content), but stops at the first file that cannot be analysed. Returns (added or replaced,
/// unchanged).
fn index_files(index: &Path, files: &[PathBuf], params: &Profile) -> Result<(usize, usize)> {
    let bar = Bar(progress(0, "indexing"));
    let options = AddOptions {
        detect: Some(params.detect.clone()),
        units: Some(Units::ScaleFree),
        canonical: Some(params.surface.is_some()),
        keep_going: false,
    };
    let s = collection::add(index, files, &options, &bar);
    bar.0.finish_and_clear();
    let s = s?;
    Ok((s.added + s.replaced, s.unchanged))
}

pub fn run(args: Args) -> Result<ExitCode> {
    if args.per_class == 0 {
        bail!("--per-class must be at least 1");
    }
    if args.vertices < keycomp_shapes::MIN_VERTICES {
        bail!(
            "--vertices must be at least {} (coarser grids cannot resolve the shapes' thinnest \
             parts), got {}",
            keycomp_shapes::MIN_VERTICES,
            args.vertices
        );
    }
    // Every check before anything is created.
    crate::output::check_output_folder(&args.out)?;
    crate::output::check_output_folder(&args.index)?;
    let t_all = Instant::now();
    let params = Profile::current(&args.detect.retrieval_params());
    let gen_params = GenerateParams {
        seed: args.shape_seed,
        target_vertices: args.vertices,
        ..GenerateParams::default()
    };
    let collection_dir = args.out.join("collection");
    let query_dir = args.out.join("queries");
    crate::output::create_output_folder(&args.out)?;
    for d in [&collection_dir, &query_dir] {
        std::fs::create_dir_all(d)
            .with_context(|| format!("{}: cannot create the directory", d.display()))?;
    }

    // 1. Generate: per class, `per_class` indexed instances and one held-out query instance.
    let t = Instant::now();
    let n_shapes = Class::ALL.len() * (args.per_class + 1);
    let bar = progress(n_shapes as u64, "generating shapes");
    let shapes: Vec<Shape> =
        keycomp_shapes::collection(&Class::ALL, args.per_class + 1, &gen_params, &|_| {
            bar.inc(1)
        })?;
    bar.finish_and_clear();
    let gen_s = t.elapsed().as_secs_f64();
    let mut files = Vec::new();
    for s in &shapes {
        let held_out = s.instance == args.per_class;
        let dir = if held_out {
            &query_dir
        } else {
            &collection_dir
        };
        let path = dir.join(format!("{}.off", s.name));
        keycomp_mesh::write_off(&s.mesh, &path)?;
        if !held_out {
            files.push(path);
        }
    }
    let mean_v = shapes.iter().map(|s| s.mesh.num_vertices()).sum::<usize>() / shapes.len();
    eprintln!(
        "generated {} shapes ({} classes, about {mean_v} vertices each) in {gen_s:.1} s",
        shapes.len(),
        Class::ALL.len()
    );

    // 2. Index the collection.
    let t = Instant::now();
    let (changed, unchanged) = index_files(&args.index, &files, &params)?;
    let index_s = t.elapsed().as_secs_f64();
    eprintln!(
        "indexed {} into {}: {changed} added, {unchanged} already there, in {index_s:.1} s",
        collection_dir.display(),
        args.index.display()
    );

    // 3. Queries: each class's held-out instance whole, and a fragment (plane cut or ball,
    //    alternating by class) of one indexed instance keeping 30–60 % of its area.
    let mut rng = ChaCha8Rng::seed_from_u64(args.shape_seed ^ 0x5EED_C075);
    let mut queries = Vec::new();
    for (ci, &class) in Class::ALL.iter().enumerate() {
        let held = shapes
            .iter()
            .find(|s| s.class == class && s.instance == args.per_class)
            .context("held-out shape missing")?;
        queries.push(Query {
            name: held.name.clone(),
            class,
            kind: Kind::Whole,
            source: None,
            kept: 1.0,
            path: query_dir.join(format!("{}.off", held.name)),
        });
        let src = shapes
            .iter()
            .find(|s| s.class == class && s.instance == ci % args.per_class)
            .context("source shape missing")?;
        let fraction = rng.random_range(0.3..0.6);
        // the fragments of `keycomp bench retrieval`
        let (kind, how) = if ci % 2 == 0 {
            (Kind::Plane, PartialKind::Plane)
        } else {
            (Kind::Ball, PartialKind::Ball)
        };
        let part = cut_fragment(&src.mesh, how, fraction, &mut rng)
            .with_context(|| format!("cutting a {how} fragment of {}", src.name))?
            .mesh;
        let kept = geometry::total_area(&part) / geometry::total_area(&src.mesh);
        let tag = match kind {
            Kind::Plane => "plane",
            _ => "ball",
        };
        let name = format!("{}-{tag}{:02.0}", src.name, kept * 100.0);
        let path = query_dir.join(format!("{name}.off"));
        keycomp_mesh::write_off(&part, &path)?;
        queries.push(Query {
            name,
            class,
            kind,
            source: Some(src.name.clone()),
            kept,
            path,
        });
    }

    // 4. Run them as `keycomp query` does (with the index's detection parameters).
    let searcher = Searcher::open(&args.index, args.detect.explicit().as_ref())?;
    let bar = progress(queries.len() as u64, "querying");
    let mut runs: Vec<(Analysed, Vec<Ranked>, f64)> = Vec::new();
    for q in &queries {
        let t = Instant::now();
        let a = searcher.analyse(&q.path)?;
        let ranked = searcher.rank(&a, args.k)?;
        runs.push((a, ranked, t.elapsed().as_secs_f64()));
        bar.inc(1);
    }
    bar.finish_and_clear();

    // 5. Table.
    let mut s = String::new();
    writeln!(
        s,
        "keycomp demo: {} classes × {} shapes generated in code and indexed; {} queries \
         (each class: a held-out shape, and a fragment cut from an indexed one)",
        Class::ALL.len(),
        args.per_class,
        queries.len()
    )?;
    writeln!(
        s,
        "{:<22} {:<10} {:>5} {:>5}  {:<56} {:<4} {:>6}",
        "query", "class", "kept", "comps", "top results (score)", "top1", "time"
    )?;
    let (mut hits, mut whole_hits, mut part_hits, mut source_first) = (0, 0, 0, 0);
    for (q, (a, ranked, secs)) in queries.iter().zip(&runs) {
        let top: Vec<String> = ranked
            .iter()
            .map(|r| {
                let stem = r
                    .path
                    .file_stem()
                    .map(|x| x.to_string_lossy().into_owned())
                    .unwrap_or_default();
                format!("{stem} ({:.2})", r.result.score)
            })
            .collect();
        let first = ranked.first();
        let hit = first.and_then(|r| class_of(&r.path)) == Some(q.class);
        if hit {
            hits += 1;
            match q.kind {
                Kind::Whole => whole_hits += 1,
                _ => part_hits += 1,
            }
        }
        if let (Some(src), Some(r)) = (&q.source, first)
            && r.path.file_stem().and_then(|x| x.to_str()) == Some(src.as_str())
        {
            source_first += 1;
        }
        writeln!(
            s,
            "{:<22} {:<10} {:>4.0}% {:>5}  {:<56} {:<4} {:>5.2}s",
            q.name,
            q.class.name(),
            q.kept * 100.0,
            a.description.components.len(),
            if top.is_empty() {
                "(no match)".to_string()
            } else {
                top.join(", ")
            },
            if hit { "hit" } else { "miss" },
            secs
        )?;
    }
    let n_whole = queries
        .iter()
        .filter(|q| matches!(q.kind, Kind::Whole))
        .count();
    let n_part = queries.len() - n_whole;
    writeln!(
        s,
        "top-1 class: {hits}/{} hits (held-out whole shapes {whole_hits}/{n_whole}, fragments \
         {part_hits}/{n_part}); fragments whose source shape ranks first: {source_first}/{n_part}",
        queries.len()
    )?;

    // 6. Report.
    let t = Instant::now();
    let entries: Vec<report::QueryEntry> = queries
        .iter()
        .zip(&runs)
        .map(|(q, (a, ranked, _))| report::QueryEntry {
            title: q.name.clone(),
            note: Some(match (&q.kind, &q.source) {
                (Kind::Whole, _) => format!(
                    "class {}: a held-out shape (not in the index)",
                    q.class.name()
                ),
                (kind, src) => format!(
                    "class {}: {} of {} keeping {:.0} % of its area",
                    q.class.name(),
                    if matches!(kind, Kind::Plane) {
                        "a plane cut"
                    } else {
                        "a geodesic ball"
                    },
                    src.as_deref().unwrap_or("?"),
                    q.kept * 100.0
                ),
            }),
            query: a,
            results: ranked,
        })
        .collect();
    let page = report::write_report(
        &args.out.join("report"),
        searcher.reader(),
        &entries,
        &report::ReportParams::default(),
    )?;
    let report_s = t.elapsed().as_secs_f64();
    writeln!(
        s,
        "report: {} (rendered in {report_s:.1} s); total {:.1} s",
        page.display(),
        t_all.elapsed().as_secs_f64()
    )?;
    output::print_text(&s)?;
    Ok(ExitCode::SUCCESS)
}
