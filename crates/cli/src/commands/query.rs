//! `keycomp query MESH`: rank the indexed shapes by how well their key-components match the
//! query's (a whole shape or a fragment).

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use keycomp::search::{QueryTimings, Searcher};

use crate::args::DetectArgs;
use crate::{output, report};

pub const EXAMPLES: &str = "Examples:
  keycomp index add ../shared/data/tosca && keycomp query ../shared/data/tosca/cat3.off
  keycomp query scan-of-a-leg.ply -k 5 --json
  keycomp query cat3-half.off --report cat3-report   # then open cat3-report/index.html";

/// Arguments of `keycomp query`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Query mesh (a whole shape or a fragment).
    pub mesh: PathBuf,
    /// Index directory.
    #[arg(long, default_value = "index", value_name = "DIR")]
    pub index: PathBuf,
    /// Number of results.
    #[arg(short = 'k', long = "top", default_value_t = 10, value_parser = crate::args::at_least_one)]
    pub k: usize,
    /// Weight of the pose check, 0–1: above 0, shapes whose matched parts sit as the query's
    /// do (the same pose, a fragment's exact source) rank above the same parts in another
    /// pose. 0 (default) ranks independently of pose, as classes of articulated shapes need.
    #[arg(long, value_name = "W", default_value_t = 0.0, value_parser = crate::args::unit_weight)]
    pub pose: f64,
    /// Weight of geometric verification, 0–1, or auto (the default: for a query with a
    /// boundary, a fragment or a scan, 1 in file units or on canonical surfaces, 0.5 on meshes
    /// as read; 0 for a closed shape): each shape's
    /// score is scaled by 1 − W·(1 − f), f the share of the query's surface that lies on the
    /// shape once aligned by the matched parts, so a fragment's exact source ranks first. It
    /// re-ranks the 32 best candidates; those beyond count as fitness 0.
    #[arg(long, value_name = "W|auto", default_value = "auto", value_parser = crate::args::auto_or_unit_weight)]
    pub verify: crate::args::AutoWeight,
    /// Refine the transform (where the query sits on a result, `transform` in --json) of this
    /// many of the best results on their file's surface (point-to-plane ICP; each reads that
    /// file again); the others keep verification's alignment.
    #[arg(long, value_name = "N", default_value_t = keycomp::search::REFINED_RESULTS)]
    pub refine: usize,
    #[command(flatten)]
    pub detect: DetectArgs,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Also write an HTML report with pictures to this directory (DIR/index.html): the query
    /// with its key-components coloured, each result with its matched components in the same
    /// colours.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Also write the analysed query to this JSON file: per scale hypothesis, the mesh its
    /// parts are on (the file, or its canonical surface) as `positions` and `faces`, and its
    /// parts as vertex ids (`hypotheses[h].parts[part]`, the numbering of `query_component`),
    /// for viewers of the matched parts (`keycomp serve` uses it).
    #[arg(long, value_name = "FILE")]
    pub analysis_out: Option<PathBuf>,
    /// Also write the query moved onto each result (its `transform`) into this folder, as
    /// binary PLY (`NN-<result's name>.ply`, NN the rank; the query's mesh, or its points):
    /// results without an alignment get no file.
    #[arg(long, value_name = "DIR")]
    pub aligned_dir: Option<PathBuf>,
}

/// What `--analysis-out` writes: per scale hypothesis, the mesh analysed and its parts.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
pub struct AnalysisOut {
    /// One per scale hypothesis, in their order (`hypothesis` of a result).
    pub hypotheses: Vec<AnalysedHypothesis>,
}

/// The query as analysed under one scale hypothesis.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
pub struct AnalysedHypothesis {
    /// Vertex positions of the analysed mesh (the file's, or its canonical surface sampled
    /// for this hypothesis).
    pub positions: Vec<[f64; 3]>,
    /// Its triangles.
    pub faces: Vec<[u32; 3]>,
    /// Per part (the numbering of `query_component`), its vertex ids.
    pub parts: Vec<Vec<u32>>,
}

impl AnalysisOut {
    fn of(q: &keycomp::Analysed) -> AnalysisOut {
        AnalysisOut {
            hypotheses: (0..q.hypothesis_count())
                .map(|h| {
                    let mesh = q.mesh_of(h);
                    AnalysedHypothesis {
                        positions: mesh.positions.iter().map(|p| [p.x, p.y, p.z]).collect(),
                        faces: mesh.faces.clone(),
                        parts: q
                            .hypothesis(h)
                            .components
                            .iter()
                            .map(|c| c.vertices.clone())
                            .collect(),
                    }
                })
                .collect(),
        }
    }
}

pub fn run(args: Args) -> Result<ExitCode> {
    if let Some(dir) = &args.report {
        // before any work: the report's folder must be creatable
        crate::output::check_output_folder(dir)?;
    }
    if let Some(dir) = &args.aligned_dir {
        keycomp::folders::check_output_folder(dir)?;
    }
    let mut searcher = Searcher::open(&args.index, args.detect.explicit().as_ref())?;
    if let Some(note) = searcher.migration_note() {
        eprintln!("note: {note}");
    }
    searcher.set_pose_weight(args.pose)?;
    searcher.set_verify_weight(args.verify.0)?;
    searcher.set_refined_results(args.refine);
    let reader = searcher.reader();
    let (q, ranked, answer) = searcher.query_full(&args.mesh, args.k)?;
    for w in &q.warnings {
        eprintln!("warning: {}: {w}", args.mesh.display());
    }
    let QueryTimings {
        describe: describe_ms,
        open: open_ms,
        search: search_ms,
        transforms: transforms_ms,
        ..
    } = answer.timings_ms;
    if let Some(dir) = &args.aligned_dir {
        keycomp::folders::create_output_folder(dir)?;
        for hit in &answer.results {
            if let Some(t) = &hit.transform {
                let stem = std::path::Path::new(&hit.path)
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "shape".into());
                let out = dir.join(format!("{:02}-{stem}.ply", hit.rank));
                output::write_moved(&q.input, t, &out)?;
            }
        }
    }
    if let Some(file) = &args.analysis_out {
        let text = serde_json::to_vec(&AnalysisOut::of(&q))?;
        output::write_bytes(file, &text)?;
    }
    let not_returned = &answer.not_returned;
    let report = match &args.report {
        Some(dir) => {
            let entry = report::QueryEntry {
                title: args.mesh.display().to_string(),
                note: None,
                query: &q,
                results: &ranked,
            };
            Some(report::write_report(
                dir,
                reader,
                &[entry],
                &report::ReportParams::default(),
            )?)
        }
        None => None,
    };

    if args.json {
        if let Some(page) = &report {
            eprintln!("report: {}", page.display()); // stdout is the JSON
        }
        output::print_json(&answer)?;
    } else {
        let mut s = String::new();
        writeln!(
            s,
            "{}: {} parts; {} shapes in {}",
            args.mesh.display(),
            answer.components,
            reader.len(),
            args.index.display()
        )?;
        if answer.components == 0 {
            writeln!(
                s,
                "no parts found in the query (an empty mesh?): nothing to match"
            )?;
        }
        writeln!(s, "{:>4}  {:>6}  {:>7}  path", "rank", "score", "matched")?;
        for (i, r) in ranked.iter().enumerate() {
            writeln!(
                s,
                "{:>4}  {:>6.3}  {:>7}  {}",
                i + 1,
                r.result.score,
                r.result.matches.len(),
                r.path.display()
            )?;
        }
        if !not_returned.is_empty() {
            writeln!(
                s,
                "not returned ({} shapes: none of their parts is among the nearest of a query part):",
                not_returned.len()
            )?;
            for p in not_returned.iter().take(20) {
                writeln!(s, "        {p}")?;
            }
            if not_returned.len() > 20 {
                writeln!(s, "        … and {} more", not_returned.len() - 20)?;
            }
        }
        writeln!(
            s,
            "time: describe query {describe_ms:.0} ms, open index {open_ms:.1} ms, search {search_ms:.1} ms, transforms {transforms_ms:.1} ms"
        )?;
        if let Some(page) = &report {
            writeln!(s, "report: {}", page.display())?;
        }
        output::print_text(&s)?;
    }
    Ok(if ranked.is_empty() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
