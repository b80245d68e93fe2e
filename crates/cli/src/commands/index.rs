//! `keycomp index add|list|stats|remove|verify`: the on-disk index of described shapes.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use keycomp::collection::{self, AddOptions};
use keycomp_describe::DIM;

use keycomp::collection::Reader;

use crate::args::{DetectArgs, SurfaceArgs, UnitsArgs};
use crate::output;
use crate::progress::{Bar, progress};

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
    #[command(flatten)]
    pub surface: SurfaceArgs,
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
    let options = AddOptions {
        detect: args.detect.explicit(),
        units: args.units.units()?,
        // a new index made with a paper preset analyses the meshes as read, as the paper did;
        // an existing one keeps its own choice
        canonical: args.surface.canonical().or_else(|| {
            let new = !args.dir.index.join(keycomp_index::MANIFEST_NAME).exists();
            (new && !args.detect.canonical_by_default()).then_some(false)
        }),
        keep_going: true,
    };
    let bar = Bar(progress(0, "indexing"));
    let summary = collection::add(&args.dir.index, &args.paths, &options, &bar);
    bar.0.finish_and_clear();
    let s = summary?;
    if args.dir.json {
        output::print_json(&s)?;
    } else {
        let mut text = String::new();
        writeln!(
            text,
            "{}: {} added, {} replaced, {} unchanged, {} failed ({} shapes in the index)",
            args.dir.index.display(),
            s.added,
            s.replaced,
            s.unchanged,
            s.failed.len(),
            s.shapes
        )?;
        for f in &s.failed {
            writeln!(text, "  failed: {}", f.message)?;
        }
        output::print_text(&text)?;
    }
    Ok(if s.failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(2)
    })
}

fn list(args: DirArgs) -> Result<ExitCode> {
    let reader = Reader::open(&args.index)?;
    if args.json {
        let rows: Vec<serde_json::Value> = reader
            .shapes()?
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
        for sh in reader.shapes()? {
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
        if let Some(note) = serde_json::from_str::<keycomp::Profile>(reader.profile())
            .ok()
            .and_then(|p| p.migration_note(&args.index))
        {
            output::print_text(&format!("note: {note}\n"))?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn remove(args: RemoveArgs) -> Result<ExitCode> {
    let s = collection::remove(&args.dir.index, &args.paths)?;
    if args.dir.json {
        output::print_json(&s)?;
    } else {
        output::print_text(&format!(
            "{}: removed {} shapes ({} left)\n",
            args.dir.index.display(),
            s.removed,
            s.shapes
        ))?;
    }
    Ok(if s.removed == 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

fn merge(args: MergeArgs) -> Result<ExitCode> {
    let dst = &args.dir.index;
    let s = collection::merge(dst, &args.sources)?;
    if args.dir.json {
        output::print_json(&serde_json::json!({
            "index": dst.display().to_string(),
            "sources": args.sources.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "read": s.read,
            "added": s.added,
            "duplicates": s.duplicates,
            "shapes": s.shapes,
            "generation": s.generation,
        }))?;
    } else {
        output::print_text(&format!(
            "{}: merged {} indexes: {} shapes read, {} added, {} already there ({} shapes in the index)\n",
            dst.display(),
            args.sources.len(),
            s.read,
            s.added,
            s.duplicates,
            s.shapes
        ))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn verify(args: DirArgs) -> Result<ExitCode> {
    let report = keycomp_index::verify::<DIM>(&args.index)?;
    let code = if report.is_ok() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(2)
    };
    if args.json {
        output::print_json(&serde_json::json!({
            "dir": report.dir.display().to_string(),
            "ok": report.is_ok(),
            "generation": report.generation,
            "segments_listed": report.segments_listed,
            "segments_ok": report.segments_ok,
            "shapes": report.shapes,
            "components": report.components,
            "problems": report.problems.iter().map(|p| p.to_string()).collect::<Vec<_>>(),
            "leftovers": report.leftovers.iter().map(|l| l.display().to_string()).collect::<Vec<_>>(),
        }))?;
        return Ok(code);
    }
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
    Ok(code)
}
