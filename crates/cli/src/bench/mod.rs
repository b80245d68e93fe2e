//! `keycomp bench …`: measurements that produce the tables of BENCHMARKS.md.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};
use keycomp_components::detect;
use keycomp_mesh::read_mesh;
use serde::Serialize;

pub mod repeatability;
pub mod retrieval;

use crate::args::DetectArgs;
use crate::output;

/// Benchmarks.
#[derive(Debug, clap::Subcommand)]
pub enum BenchCommand {
    /// Time every stage of key-component detection on mesh files (median of several runs).
    #[command(
        after_help = "Example:\n  keycomp bench detect ../shared/data/models/nefertiti.obj --runs 5 --threads 2"
    )]
    Detect(DetectBenchArgs),
    /// Repeatability of key-components under SHREC'10-style transformations and real poses:
    /// the paper's Tables 1-3 (ours beside the paper's) and Figs. 7-9 (Section 4).
    #[command(after_help = crate::bench::repeatability::EXAMPLES)]
    Repeatability(crate::bench::repeatability::Args),
    /// Retrieval quality on a labelled collection: whole-shape and partial queries, PSB
    /// measures (NN, FT, ST, E, DCG, mAP, precision-recall), key-components against D2.
    #[command(after_help = crate::bench::retrieval::EXAMPLES)]
    Retrieval(crate::bench::retrieval::Args),
}

/// Arguments of `keycomp bench detect`.
#[derive(Debug, clap::Args)]
pub struct DetectBenchArgs {
    /// Mesh files.
    #[arg(required = true)]
    pub meshes: Vec<PathBuf>,
    #[command(flatten)]
    pub detect: DetectArgs,
    /// Runs per mesh; the table shows the median of each column.
    #[arg(long, default_value_t = 3, value_parser = crate::args::at_least_one)]
    pub runs: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print JSON instead of a markdown table.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Serialize)]
struct Row {
    mesh: String,
    vertices: usize,
    keypoints: usize,
    components: usize,
    /// Vertices of the mesh the fronts ran on (the proxy's when there is one).
    geodesic_vertices: usize,
    read_ms: f64,
    harris_ms: f64,
    geodesic_ms: f64,
    /// The part of `geodesic_ms` spent building the proxy.
    simplify_ms: f64,
    mds_ms: f64,
    cluster_ms: f64,
    extract_ms: f64,
    total_ms: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

pub fn run(cmd: BenchCommand) -> Result<ExitCode> {
    match cmd {
        BenchCommand::Detect(args) => detect_bench(args),
        BenchCommand::Repeatability(args) => crate::bench::repeatability::run_cmd(args),
        BenchCommand::Retrieval(args) => crate::bench::retrieval::run(args),
    }
}

fn detect_bench(args: DetectBenchArgs) -> Result<ExitCode> {
    let params = args.detect.params();
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        builder = builder.num_threads(n);
    }
    let pool = builder.build().context("cannot start the thread pool")?;
    let threads = pool.current_num_threads();
    let runs = args.runs.max(1);
    let mut rows = Vec::new();
    for path in &args.meshes {
        let mut samples: Vec<[f64; 8]> = Vec::with_capacity(runs);
        let mut last = (0, 0, 0, 0);
        for _ in 0..runs {
            let t0 = Instant::now();
            let mesh = read_mesh(path)?.mesh;
            let read = t0.elapsed().as_secs_f64() * 1e3;
            let det = pool
                .install(|| detect(&mesh, &params))
                .with_context(|| format!("{}: detection failed", path.display()))?;
            let total = t0.elapsed().as_secs_f64() * 1e3;
            let t = det.timings;
            samples.push([
                read, t.harris, t.geodesic, t.mds, t.cluster, t.extract, total, t.simplify,
            ]);
            last = (
                mesh.num_vertices(),
                det.keypoints.len(),
                det.components.len(),
                det.geodesic_vertices,
            );
        }
        let col = |i: usize| median(samples.iter().map(|s| s[i]).collect());
        rows.push(Row {
            mesh: path.display().to_string(),
            vertices: last.0,
            keypoints: last.1,
            components: last.2,
            geodesic_vertices: last.3,
            read_ms: col(0),
            harris_ms: col(1),
            geodesic_ms: col(2),
            simplify_ms: col(7),
            mds_ms: col(3),
            cluster_ms: col(4),
            extract_ms: col(5),
            total_ms: col(6),
        });
        eprintln!("{}: done", path.display());
    }
    if args.json {
        output::print_json(&rows)?;
        return Ok(ExitCode::SUCCESS);
    }
    let mut s = String::new();
    writeln!(
        s,
        "preset {}, {threads} threads, median of {runs} runs, times in ms; geodesic: {}\n",
        args.detect.detection_preset(),
        if params.geodesic.proxy_vertices == 0 {
            format!(
                "full mesh, corners ≥ {}° split",
                params.geodesic.min_split_angle_degrees
            )
        } else {
            format!(
                "proxy of ≤ {} vertices, corners ≥ {}° split",
                params.geodesic.proxy_vertices, params.geodesic.min_split_angle_degrees
            )
        }
    )?;
    writeln!(
        s,
        "| mesh | vertices | keypoints | components | fronts on | read | harris | geodesic (simplify) | mds | cluster | extract | total |"
    )?;
    writeln!(
        s,
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    )?;
    for r in &rows {
        let name = std::path::Path::new(&r.mesh)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| r.mesh.clone());
        writeln!(
            s,
            "| {name} | {} | {} | {} | {} | {:.0} | {:.0} | {:.0} ({:.0}) | {:.0} | {:.1} | {:.1} | {:.0} |",
            r.vertices,
            r.keypoints,
            r.components,
            r.geodesic_vertices,
            r.read_ms,
            r.harris_ms,
            r.geodesic_ms,
            r.simplify_ms,
            r.mds_ms,
            r.cluster_ms,
            r.extract_ms,
            r.total_ms
        )?;
    }
    output::print_text(&s)?;
    Ok(ExitCode::SUCCESS)
}
