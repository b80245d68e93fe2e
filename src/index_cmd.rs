//! `keycomp index add|list|stats|remove|verify`: the on-disk index of described shapes.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Result, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use keycomp_describe::{DIM, DescribeParams};
use keycomp_index::{IndexReader, IndexWriter, ShapeRecord, canonical_path};
use keycomp_mesh::read_mesh;
use rayon::prelude::*;

pub use keycomp::{Profile, record_of};

use crate::detect::DetectArgs;
use crate::output;

/// The index as the CLI uses it: descriptors of the describe crate's length.
pub type Writer = IndexWriter<DIM>;
/// The index as the CLI uses it: descriptors of the describe crate's length.
pub type Reader = IndexReader<DIM>;

/// Opens (or creates) the index at `dir` for adding shapes analysed with `profile`: an empty
/// index takes it, an index made another way is refused with a clear error.
pub fn open_writer(dir: &Path, profile: &Profile) -> Result<Writer> {
    let mut w = Writer::create_or_open(dir)?;
    w.ensure_profile(&profile.to_text()?)?;
    Ok(w)
}

/// Opens the index at `dir` for querying and chooses the profile of the query: the index's
/// description parameters (its length unit included) always, and its detection parameters when
/// the command line gives no detection option or agrees with them; anything else (another
/// descriptor version, other detection parameters, an index without a profile) is a clear
/// error, since its descriptors would not be comparable.
pub fn open_reader_for_query(dir: &Path, args: &DetectArgs) -> Result<(Reader, Profile)> {
    let reader = Reader::open(dir)?;
    let mine = Profile::current(&args.retrieval_params());
    let profile = keycomp::query_profile(
        dir,
        reader.profile(),
        reader.shapes().len(),
        &mine,
        args.is_default(),
    )?;
    Ok((reader, profile))
}

/// The length unit options of the commands that describe shapes (`index add`, `match`).
#[derive(Debug, Clone, clap::Args)]
pub struct UnitsArgs {
    /// Length unit of the description: scale-free (every mesh scaled to unit area on its own,
    /// the default) or file (the files' own units, for a collection and queries in the same
    /// real units, e.g. CAD in mm or calibrated scans: a fragment keeps its source's scale).
    /// Recorded in the index's profile; queries use the index's.
    #[arg(long, value_name = "MODE", value_parser = ["scale-free", "file"])]
    pub units: Option<String>,
    /// With --units file: the length unit, in file units [default: the square root of the
    /// median surface area of the shapes added (`index add` into a new index) or of the second
    /// shape (`match`)].
    #[arg(long, value_name = "L", requires = "units")]
    pub unit_length: Option<f64>,
}

impl UnitsArgs {
    /// Whether file units were asked for.
    pub fn file(&self) -> bool {
        self.units.as_deref() == Some("file")
    }

    /// The description parameters these options give, `sizes` standing for the shapes whose
    /// median area sets the default unit (called only with --units file and no --unit-length).
    pub fn describe_params(&self, sizes: impl FnOnce() -> Vec<f64>) -> Result<DescribeParams> {
        if !self.file() {
            if self.unit_length.is_some() {
                bail!("--unit-length needs --units file");
            }
            return Ok(DescribeParams::default());
        }
        let length = match self.unit_length {
            Some(l) if l.is_finite() && l > 0.0 => l,
            Some(l) => bail!("--unit-length must be a positive number of file units, got {l}"),
            None => unit_from_areas(sizes())?,
        };
        Ok(DescribeParams {
            units: keycomp_describe::Units::File { length },
            ..DescribeParams::default()
        })
    }
}

/// The length unit of a collection in file units: the square root of its median surface area.
pub fn unit_from_areas(mut areas: Vec<f64>) -> Result<f64> {
    areas.retain(|a| a.is_finite() && *a > 0.0);
    if areas.is_empty() {
        bail!("--units file: no shape with a positive surface area to choose the length unit from");
    }
    areas.sort_by(f64::total_cmp);
    Ok(areas[areas.len() / 2].sqrt())
}

/// Surface areas of the readable meshes among `files` (unreadable ones are left out; they fail
/// with a clear message when analysed).
pub fn areas_of(files: &[PathBuf]) -> Vec<f64> {
    files
        .par_iter()
        .filter_map(|p| read_mesh(p).ok())
        .map(|m| keycomp_mesh::geometry::total_area(&m.mesh))
        .collect()
}

/// Shapes described before each commit to disk.
const BATCH: usize = 32;

/// Index subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum IndexCommand {
    /// Add mesh files, or every supported mesh below directories (recursively).
    #[command(
        after_help = "Examples:\n  keycomp index add ../shared/data/tosca\n  keycomp index add a.off b.ply --index my-index"
    )]
    Add(Box<AddArgs>),
    /// List the indexed shapes.
    List(DirArgs),
    /// Counts and sizes.
    Stats(DirArgs),
    /// Remove shapes by path.
    Remove(RemoveArgs),
    /// Check every file of the index (checksums, versions, listed segments); changes nothing.
    Verify(DirArgs),
    /// Merge indexes built apart (e.g. shards of one collection) into --index, in one commit.
    #[command(
        after_help = "Every source must have been made with the same parameters (profile) as the others and as\n\
                      --index, unless --index is empty. A shape (canonical path) in several indexes with the same\n\
                      content is stored once; with different contents the merge stops and names both indexes.\n\
                      Nothing is written unless the whole merge succeeds.\n\n\
                      Examples:\n  keycomp index merge shard-0 shard-1 shard-2 --index all"
    )]
    Merge(MergeArgs),
}

/// Arguments of `keycomp index merge`.
#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// Source index directories (read, never changed).
    #[arg(required = true, value_name = "SRC")]
    pub sources: Vec<PathBuf>,
    #[command(flatten)]
    pub dir: DirArgs,
}

/// The index directory option.
#[derive(Debug, Clone, clap::Args)]
pub struct DirArgs {
    /// Index directory.
    #[arg(long, default_value = "index", value_name = "DIR")]
    pub index: PathBuf,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `keycomp index add`.
#[derive(Debug, clap::Args)]
pub struct AddArgs {
    /// Mesh files or directories.
    #[arg(required = true)]
    pub paths: Vec<PathBuf>,
    #[command(flatten)]
    pub dir: DirArgs,
    #[command(flatten)]
    pub detect: DetectArgs,
    #[command(flatten)]
    pub units: UnitsArgs,
}

/// Arguments of `keycomp index remove`.
#[derive(Debug, clap::Args)]
pub struct RemoveArgs {
    /// Paths of indexed shapes, or folders: every indexed shape under a folder is removed.
    #[arg(required = true)]
    pub paths: Vec<PathBuf>,
    #[command(flatten)]
    pub dir: DirArgs,
}

/// Records of `files` for `writer`'s index ([`keycomp::records_of_new`]), advancing `bar` per
/// file.
pub fn records_of_new(
    writer: &Writer,
    files: &[PathBuf],
    profile: &Profile,
    bar: &ProgressBar,
) -> Vec<Option<Result<ShapeRecord<DIM>>>> {
    keycomp::records_of_new(
        files,
        profile,
        |c| writer.lookup(c).map(|(_, h)| h),
        || bar.inc(1),
    )
    .into_iter()
    .map(|r| r.map(|r| r.map_err(anyhow::Error::from)))
    .collect()
}

/// A progress bar on stderr, hidden when stderr is not a terminal.
pub fn progress(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    if let Ok(style) =
        ProgressStyle::with_template("{spinner} {msg} [{bar:30}] {pos}/{len} {elapsed} (eta {eta})")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_string());
    bar
}

pub fn run(cmd: IndexCommand) -> Result<ExitCode> {
    match cmd {
        IndexCommand::Add(a) => add(*a),
        IndexCommand::List(d) => list(d),
        IndexCommand::Stats(d) => stats(d),
        IndexCommand::Remove(r) => remove(r),
        IndexCommand::Verify(d) => verify(d),
        IndexCommand::Merge(m) => merge(m),
    }
}

fn add(args: AddArgs) -> Result<ExitCode> {
    let params = args.detect.retrieval_params();
    let files = keycomp::mesh_files(&args.paths)?;
    if files.is_empty() {
        bail!("no mesh files (.off, .obj, .ply, .stl, .gltf, .glb) found in the paths given");
    }
    output::check_output_folder(&args.dir.index)?;
    let mut writer = Writer::create_or_open(&args.dir.index)?;
    // an index that has a profile keeps its description (its length unit included)
    let existing = serde_json::from_str::<Profile>(writer.profile()).ok();
    let describe = match existing {
        Some(p) => {
            let file = matches!(p.describe.units, keycomp_describe::Units::File { .. });
            if args.units.units.is_some() && file != args.units.file() {
                bail!(
                    "index {} describes shapes in {} units; drop --units or use another --index",
                    args.dir.index.display(),
                    if file { "file" } else { "scale-free" }
                );
            }
            p.describe
        }
        None => args.units.describe_params(|| areas_of(&files))?,
    };
    let profile = Profile::with(&params, describe);
    writer.ensure_profile(&profile.to_text()?)?;
    let bar = progress(files.len() as u64, "indexing");
    let (mut added, mut replaced, mut unchanged) = (0usize, 0usize, 0usize);
    let mut failed: Vec<String> = Vec::new();
    for chunk in files.chunks(BATCH) {
        let results = records_of_new(&writer, chunk, &profile, &bar);
        let mut records = Vec::new();
        for (p, r) in chunk.iter().cloned().zip(results) {
            match r {
                None => unchanged += 1,
                Some(Ok(rec)) => records.push(rec),
                Some(Err(e)) => {
                    let why = naming(&p, &e);
                    bar.suspend(|| eprintln!("skipped: {why}"));
                    failed.push(why);
                }
            }
        }
        if !records.is_empty() {
            let s = writer.add_batch(records)?;
            added += s.added;
            replaced += s.replaced;
            unchanged += s.skipped;
        }
    }
    bar.finish_and_clear();
    let mut s = String::new();
    writeln!(
        s,
        "{}: {added} added, {replaced} replaced, {unchanged} unchanged, {} failed ({} shapes in the index)",
        args.dir.index.display(),
        failed.len(),
        writer.len()
    )?;
    for why in &failed {
        writeln!(s, "  failed: {why}")?;
    }
    output::print_text(&s)?;
    Ok(if failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(2)
    })
}

fn list(args: DirArgs) -> Result<ExitCode> {
    let reader = Reader::open(&args.index)?;
    if args.json {
        let rows: Vec<serde_json::Value> = reader
            .shapes()
            .iter()
            .map(|s| {
                serde_json::json!({
                    "id": s.id.0,
                    "path": s.record.path.display().to_string(),
                    "hash": s.record.content_hash.to_hex(),
                    "vertices": s.record.vertex_count,
                    "faces": s.record.face_count,
                    "components": s.record.components.len(),
                })
            })
            .collect();
        output::print_json(&rows)?;
    } else {
        let mut s = String::new();
        for sh in reader.shapes() {
            writeln!(
                s,
                "{:>6}  {:>8} v  {:>3} comp  {}",
                sh.id.0,
                sh.record.vertex_count,
                sh.record.components.len(),
                sh.record.path.display()
            )?;
        }
        output::print_text(&s)?;
    }
    Ok(ExitCode::SUCCESS)
}

fn stats(args: DirArgs) -> Result<ExitCode> {
    let reader = Reader::open(&args.index)?;
    let st = reader.stats();
    if args.json {
        output::print_json(&serde_json::json!({
            "dir": st.dir.display().to_string(),
            "format_version": st.format_version,
            "generation": st.generation,
            "dim": st.dim,
            "shapes": st.shapes,
            "components": st.components,
            "segments": st.segments,
            "tombstones": st.tombstones,
            "bytes": st.bytes,
            "open_ms": reader.load_time().as_secs_f64() * 1e3,
            "profile": serde_json::from_str::<serde_json::Value>(reader.profile())
                .unwrap_or_else(|_| serde_json::Value::String(reader.profile().to_string())),
        }))?;
    } else {
        output::print_text(&format!(
            "{}: format {}, generation {}, {} shapes, {} components (dim {}), {} segments, {} bytes, opened in {:.1} ms\n",
            st.dir.display(),
            st.format_version,
            st.generation,
            st.shapes,
            st.components,
            st.dim,
            st.segments,
            st.bytes,
            reader.load_time().as_secs_f64() * 1e3
        ))?;
        output::print_text(&format!(
            "profile: {}\n",
            if reader.profile().is_empty() {
                "none (older keycomp: rebuild before querying)"
            } else {
                reader.profile()
            }
        ))?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The error `e` about `path` as one line that names the file once.
fn naming(path: &Path, e: &anyhow::Error) -> String {
    let why = output::error_chain(e);
    let name = path.display().to_string();
    if why.contains(&name) {
        why
    } else {
        format!("{name}: {why}")
    }
}

fn remove(args: RemoveArgs) -> Result<ExitCode> {
    if !args.dir.index.join(keycomp_index::MANIFEST_NAME).is_file() {
        bail!(
            "{}: not a keycomp index (no MANIFEST); nothing to remove",
            args.dir.index.display()
        );
    }
    let mut writer = Writer::create_or_open(&args.dir.index)?;
    // A folder stands for every indexed shape under it, as `index add FOLDER` adds every mesh
    // under it (also those whose files are gone since).
    let mut paths: Vec<PathBuf> = Vec::new();
    for p in &args.paths {
        if p.is_dir() {
            let root = canonical_path(p);
            let mut under: Vec<PathBuf> = writer
                .canonical_paths()
                .filter(|c| c.starts_with(&root))
                .map(Path::to_path_buf)
                .collect();
            under.sort();
            paths.extend(under);
        } else {
            paths.push(p.clone());
        }
    }
    let n = writer.remove(&paths)?;
    output::print_text(&format!(
        "{}: removed {n} shapes ({} left)\n",
        args.dir.index.display(),
        writer.len()
    ))?;
    Ok(if n == 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

fn merge(args: MergeArgs) -> Result<ExitCode> {
    let dst = &args.dir.index;
    let mut sources = Vec::with_capacity(args.sources.len());
    for src in &args.sources {
        if canonical_path(src) == canonical_path(dst) {
            bail!("{}: an index cannot be merged into itself", src.display());
        }
        sources.push(Reader::open(src)?);
    }
    output::check_output_folder(dst)?;
    let mut writer = Writer::create_or_open(dst)?;
    let s = writer.merge(&sources)?;
    if args.dir.json {
        output::print_json(&serde_json::json!({
            "index": dst.display().to_string(),
            "sources": args.sources.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "read": s.read,
            "added": s.added,
            "duplicates": s.duplicates,
            "shapes": writer.len(),
            "generation": s.generation,
        }))?;
    } else {
        output::print_text(&format!(
            "{}: merged {} indexes: {} shapes read, {} added, {} already there ({} shapes in the index)\n",
            dst.display(),
            sources.len(),
            s.read,
            s.added,
            s.duplicates,
            writer.len()
        ))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn verify(args: DirArgs) -> Result<ExitCode> {
    let report = keycomp_index::verify::<DIM>(&args.index)?;
    let mut s = String::new();
    writeln!(
        s,
        "{}: {} of {} segments ok, {} shapes, {} components",
        report.dir.display(),
        report.segments_ok,
        report.segments_listed,
        report.shapes,
        report.components
    )?;
    for p in &report.problems {
        writeln!(s, "  problem: {p}")?;
    }
    for l in &report.leftovers {
        writeln!(
            s,
            "  leftover (from an interrupted add; removed by the next add): {}",
            l.display()
        )?;
    }
    output::print_text(&s)?;
    Ok(if report.is_ok() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(2)
    })
}
