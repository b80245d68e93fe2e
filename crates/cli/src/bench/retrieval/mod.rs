//! `keycomp bench retrieval`: retrieval quality of a labelled collection, key-components against
//! two baselines, the D2 shape distribution and an FPFH bag of words, on whole-shape and partial
//! queries.
//!
//! **Key-components** go through the product path: every collection file is analysed by
//! [`keycomp::record_of`], the function `keycomp index add` uses, with the same
//! detection options ([`DetectArgs::retrieval_params`], the same defaults, including the
//! scaling of N for small meshes), the records are written to a fresh on-disk index in
//! `OUT/index` (opened by [`crate::progress::open_writer`], as `index add` does), and each query is ranked by `keycomp_retrieval::rank` over that
//! index, as `keycomp query` does. A partial query is written to `OUT/fragments` as an OFF file
//! and analysed as `keycomp query` analyses a file given to it ([`keycomp::records_as`] with
//! [`keycomp::Role::Query`]: scale-free, a fragment is described under two scale hypotheses
//! and ranked by `keycomp_retrieval::rank_hypotheses`); so is a whole shape with a boundary
//! queried whole. Shapes `rank` does not return (no part among the nearest
//! neighbours of a query part) follow in a seeded random order ([`complete_ranking`]).
//!
//! **Baselines** are a descriptor per mesh and a distance between descriptors ([`Baseline`]),
//! computed on the same queries (a fragment's descriptors from the fragment mesh that is written
//! and indexed for key-components):
//!
//! * **D2** (Osada et al. 2002, [`keycomp_bench::retrieval::d2`]): L1 distance between
//!   histograms.
//! * **FPFH BoW** and **FPFH BoW units** (Rusu et al. 2009,
//!   [`keycomp_bench::retrieval::fpfh`]): FPFHs of 3,000 points sampled on each mesh, a
//!   256-word k-means codebook fitted on the collection's features, tf-idf weighted histograms
//!   of words, cosine distance. The neighbourhood radius is 0.075·√A with A the mesh's own area
//!   ("FPFH BoW", scale-free) or the median area of the collection's shapes ("FPFH BoW units":
//!   one radius in file units for every shape and fragment, so a fragment keeps its source's
//!   scale). The collection's points are sampled once and described at both radii; each mode
//!   has its own codebook and idf, fitted before any fragment is cut.
//!
//! **Cache.** Records are cached in `OUT/cache` (or `--cache`) as JSON, keyed by a hash of the
//! file's content, the detection parameters, the role (shape or query) and the running
//! executable's bytes ([`keycomp_bench::cache`], the benchmarks' one cache rule): a rebuilt
//! binary (whose detection may have changed) never reuses an old entry, and a re-run of the
//! same binary skips detection. Entries are written atomically; an unreadable entry is
//! recomputed.
//!
//! **External queries** (`--queries DIR --truth CSV`): files from elsewhere (real range scans,
//! point clouds, meshes at another resolution), each named in the CSV with its source shape in
//! the collection, are ranked as `keycomp query` ranks them and by every baseline (which
//! describe the file's triangles, or a point cloud's canonical surface), and measured as the
//! query set `external` with the same tables as the cut fragments.
//!
//! The measures are documented in [`keycomp_bench::retrieval::metrics`].

mod answer;
mod baselines;
mod cache;
mod collection;
mod external;
mod partial;
mod repeatability;
mod report;
mod results;
mod setup;
mod whole;

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use keycomp_mesh::Format;

use crate::args::DetectArgs;
use crate::output;
use answer::Setting;
use cache::RecordCache;
use collection::Collection;
use report::{Times, report_text};
use results::{Results, query_set};
use setup::Setup;

pub const EXAMPLES: &str = "Examples:
  keycomp bench retrieval --collection ../shared/data/tosca
  keycomp bench retrieval --collection ../shared/data/faust --class-from-name 'tr_reg_\\d(\\d)\\d' --out bench-out/retrieval-faust-subject
  keycomp bench retrieval --collection my-shapes --labels classes.csv --partial ball,scan --queries 50 --seed 3
  keycomp bench retrieval --collection ../shared/data/tosca --detect \"--preset kc2\" --partial none
  keycomp bench retrieval --collection shapes --labels classes.csv --queries scans/ --truth truth.csv --partial none

Ranks the collection for every whole shape (left out of its own ranking) and for partial
queries cut from it (ball: geodesic ball, plane: plane cut, scan: one simulated range-scan
view; each keeps 20-60 % of the area, drawn per query), once by key-components (detection and
description as `keycomp index add` does, an on-disk index, `keycomp query`'s ranking), by the
D2 shape distribution, and by an FPFH bag of words (3,000 sampled points, FPFH at radius
0.075*sqrt(area), a 256-word k-means codebook of the collection, tf-idf, cosine), once with
each mesh's own area ('FPFH BoW', scale-free) and once with the collection's median area
('FPFH BoW units', file units: fragments keep their source's scale). Prints NN, FT, ST, E,
DCG and mAP (Princeton Shape Benchmark definitions) and, for partial queries, the mean rank of
the source shape and how often it is first, among the first three, and ahead of every shape
of another class ('source ahead': `--partial plane --area 0.5,0.5` measures halves). With
--queries DIR --truth CSV (lines query,source[,class]), the files of DIR named there are one
more query set, 'external' (real scans, point clouds, other tessellations). Writes
OUT/results.json, OUT/pr-<queries>.svg (precision-recall), OUT/fragments/*.off and OUT/index;
detections are cached in OUT/cache.";

/// Arguments of `keycomp bench retrieval`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Folder of mesh files (.off, .obj, .ply, .stl, .gltf, .glb; searched recursively).
    #[arg(long, value_name = "DIR")]
    pub collection: PathBuf,
    /// Classes from a CSV file of `file,class` lines (file name, stem or path relative to the
    /// collection).
    #[arg(long, value_name = "CSV", conflicts_with = "class_from_name")]
    pub labels: Option<PathBuf>,
    /// Classes from the file stems: the first capture group of this regular expression (or its
    /// whole match) [default: ^(\D+), the name before the first digit].
    #[arg(long, value_name = "REGEX")]
    pub class_from_name: Option<String>,
    /// Partial query kinds: ball, plane, scan, or none (whole-shape queries only); repeat or
    /// separate with commas [default: ball,plane,scan].
    #[arg(long, value_name = "KIND", num_args = 1.., value_delimiter = ',')]
    pub partial: Vec<String>,
    /// A number: partial queries per kind [default: one per collection shape], their sources
    /// drawn without repetition until every shape has been used once. A folder: external
    /// queries (real scans, point clouds, any file keycomp reads), each named with its source
    /// shape in --truth, measured as one more query set ('external') beside the others (a
    /// folder named like a number: write it ./50).
    #[arg(long, value_name = "N|DIR", value_parser = parse_queries)]
    pub queries: Option<Queries>,
    /// With --queries DIR: the ground truth, a CSV file of `query,source[,class]` lines: the
    /// query file (name, stem or path relative to DIR), its source in the collection (name,
    /// stem or path relative to it), and optionally its class (default: the source's). One
    /// query per line; files of DIR not named are not queried.
    #[arg(long, value_name = "CSV")]
    pub truth: Option<PathBuf>,
    /// Seed of everything random (fragment sources, centres, directions and fractions; the
    /// order of unranked shapes; D2 and FPFH sampling, the FPFH codebook).
    #[arg(long, default_value_t = 0, value_name = "S")]
    pub seed: u64,
    /// Range of the area fraction a fragment keeps, drawn uniformly per query.
    #[arg(long, default_value = "0.2,0.6", value_name = "MIN,MAX", value_parser = parse_range)]
    pub area: (f64, f64),
    /// Point pairs sampled per D2 histogram.
    #[arg(long, default_value_t = 1 << 18, value_name = "N")]
    pub d2_pairs: usize,
    /// Output folder.
    #[arg(long, default_value = "bench-out/retrieval", value_name = "DIR")]
    pub out: PathBuf,
    /// Cache of detections [default: OUT/cache].
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
    /// Length unit of key-component description: scale-free (each mesh and fragment scaled to
    /// unit area) or file (one unit for every shape and fragment, the square root of the
    /// collection's median area: fragments keep their source's scale), as `keycomp index add
    /// --units` records it.
    #[arg(long, default_value = "scale-free", value_parser = ["scale-free", "file"], value_name = "MODE")]
    pub units: String,
    /// The surface analysed, as `keycomp index add --surface` records it: as-read (the meshes
    /// and fragments as they are) or canonical (each remade as one surface of about 10,000
    /// vertices).
    #[arg(long, default_value = "as-read", value_parser = ["as-read", "canonical"], value_name = "MODE")]
    pub surface: String,
    /// Ablation: the canonical surface's vertex budget, with `--surface canonical` [default:
    /// 10,000].
    #[arg(long, value_name = "N")]
    pub surface_vertices: Option<usize>,
    /// Ablation: patch radii of the description (comma-separated; 'none' for no patches)
    /// [default: the description's default levels].
    #[arg(long, value_name = "R,R,...")]
    pub levels: Option<String>,
    /// Ablation: most patches per level [default: the description's].
    #[arg(long, value_name = "N")]
    pub patches: Option<usize>,
    /// Ablation: no whole-surface part.
    #[arg(long)]
    pub no_whole: bool,
    /// Ablation: how far the fronts from patch centres run (`DescribeParams::layout_reach`, in
    /// the length unit; 'none' for the whole mesh) [default: the description's].
    #[arg(long, value_name = "R")]
    pub layout_reach: Option<String>,
    /// Key-components only: leave out D2 and the FPFH bags of words (quicker ablations; the
    /// tables then have no baseline column).
    #[arg(long)]
    pub no_baselines: bool,
    /// Ablation: the size check's tolerance (`MatchParams::area_tolerance`; 0 turns it off)
    /// [default: the matching's].
    #[arg(long, value_name = "T")]
    pub area_tolerance: Option<f64>,
    /// Ablation: the layout check's tolerance (`MatchParams::layout_tolerance`, ≥ 1)
    /// [default: the matching's].
    #[arg(long, value_name = "T")]
    pub layout_tolerance: Option<f64>,
    /// Ablation: the descriptor distance at which similarity reaches 0
    /// (`MatchParams::max_distance`) [default: the matching's].
    #[arg(long, value_name = "D")]
    pub max_distance: Option<f32>,
    /// Ablation: how much the pose check weighs (`MatchParams::pose_weight`, in [0, 1])
    /// [default: the matching's].
    #[arg(long, value_name = "W", value_parser = crate::args::unit_weight)]
    pub pose_weight: Option<f64>,
    /// Ablation: the pose check's tolerance (`MatchParams::pose_tolerance`, ≥ 1) [default: the
    /// matching's].
    #[arg(long, value_name = "T")]
    pub pose_tolerance: Option<f64>,
    /// Ablation: how much geometric verification weighs (`MatchParams::verify_weight`, in
    /// [0, 1]) for every query [default: automatic, `keycomp_retrieval::verify_weight_for`:
    /// 0.5 for a fragment (1 in file units or on canonical surfaces), 0 for a whole shape].
    #[arg(long, value_name = "W", value_parser = crate::args::unit_weight)]
    pub verify_weight: Option<f64>,
    /// Ablation: geometric verification's tolerance (`MatchParams::verify_tolerance`, > 0)
    /// [default: the matching's].
    #[arg(long, value_name = "D")]
    pub verify_tolerance: Option<f64>,
    /// Ablation: weigh query parts by their inverse frequency in the index
    /// (`MatchParams::idf`).
    #[arg(long)]
    pub idf: bool,
    /// Ablation: leave out parts that reach a mesh's boundary
    /// (`DescribeParams::complete_only`).
    #[arg(long)]
    pub complete_only: bool,
    /// Also measure partial repeatability: for every fragment, the source's parts lying mostly
    /// inside it against the fragment's own parts (analyses every source and fragment once
    /// more, with their vertex sets).
    #[arg(long)]
    pub repeatability: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Detection options, as `keycomp index add` takes them (e.g. "--preset kc2 --n 20");
    /// without it, `index add`'s defaults.
    #[arg(long, value_name = "OPTIONS", allow_hyphen_values = true)]
    pub detect: Option<String>,
}

/// Parses detection options with the same definitions (and defaults) as `keycomp index add`.
#[derive(Debug, clap::Parser)]
#[command(name = "--detect", no_binary_name = true, disable_help_flag = true)]
struct DetectOptions {
    #[command(flatten)]
    detect: DetectArgs,
}

fn detect_args(options: Option<&str>) -> Result<DetectArgs> {
    use clap::Parser as _;
    let words = options.unwrap_or("").split_whitespace();
    DetectOptions::try_parse_from(words)
        .map(|o| o.detect)
        .map_err(|e| anyhow::anyhow!("--detect: {}", e.render().to_string().trim()))
}

/// What `--queries` gives: a count of partial queries per kind, or a folder of external ones.
#[derive(Debug, Clone, PartialEq)]
pub enum Queries {
    /// Partial queries per kind.
    PerKind(usize),
    /// A folder of query files, named in `--truth`.
    Folder(PathBuf),
}

fn parse_queries(s: &str) -> Result<Queries, String> {
    if !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()) {
        s.parse()
            .map(Queries::PerKind)
            .map_err(|_| format!("'{s}': too large a count"))
    } else {
        Ok(Queries::Folder(PathBuf::from(s)))
    }
}

fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let bad = || format!("'{s}': expected MIN,MAX with 0 < MIN <= MAX <= 1, e.g. 0.2,0.6");
    let (a, b) = s.split_once(',').ok_or_else(bad)?;
    let a: f64 = a.trim().parse().map_err(|_| bad())?;
    let b: f64 = b.trim().parse().map_err(|_| bad())?;
    if a > 0.0 && a <= b && b <= 1.0 {
        Ok((a, b))
    } else {
        Err(bad())
    }
}

/// Files keycomp reads (meshes, scans, point clouds) below `dir`, sorted by path; `option`
/// names the folder's option in errors.
fn list_meshes(dir: &Path, option: &str) -> Result<Vec<PathBuf>> {
    if !dir.is_dir() {
        bail!("{}: not a folder ({option})", dir.display());
    }
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in fs::read_dir(&d).with_context(|| format!("{}: cannot read folder", d.display()))? {
            let p = e
                .with_context(|| format!("{}: cannot read folder", d.display()))?
                .path();
            if p.is_dir() {
                stack.push(p);
            } else if Format::from_path(&p).is_ok() {
                out.push(p);
            }
        }
    }
    out.sort();
    Ok(out)
}

/// A seed for one random decision, from the run's seed, a tag and an index.
fn sub_seed(seed: u64, tag: &str, i: u64) -> u64 {
    let mut b = Vec::with_capacity(tag.len() + 16);
    b.extend_from_slice(&seed.to_le_bytes());
    b.extend_from_slice(tag.as_bytes());
    b.extend_from_slice(&i.to_le_bytes());
    xxhash_rust::xxh3::xxh3_64(&b)
}

pub fn run(args: Args) -> Result<ExitCode> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        builder = builder.num_threads(n);
    }
    let pool = builder.build().context("cannot start the thread pool")?;
    pool.install(|| run_in_pool(args))
}

/// The run: the collection analysed and indexed, the baselines fitted, then the query sets
/// (whole shapes, fragments of each kind, external files) measured, written and printed.
fn run_in_pool(args: Args) -> Result<ExitCode> {
    let t0 = Instant::now();
    let setup = Setup::new(&args)?;
    let n = setup.files.len();
    output::create_output_folder(&args.out)?;
    let cache = RecordCache::new(
        args.cache.clone().unwrap_or_else(|| args.out.join("cache")),
        &setup.params,
    );
    let Collection {
        records,
        hists,
        points,
        hits,
    } = collection::analyse(
        &setup.files,
        &setup.params,
        &cache,
        !args.no_baselines,
        &setup.d2_params,
        &setup.fpfh_params,
    )?;
    let detect_s = t0.elapsed().as_secs_f64();
    let t_fit = Instant::now();
    let (baselines, fpfh_scales) = baselines::fit(
        args.no_baselines,
        &setup.files,
        hists,
        points,
        setup.d2_params,
        &setup.fpfh_params,
    )?;
    let fit_s = t_fit.elapsed().as_secs_f64();
    let (reader, index_of) =
        collection::fresh_index(&args.out, &setup.params, &records, &setup.files)?;
    let setting = Setting {
        args: &args,
        cache: &cache,
        params: &setup.params,
        reader: &reader,
        index_of: &index_of,
        match_params: &setup.match_params,
        baselines: &baselines,
        classes: &setup.classes,
        names: &setup.names,
        files: &setup.files,
    };
    let methods: Vec<(&str, &str)> = baselines.iter().map(|b| (b.label, b.key)).collect();
    let mut sets = vec![query_set(
        "whole",
        whole::queries(&setting, &records)?,
        &methods,
    )];
    let (by_kind, repeatability) = partial::queries(&setting, &setup.kinds)?;
    for (kind, results) in by_kind {
        sets.push(query_set(kind.name(), results, &methods));
    }
    if let Some(truth) = &setup.external {
        sets.push(query_set(
            "external",
            external::queries(&setting, truth)?,
            &methods,
        ));
    }
    let mut class_counts: BTreeMap<String, usize> = BTreeMap::new();
    for c in &setup.classes {
        *class_counts.entry(c.clone()).or_default() += 1;
    }
    let results = Results {
        collection: args.collection.display().to_string(),
        shapes: n,
        classes: class_counts,
        seed: args.seed,
        fraction_range: args.area,
        detect_params: setup.params.detect,
        describe_params: setup.params.describe,
        match_params: setup.match_params,
        verify_weight: args.verify_weight,
        d2_params: setup.d2_params,
        fpfh_params: setup.fpfh_params,
        fpfh_scales: fpfh_scales.iter().map(|&(_, k, s)| (k, s)).collect(),
        shapes_without_components: records
            .iter()
            .zip(&setup.names)
            .filter(|(r, _)| r.components.is_empty())
            .map(|(_, s)| s.clone())
            .collect(),
        components_per_shape: records.iter().map(|r| r.components.len()).sum::<usize>() as f64
            / n as f64,
        query_sets: sets,
        partial_repeatability: repeatability::repeatability_rows(&repeatability, args.area),
    };
    report::write(&results, &args, &methods)?;
    let times = Times {
        detect: detect_s,
        fit: fit_s,
        total: t0.elapsed().as_secs_f64(),
    };
    let text = report_text(
        &results,
        &args,
        &setup.detect.retrieval_preset().to_string(),
        hits,
        &methods,
        &times,
    )?;
    output::print_text(&text)?;
    Ok(ExitCode::SUCCESS)
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}
