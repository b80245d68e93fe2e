//! `keycomp bench retrieval`: retrieval quality of a labelled collection, key-components against
//! two baselines, the D2 shape distribution and an FPFH bag of words, on whole-shape and partial
//! queries (issue 6).
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
//! executable's bytes: a rebuilt
//! binary (whose detection may have changed) never reuses an old entry, and a re-run of the
//! same binary skips detection. Entries are written atomically (temporary file + rename); an
//! unreadable entry is recomputed.
//!
//! **External queries** (`--queries DIR --truth CSV`): files from elsewhere (real range scans,
//! point clouds, meshes at another resolution), each named in the CSV with its source shape in
//! the collection, are ranked as `keycomp query` ranks them and by every baseline (which
//! describe the file's triangles, or a point cloud's canonical surface), and measured as the
//! query set `external` with the same tables as the cut fragments.
//!
//! The measures are documented in [`keycomp_bench::retrieval::metrics`].

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use keycomp_bench::retrieval::d2::{D2Params, d2, l1};
use keycomp_bench::retrieval::fpfh::{
    BagOfWords, FpfhParams, FpfhScale, OrientedPoints, cosine_distance, features_of,
    sample_oriented,
};
use keycomp_bench::retrieval::labels::{
    DEFAULT_CLASS_REGEX, Truth, classes_from_csv, classes_from_names, truth_from_csv,
};
use keycomp_bench::retrieval::metrics::{QueryScores, Summary, score, summarize};
use keycomp_bench::retrieval::{complete_ranking, pr_svg, rank_by_distance};
use keycomp_bench::svg::Curve;
use keycomp_components::DetectParams;
use keycomp_describe::{DIM, DescribeParams, Units};
use keycomp_fragment::{PartialKind, cut_fragment};
use keycomp_index::{ContentHash, ShapeRecord};
use keycomp_mesh::{Mesh, read_mesh};
use keycomp_retrieval::{MatchParams, rank_hypotheses};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::args::DetectArgs;
use crate::output;
use crate::progress::{open_writer, progress};
use keycomp::Profile;
use keycomp::analyse;
use keycomp::collection::Reader;
use keycomp::collection::{areas_of, unit_from_areas};
use keycomp::{Role, records_as};

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
            } else if keycomp_mesh::Format::from_path(&p).is_ok() {
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

/// Records cached by content, detection parameters and executable (see the module docs).
struct RecordCache {
    dir: Option<PathBuf>,
    salt: String,
}

impl RecordCache {
    fn new(dir: PathBuf, params: &Profile) -> RecordCache {
        let exe = std::env::current_exe()
            .ok()
            .and_then(|p| fs::read(p).ok())
            .map(|b| xxhash_rust::xxh3::xxh3_128(&b));
        // A cache that cannot be made only costs time.
        let made = fs::create_dir_all(&dir).is_ok();
        match exe {
            Some(h) if made => RecordCache {
                dir: Some(dir),
                salt: format!(
                    "{h:032x}|{}",
                    serde_json::to_string(params).unwrap_or_default()
                ),
            },
            _ => {
                eprintln!(
                    "warning: cannot read the running executable or create {}; detections are \
                     not cached",
                    dir.display()
                );
                RecordCache {
                    dir: None,
                    salt: String::new(),
                }
            }
        }
    }

    fn path(&self, hash: &ContentHash, role: Role) -> Option<PathBuf> {
        let dir = self.dir.as_ref()?;
        let key = xxhash_rust::xxh3::xxh3_128(format!("{hash}|{role:?}|{}", self.salt).as_bytes());
        Some(dir.join(format!("{key:032x}.json")))
    }

    /// The records of `path` (content `hash`) analysed as `role` (one per description), from
    /// the cache or computed (and stored).
    fn records(
        &self,
        path: &Path,
        hash: ContentHash,
        params: &Profile,
        role: Role,
    ) -> Result<(Vec<ShapeRecord<DIM>>, bool)> {
        let entry = self.path(&hash, role);
        let cached = entry
            .as_ref()
            .and_then(|e| fs::read(e).ok())
            .and_then(|b| serde_json::from_slice::<Vec<ShapeRecord<DIM>>>(&b).ok())
            .filter(|rs| !rs.is_empty() && rs.iter().all(|r| r.content_hash == hash));
        if let Some(mut rs) = cached {
            for r in &mut rs {
                r.path = path.to_path_buf();
                r.canonical_path = keycomp_index::canonical_path(path);
            }
            return Ok((rs, true));
        }
        let r = records_as(path, hash, params, role)?;
        if let (Some(e), Ok(bytes)) = (entry, serde_json::to_vec(&r)) {
            // a cache that cannot be written only costs time
            let _ = output::write_bytes(&e, &bytes);
        }
        Ok((r, false))
    }
}

/// How a [`Baseline`] describes a mesh.
type Describe = Box<dyn Fn(&Mesh) -> Result<Vec<f64>> + Send + Sync>;

/// A baseline method: one descriptor per mesh and a distance between two descriptors (smaller
/// is more alike). Key-components are not one: they go through the product's index and ranking.
struct Baseline {
    /// Row label in the tables and curve label in the PR plots.
    label: &'static str,
    /// Key in `results.json`.
    key: &'static str,
    /// Descriptors of the collection's shapes, in collection order.
    collection: Vec<Vec<f64>>,
    /// The descriptor of another mesh (a fragment).
    describe: Describe,
    /// The distance between two descriptors.
    distance: fn(&[f64], &[f64]) -> f64,
}

impl Baseline {
    /// The collection from nearest to farthest from `query` (ties by index), without `exclude`.
    fn ranking(&self, query: &[f64], exclude: Option<usize>) -> Vec<usize> {
        let d: Vec<f64> = self
            .collection
            .iter()
            .map(|c| (self.distance)(query, c))
            .collect();
        rank_by_distance(&d, exclude)
    }
}

/// The FPFH bag-of-words baseline at one radius rule: a codebook and idf fitted on the
/// collection's points (sampled once, `points[i]` for shape `i`), the collection's tf-idf
/// vectors, and the description of other meshes with the same model.
fn fpfh_baseline(
    label: &'static str,
    key: &'static str,
    points: &[OrientedPoints],
    files: &[PathBuf],
    params: &FpfhParams,
    scale: FpfhScale,
) -> Result<Baseline> {
    let features: Vec<_> = points
        .par_iter()
        .zip(files)
        .map(|(p, f)| {
            features_of(p, params, scale).with_context(|| format!("{}: {label}", f.display()))
        })
        .collect::<Result<_>>()?;
    let (model, collection) = BagOfWords::fit(&features, params, scale)
        .with_context(|| format!("{label}: cannot fit the codebook"))?;
    Ok(Baseline {
        label,
        key,
        collection,
        describe: Box::new(move |m: &Mesh| Ok(model.describe(m)?)),
        distance: cosine_distance,
    })
}

/// A query's ranking scored for one method.
#[derive(Debug, Serialize)]
struct MethodResult {
    /// Shapes the method returned before the random tail (every shape for a baseline).
    returned: usize,
    /// 1-based rank of the source shape (partial queries).
    #[serde(skip_serializing_if = "Option::is_none")]
    source_rank: Option<usize>,
    /// Whether the source shape is ranked ahead of every shape of another class (partial
    /// queries): with a score per shape, the source scores higher than any of them.
    #[serde(skip_serializing_if = "Option::is_none")]
    source_ahead: Option<bool>,
    /// The first five results (file stems).
    top: Vec<String>,
    nn: Option<f64>,
    ft: Option<f64>,
    st: Option<f64>,
    e: Option<f64>,
    dcg: Option<f64>,
    ap: Option<f64>,
    #[serde(skip)]
    scores: Option<QueryScores>,
}

#[derive(Debug, Serialize)]
struct QueryResult {
    query: String,
    class: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    source: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    target_fraction: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    fraction: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    cut: Option<String>,
    /// Key-components of the query.
    components: usize,
    /// Why the query has no key-component record (detection failed), if so.
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<String>,
    key_components: MethodResult,
    /// One result per baseline, by [`Baseline::key`] (`d2`, `fpfh_bow`, `fpfh_bow_units`).
    #[serde(flatten)]
    baselines: BTreeMap<&'static str, MethodResult>,
    /// A seeded random ranking, the chance level of every measure (summarised only).
    #[serde(skip)]
    random: MethodResult,
}

impl QueryResult {
    /// The result of one method: key-components for `None`, else the baseline with that key.
    fn method(&self, key: Option<&str>) -> &MethodResult {
        key.map_or(&self.key_components, |k| &self.baselines[k])
    }
}

#[derive(Debug, Serialize)]
struct MethodSummary {
    #[serde(flatten)]
    summary: Summary,
    /// Queries for which the method returned no shape (all ranks random; every query for the
    /// random ranking).
    empty: usize,
    /// Mean 1-based rank of the source shape (partial queries).
    #[serde(skip_serializing_if = "Option::is_none")]
    mean_source_rank: Option<f64>,
    /// Partial queries whose source shape is ranked first.
    #[serde(skip_serializing_if = "Option::is_none")]
    source_first: Option<usize>,
    /// Partial queries whose source shape is among the first three.
    #[serde(skip_serializing_if = "Option::is_none")]
    source_top3: Option<usize>,
    /// Partial queries whose source shape is ranked ahead of every shape of another class.
    #[serde(skip_serializing_if = "Option::is_none")]
    source_ahead: Option<usize>,
}

#[derive(Debug, Serialize)]
struct QuerySet {
    name: String,
    queries: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    mean_fraction: Option<f64>,
    key_components: MethodSummary,
    /// One summary per baseline, by [`Baseline::key`].
    #[serde(flatten)]
    baselines: BTreeMap<&'static str, MethodSummary>,
    /// A seeded random ranking of the same queries: the chance level.
    random: MethodSummary,
    /// Every method on the queries key-components answer (return at least one shape for).
    answered: Answered,
    results: Vec<QueryResult>,
}

#[derive(Debug, Serialize)]
struct Answered {
    key_components: MethodSummary,
    #[serde(flatten)]
    baselines: BTreeMap<&'static str, MethodSummary>,
}

#[derive(Debug, Serialize)]
struct Results {
    collection: String,
    shapes: usize,
    classes: BTreeMap<String, usize>,
    seed: u64,
    fraction_range: (f64, f64),
    detect_params: DetectParams,
    describe_params: DescribeParams,
    match_params: MatchParams,
    /// Geometric verification's weight as given (`--verify-weight`); `None`: automatic, by
    /// whether the query has a boundary (`keycomp_retrieval::verify_weight_for`).
    verify_weight: Option<f64>,
    d2_params: D2Params,
    fpfh_params: FpfhParams,
    /// The radius rule of each FPFH baseline (for "FPFH BoW units", the collection's median
    /// surface area in file units squared).
    fpfh_scales: BTreeMap<&'static str, FpfhScale>,
    /// Collection shapes without key-components (never returned by key-component queries).
    shapes_without_components: Vec<String>,
    components_per_shape: f64,
    query_sets: Vec<QuerySet>,
    /// Partial repeatability per query kind and third of the kept-area range (with
    /// `--repeatability`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    partial_repeatability: Vec<RepeatabilityRow>,
}

/// One row of the partial-repeatability table: the parts of every fragment of one kind and
/// kept-area bin pooled (see [`Repeatability`]).
#[derive(Debug, Serialize)]
struct RepeatabilityRow {
    kind: &'static str,
    area: (f64, f64),
    fragments: usize,
    kc_parts: usize,
    kc_overlap: f64,
    patch_parts: usize,
    patch_overlap: f64,
}

fn repeatability_rows(
    all: &[(&'static str, f64, Repeatability)],
    range: (f64, f64),
) -> Vec<RepeatabilityRow> {
    let mut rows = Vec::new();
    let kinds: Vec<&'static str> = {
        let mut k: Vec<_> = all.iter().map(|r| r.0).collect();
        k.dedup();
        k
    };
    let step = (range.1 - range.0) / 3.0;
    for kind in kinds {
        for b in 0..3 {
            let lo = range.0 + step * b as f64;
            let hi = if b == 2 { f64::INFINITY } else { lo + step };
            let lo = if b == 0 { f64::NEG_INFINITY } else { lo };
            let sel: Vec<&Repeatability> = all
                .iter()
                .filter(|r| r.0 == kind && r.1 >= lo && r.1 < hi)
                .map(|r| &r.2)
                .collect();
            if sel.is_empty() {
                continue;
            }
            let kc_parts: usize = sel.iter().map(|r| r.kc_parts).sum();
            let patch_parts: usize = sel.iter().map(|r| r.patch_parts).sum();
            let pooled = |f: &dyn Fn(&Repeatability) -> f64, n: usize| {
                if n > 0 {
                    sel.iter().map(|r| f(r)).sum::<f64>() / n as f64
                } else {
                    0.0
                }
            };
            rows.push(RepeatabilityRow {
                kind,
                area: (range.0 + step * b as f64, range.0 + step * (b + 1) as f64),
                fragments: sel.len(),
                kc_parts,
                kc_overlap: pooled(&|r| r.kc_overlap * r.kc_parts as f64, kc_parts),
                patch_parts,
                patch_overlap: pooled(&|r| r.patch_overlap * r.patch_parts as f64, patch_parts),
            });
        }
    }
    rows
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

/// Scores one ranking (`order` of collection indices) for a query of `class`.
fn method_result(
    order: &[usize],
    returned: usize,
    class: &str,
    classes: &[String],
    names: &[String],
    source: Option<usize>,
) -> MethodResult {
    let rel: Vec<bool> = order.iter().map(|&j| classes[j] == class).collect();
    let scores = score(&rel);
    MethodResult {
        returned,
        source_rank: source.and_then(|s| order.iter().position(|&j| j == s).map(|p| p + 1)),
        source_ahead: source.map(|s| {
            let at = order.iter().position(|&j| j == s).unwrap_or(usize::MAX);
            let other = order
                .iter()
                .position(|&j| classes[j] != class)
                .unwrap_or(usize::MAX);
            at < other
        }),
        top: order.iter().take(5).map(|&j| names[j].clone()).collect(),
        nn: scores.as_ref().map(|s| s.nn),
        ft: scores.as_ref().map(|s| s.ft),
        st: scores.as_ref().map(|s| s.st),
        e: scores.as_ref().map(|s| s.e),
        dcg: scores.as_ref().map(|s| s.dcg),
        ap: scores.as_ref().map(|s| s.ap),
        scores,
    }
}

fn summarize_method(
    results: &[&QueryResult],
    pick: impl Fn(&QueryResult) -> &MethodResult,
) -> MethodSummary {
    let scores: Vec<Option<QueryScores>> = results.iter().map(|r| pick(r).scores.clone()).collect();
    let classes: Vec<&str> = results.iter().map(|r| r.class.as_str()).collect();
    let ranks: Vec<usize> = results.iter().filter_map(|r| pick(r).source_rank).collect();
    MethodSummary {
        summary: summarize(&scores, &classes),
        empty: results.iter().filter(|r| pick(r).returned == 0).count(),
        mean_source_rank: (!ranks.is_empty())
            .then(|| ranks.iter().sum::<usize>() as f64 / ranks.len() as f64),
        source_first: (!ranks.is_empty()).then(|| ranks.iter().filter(|&&r| r == 1).count()),
        source_top3: (!ranks.is_empty()).then(|| ranks.iter().filter(|&&r| r <= 3).count()),
        source_ahead: (!ranks.is_empty()).then(|| {
            results
                .iter()
                .filter(|r| pick(r).source_ahead == Some(true))
                .count()
        }),
    }
}

/// Partial repeatability of one fragment: for key-components (level 0) and for patches (levels
/// 1 to L, the whole surface left out), the source's parts with at least half of their area inside the fragment, and the
/// mean over them of the best overlap (area IoU on the fragment, as in the repeatability
/// benchmark) between the part restricted to the fragment and a part the fragment's own
/// analysis finds (of the same kind: key-component or patch, any level).
#[derive(Debug, Clone, Copy, Default, Serialize)]
struct Repeatability {
    kc_overlap: f64,
    kc_parts: usize,
    patch_overlap: f64,
    patch_parts: usize,
}

fn partial_repeatability(
    source: &Path,
    fragment: &Path,
    original: &[u32],
    profile: &Profile,
) -> Result<Repeatability> {
    let s = analyse(source, profile)?;
    let f = keycomp::analyse_as(fragment, profile, Role::Query)?;
    let src_areas = keycomp_mesh::geometry::vertex_areas(&s.mesh);
    let frag_areas = keycomp_mesh::geometry::vertex_areas(&f.mesh);
    let mut to_frag = vec![u32::MAX; s.mesh.num_vertices()];
    for (i, &o) in original.iter().enumerate() {
        if let Some(t) = to_frag.get_mut(o as usize) {
            *t = i as u32;
        }
    }
    // key-components are level 0, patches levels 1..=L; the whole surface (L + 1) is neither
    let whole = profile.describe.levels.len() + 1;
    let in_group = move |c: &&keycomp_describe::ComponentDescription, patches: bool| {
        (c.level as usize) < whole && (c.level > 0) == patches
    };
    let group = |patches: bool| -> (f64, usize) {
        let mine: Vec<&[u32]> = f
            .description
            .components
            .iter()
            .filter(|c| in_group(c, patches))
            .map(|c| c.vertices.as_slice())
            .collect();
        let (mut sum, mut count) = (0.0, 0);
        for c in s
            .description
            .components
            .iter()
            .filter(|c| in_group(c, patches))
        {
            let total: f64 = c.vertices.iter().map(|&v| src_areas[v as usize]).sum();
            let inside: Vec<u32> = c
                .vertices
                .iter()
                .map(|&v| to_frag[v as usize])
                .filter(|&t| t != u32::MAX)
                .collect();
            let kept: f64 = c
                .vertices
                .iter()
                .filter(|&&v| to_frag[v as usize] != u32::MAX)
                .map(|&v| src_areas[v as usize])
                .sum();
            if total <= 0.0 || kept < 0.5 * total {
                continue;
            }
            let best = mine
                .iter()
                .map(|m| keycomp_bench::overlap(&frag_areas, &inside, m))
                .fold(0.0, f64::max);
            sum += best;
            count += 1;
        }
        (if count > 0 { sum / count as f64 } else { 0.0 }, count)
    };
    let (kc_overlap, kc_parts) = group(false);
    let (patch_overlap, patch_parts) = group(true);
    Ok(Repeatability {
        kc_overlap,
        kc_parts,
        patch_overlap,
        patch_parts,
    })
}

/// Key-component ranking of the collection for one query, its records one per scale
/// hypothesis (indices into the collection).
fn kc_ranking(
    reader: &Reader,
    records: &[ShapeRecord<DIM>],
    index_of: &HashMap<PathBuf, usize>,
    match_params: &MatchParams,
    verify: Option<f64>,
    canonical: bool,
) -> Result<Vec<usize>> {
    let Some(record) = records.first() else {
        return Ok(Vec::new());
    };
    let match_params = &MatchParams {
        verify_weight: keycomp_retrieval::verify_weight_for(
            record.boundary_vertices as usize,
            match_params.file_units || canonical,
            verify,
        ),
        verify_search: keycomp_retrieval::verify_search_for(canonical),
        ..*match_params
    };
    if record.components.is_empty() {
        return Ok(Vec::new());
    }
    let parts: Vec<_> = records
        .iter()
        .map(|r| {
            (
                r.components
                    .iter()
                    .map(|c| c.descriptor)
                    .collect::<Vec<_>>(),
                keycomp_retrieval::record_areas(r, match_params),
                keycomp_retrieval::record_centres(r, match_params),
            )
        })
        .collect();
    let views: Vec<_> = records
        .iter()
        .zip(&parts)
        .map(
            |(r, (descs, areas, centres))| keycomp_retrieval::ShapeView {
                descriptors: descs,
                layout: &r.layout,
                areas,
                centres,
                sample: keycomp_retrieval::record_sample(r, match_params),
            },
        )
        .collect();
    let ranked = rank_hypotheses(reader, &views, index_of.len(), match_params)?;
    Ok(ranked
        .iter()
        .filter_map(|r| index_of.get(&r.path).copied())
        .collect())
}

pub fn run(args: Args) -> Result<ExitCode> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        builder = builder.num_threads(n);
    }
    let pool = builder.build().context("cannot start the thread pool")?;
    pool.install(|| run_in_pool(args))
}

fn run_in_pool(args: Args) -> Result<ExitCode> {
    let t0 = Instant::now();
    let kinds: Vec<PartialKind> = if args.partial.is_empty() {
        PartialKind::ALL.to_vec()
    } else if args.partial.iter().any(|k| k == "none") {
        if args.partial.len() > 1 {
            bail!("--partial none cannot be combined with other kinds");
        }
        Vec::new()
    } else {
        let mut k: Vec<PartialKind> = args
            .partial
            .iter()
            .map(|s| s.parse::<PartialKind>().map_err(anyhow::Error::msg))
            .collect::<Result<_>>()?;
        k.sort();
        k.dedup();
        k
    };
    if args.d2_pairs == 0 {
        bail!("--d2-pairs must be at least 1");
    }
    let files = list_meshes(&args.collection, "--collection")?;
    if files.len() < 2 {
        bail!(
            "{}: found {} mesh, scan or point-cloud file(s) (.off, .obj, .ply, .stl, .gltf, .glb, .xyz, .pts, .pcd); retrieval needs at least 2",
            args.collection.display(),
            files.len()
        );
    }
    let classes = match (&args.labels, &args.class_from_name) {
        (Some(csv), _) => classes_from_csv(&files, &args.collection, csv)?,
        (None, Some(re)) => classes_from_names(&files, re)?,
        (None, None) => classes_from_names(&files, DEFAULT_CLASS_REGEX)?,
    };
    let external = match (&args.queries, &args.truth) {
        (Some(Queries::Folder(dir)), Some(csv)) => {
            let queries = list_meshes(dir, "--queries")?;
            Some(truth_from_csv(
                &queries,
                dir,
                &files,
                &args.collection,
                csv,
            )?)
        }
        (Some(Queries::Folder(dir)), None) => bail!(
            "--queries {}: external queries need --truth CSV (lines query,source[,class])",
            dir.display()
        ),
        (_, Some(_)) => bail!("--truth goes with --queries DIR (a folder of query files)"),
        _ => None,
    };
    let names: Vec<String> = files.iter().map(|f| stem(f)).collect();
    let n = files.len();
    let detect = detect_args(args.detect.as_deref())?;
    // exactly what `keycomp index add` uses with these options
    let mut describe = DescribeParams::default();
    if args.units == "file" {
        describe.units = Units::File {
            length: unit_from_areas(areas_of(&files))?,
        };
    }
    if let Some(l) = &args.levels {
        describe.levels = if l.trim() == "none" {
            Vec::new()
        } else {
            l.split(',')
                .map(|x| x.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| {
                    anyhow::anyhow!("--levels: expected radii like 0.1,0.2 or 'none', got '{l}'")
                })?
        };
    }
    if let Some(p) = args.patches {
        describe.patches_per_level = p;
    }
    describe.whole = !args.no_whole;
    if let Some(r) = &args.layout_reach {
        describe.layout_reach = if r.trim() == "none" {
            None
        } else {
            match r.trim().parse::<f64>() {
                Ok(x) if x.is_finite() && x > 0.0 => Some(x),
                _ => bail!("--layout-reach: expected a positive length or 'none', got '{r}'"),
            }
        };
    }
    describe.complete_only = args.complete_only;
    let mut match_params = MatchParams {
        idf: args.idf,
        file_units: matches!(describe.units, keycomp_describe::Units::File { .. }),
        ..MatchParams::default()
    };
    if let Some(t) = args.area_tolerance {
        match_params.area_tolerance = t;
    }
    if let Some(t) = args.layout_tolerance {
        match_params.layout_tolerance = t;
    }
    if let Some(d) = args.max_distance {
        match_params.max_distance = d;
    }
    if let Some(w) = args.pose_weight {
        match_params.pose_weight = w;
    }
    if let Some(t) = args.pose_tolerance {
        if !(t.is_finite() && t >= 1.0) {
            bail!("--pose-tolerance: expected a factor ≥ 1, got {t}");
        }
        match_params.pose_tolerance = t;
    }
    if let Some(d) = args.verify_tolerance {
        if !(d.is_finite() && d > 0.0) {
            bail!("--verify-tolerance: expected a positive distance, got {d}");
        }
        match_params.verify_tolerance = d;
    }
    if !(match_params.layout_tolerance.is_finite() && match_params.layout_tolerance >= 1.0) {
        bail!(
            "--layout-tolerance: expected a factor ≥ 1, got {}",
            match_params.layout_tolerance
        );
    }
    if !(match_params.max_distance.is_finite() && match_params.max_distance > 0.0) {
        bail!(
            "--max-distance: expected a positive distance, got {}",
            match_params.max_distance
        );
    }
    if !(match_params.area_tolerance.is_finite() && match_params.area_tolerance >= 0.0) {
        bail!(
            "--area-tolerance: expected a factor ≥ 1, or 0 for no check, got {}",
            match_params.area_tolerance
        );
    }
    let surface = keycomp_surface::SurfaceParams {
        vertices: args
            .surface_vertices
            .unwrap_or(keycomp_surface::SurfaceParams::default().vertices),
        ..keycomp_surface::SurfaceParams::default()
    };
    surface.validate()?;
    let params = Profile::with(&detect.retrieval_params(), describe)
        .with_surface((args.surface == "canonical").then_some(surface));
    let d2_params = D2Params {
        pairs: args.d2_pairs,
        seed: sub_seed(args.seed, "d2", 0),
        ..D2Params::default()
    };
    let fpfh_params = FpfhParams {
        seed: sub_seed(args.seed, "fpfh", 0),
        ..FpfhParams::default()
    };
    output::create_output_folder(&args.out)?;
    let cache = RecordCache::new(
        args.cache.clone().unwrap_or_else(|| args.out.join("cache")),
        &params,
    );

    // 1. the collection: index records (product path), D2 histograms, FPFH points
    let bar = progress(n as u64, "collection");
    let analysed: Vec<Result<_>> = files
        .par_iter()
        .map(|p| {
            let r = (|| {
                let hash = ContentHash::of_file(p)?;
                let (recs, hit) = cache.records(p, hash, &params, Role::Indexed)?;
                let rec = recs.into_iter().next().context("no record")?;
                if args.no_baselines {
                    return Ok((rec, hit, None));
                }
                let mesh = read_mesh(p)?.mesh;
                let h = d2(&mesh, &d2_params).with_context(|| format!("{}: D2", p.display()))?;
                let pts = sample_oriented(&mesh, &fpfh_params)
                    .with_context(|| format!("{}: FPFH", p.display()))?;
                Ok((rec, hit, Some((h, pts))))
            })();
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    let mut records = Vec::with_capacity(n);
    let mut hists = Vec::with_capacity(n);
    let mut points = Vec::with_capacity(n);
    let mut hits = 0;
    for (p, r) in files.iter().zip(analysed) {
        let (rec, hit, baseline) = r.with_context(|| format!("{}: cannot analyse", p.display()))?;
        hits += usize::from(hit);
        records.push(rec);
        if let Some((h, pts)) = baseline {
            hists.push(h);
            points.push(pts);
        }
    }
    let detect_s = t0.elapsed().as_secs_f64();

    // the baselines, fitted on the collection before any query
    let t_fit = Instant::now();
    let areas: Vec<f64> = points.iter().map(|p| p.area).collect();
    let fpfh_scales = [
        ("FPFH BoW", "fpfh_bow", FpfhScale::ScaleFree),
        (
            "FPFH BoW units",
            "fpfh_bow_units",
            FpfhScale::file_units(&areas),
        ),
    ];
    let mut baselines = Vec::new();
    if !args.no_baselines {
        baselines.push(Baseline {
            label: "D2",
            key: "d2",
            collection: hists,
            describe: Box::new(move |m: &Mesh| Ok(d2(m, &d2_params)?)),
            distance: l1,
        });
    }
    for (label, key, scale) in fpfh_scales.into_iter().filter(|_| !args.no_baselines) {
        baselines.push(fpfh_baseline(
            label,
            key,
            &points,
            &files,
            &fpfh_params,
            scale,
        )?);
    }
    drop(points);
    let fit_s = t_fit.elapsed().as_secs_f64();

    // 2. a fresh index of the collection
    let index_dir = args.out.join("index");
    let tmp_dir = args.out.join(format!(".index-{}", std::process::id()));
    if tmp_dir.exists() {
        fs::remove_dir_all(&tmp_dir)
            .with_context(|| format!("{}: cannot remove", tmp_dir.display()))?;
    }
    {
        let mut w = open_writer(&tmp_dir, &params)?;
        w.add_batch(records.clone())?;
    }
    if index_dir.exists() {
        fs::remove_dir_all(&index_dir)
            .with_context(|| format!("{}: cannot replace", index_dir.display()))?;
    }
    fs::rename(&tmp_dir, &index_dir)
        .with_context(|| format!("{}: cannot write", index_dir.display()))?;
    let reader = Reader::open(&index_dir)?;
    let index_of: HashMap<PathBuf, usize> = reader
        .shapes()?
        .iter()
        .filter_map(|s| {
            files
                .iter()
                .position(|f| *f == s.record.path)
                .map(|i| (s.record.path.clone(), i))
        })
        .collect();
    if index_of.len() != n {
        bail!(
            "{}: the index holds {} of the {n} shapes (two files with the same canonical path?)",
            index_dir.display(),
            index_of.len()
        );
    }

    // 3. whole-shape queries, each analysed as `keycomp query` would: a shape with a boundary
    // is described as a fragment (DescribeParams::for_query), closed ones as indexed: their
    // index record is their query record
    let as_queries: Vec<Option<Vec<ShapeRecord<DIM>>>> = (0..n)
        .into_par_iter()
        .map(|i| -> Result<Option<Vec<ShapeRecord<DIM>>>> {
            let as_query = params
                .describe
                .for_query_with_boundary(records[i].boundary_vertices > 0);
            if as_query == [params.describe.clone()] {
                return Ok(None);
            }
            let hash = records[i].content_hash;
            Ok(Some(
                cache.records(&files[i], hash, &params, Role::Query)?.0,
            ))
        })
        .collect::<Result<_>>()?;
    let mut sets = Vec::new();
    let whole: Vec<QueryResult> = (0..n)
        .map(|i| -> Result<QueryResult> {
            let returned = kc_ranking(
                &reader,
                as_queries[i]
                    .as_deref()
                    .unwrap_or(std::slice::from_ref(&records[i])),
                &index_of,
                &match_params,
                args.verify_weight,
                params.surface.is_some(),
            )?;
            let kc_order = complete_ranking(
                &returned,
                n,
                Some(i),
                sub_seed(args.seed, "whole", i as u64),
            );
            let nret = returned.iter().filter(|&&j| j != i).count();
            let by_baseline = baselines
                .iter()
                .map(|b| {
                    let order = b.ranking(&b.collection[i], Some(i));
                    let m = method_result(&order, n - 1, &classes[i], &classes, &names, None);
                    (b.key, m)
                })
                .collect();
            Ok(QueryResult {
                query: names[i].clone(),
                class: classes[i].clone(),
                source: None,
                target_fraction: None,
                fraction: None,
                cut: None,
                components: records[i].components.len(),
                error: None,
                key_components: method_result(&kc_order, nret, &classes[i], &classes, &names, None),
                baselines: by_baseline,
                random: method_result(
                    &complete_ranking(&[], n, Some(i), sub_seed(args.seed, "random", i as u64)),
                    0,
                    &classes[i],
                    &classes,
                    &names,
                    None,
                ),
            })
        })
        .collect::<Result<_>>()?;
    let methods: Vec<(&str, &str)> = baselines.iter().map(|b| (b.label, b.key)).collect();
    sets.push(query_set("whole", whole, &methods));

    // 4. partial queries
    let per_kind = match &args.queries {
        Some(Queries::PerKind(k)) => *k,
        _ => n,
    };
    let mut sources: Vec<usize> = (0..n).collect();
    sources.shuffle(&mut ChaCha8Rng::seed_from_u64(sub_seed(
        args.seed, "sources", 0,
    )));
    let frag_dir = args.out.join("fragments");
    // fragments of an earlier run (perhaps with other options) would be mistaken for this one's
    if frag_dir.exists() {
        fs::remove_dir_all(&frag_dir)
            .with_context(|| format!("{}: cannot clear", frag_dir.display()))?;
    }
    if !kinds.is_empty() && per_kind > 0 {
        fs::create_dir_all(&frag_dir)
            .with_context(|| format!("{}: cannot create", frag_dir.display()))?;
    }
    let jobs: Vec<(PartialKind, usize)> = kinds
        .iter()
        .flat_map(|&k| (0..per_kind).map(move |q| (k, q)))
        .collect();
    let bar = progress(jobs.len() as u64, "partial queries");
    let mut repeatability: Vec<(&'static str, f64, Repeatability)> = Vec::new();
    type Fragment = (
        usize,
        f64,
        f64,
        String,
        Result<Vec<ShapeRecord<DIM>>>,
        Vec<Vec<f64>>,
        PathBuf,
        Option<Repeatability>,
    );
    let fragments: Vec<Result<Fragment>> = jobs
        .par_iter()
        .map(|&(kind, q)| {
            let r = (|| -> Result<Fragment> {
                let src = sources[q % n];
                let mut rng = ChaCha8Rng::seed_from_u64(sub_seed(args.seed, kind.name(), q as u64));
                let target = rng.random_range(args.area.0..=args.area.1);
                let mesh = read_mesh(&files[src])?.mesh;
                let frag = cut_fragment(&mesh, kind, target, &mut rng).with_context(|| {
                    format!("{}: cannot cut a {kind} fragment", files[src].display())
                })?;
                let path = frag_dir.join(format!("{kind}-{q:03}-{}.off", names[src]));
                let tmp = path.with_extension("off.tmp");
                keycomp_mesh::write_off(&frag.mesh, &tmp)?;
                fs::rename(&tmp, &path)
                    .with_context(|| format!("{}: cannot write", path.display()))?;
                let descriptors = baselines
                    .iter()
                    .map(|b| {
                        (b.describe)(&frag.mesh)
                            .with_context(|| format!("{}: {}", path.display(), b.label))
                    })
                    .collect::<Result<_>>()?;
                // detection may legitimately fail on a fragment: the query then has no
                // key-components (its ranking is random), which is reported
                let rec = ContentHash::of_file(&path)
                    .map_err(anyhow::Error::from)
                    .and_then(|hash| {
                        cache
                            .records(&path, hash, &params, Role::Query)
                            .map(|(r, _)| r)
                    });
                let rep = if args.repeatability {
                    Some(partial_repeatability(
                        &files[src],
                        &path,
                        &frag.original,
                        &params,
                    )?)
                } else {
                    None
                };
                Ok((
                    src,
                    target,
                    frag.fraction,
                    frag.detail,
                    rec,
                    descriptors,
                    path,
                    rep,
                ))
            })();
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    let mut by_kind: BTreeMap<PartialKind, Vec<QueryResult>> = BTreeMap::new();
    for ((kind, q), f) in jobs.iter().zip(fragments) {
        let (src, target, fraction, detail, rec, descriptors, path, rep) = f?;
        if let Some(r) = rep {
            repeatability.push((kind.name(), fraction, r));
        }
        let (returned, components, error) = kc_answer(
            &rec,
            &reader,
            &index_of,
            &match_params,
            args.verify_weight,
            params.surface.is_some(),
        )?;
        let kc_order = complete_ranking(
            &returned,
            n,
            None,
            sub_seed(args.seed, &format!("{kind}-tail"), *q as u64),
        );
        let class = &classes[src];
        let by_baseline = baselines
            .iter()
            .zip(&descriptors)
            .map(|(b, d)| {
                let order = b.ranking(d, None);
                let m = method_result(&order, n, class, &classes, &names, Some(src));
                (b.key, m)
            })
            .collect();
        by_kind.entry(*kind).or_default().push(QueryResult {
            query: stem(&path),
            class: class.clone(),
            source: Some(names[src].clone()),
            target_fraction: Some(target),
            fraction: Some(fraction),
            cut: Some(detail),
            components,
            error,
            key_components: method_result(
                &kc_order,
                returned.len(),
                class,
                &classes,
                &names,
                Some(src),
            ),
            baselines: by_baseline,
            random: method_result(
                &complete_ranking(
                    &[],
                    n,
                    None,
                    sub_seed(args.seed, &format!("{kind}-random"), *q as u64),
                ),
                0,
                class,
                &classes,
                &names,
                Some(src),
            ),
        });
    }
    for (kind, results) in by_kind {
        sets.push(query_set(kind.name(), results, &methods));
    }

    // 5. external queries, named with their sources in --truth
    if let Some(truth) = &external {
        let bar = progress(truth.len() as u64, "external queries");
        let results: Vec<QueryResult> = truth
            .par_iter()
            .enumerate()
            .map(|(q, t)| {
                let r = external_query(
                    t,
                    q,
                    &Setting {
                        args: &args,
                        cache: &cache,
                        params: &params,
                        reader: &reader,
                        index_of: &index_of,
                        match_params: &match_params,
                        baselines: &baselines,
                        classes: &classes,
                        names: &names,
                    },
                );
                bar.inc(1);
                r
            })
            .collect::<Result<_>>()?;
        bar.finish_and_clear();
        sets.push(query_set("external", results, &methods));
    }

    // 6. outputs
    let mut class_counts: BTreeMap<String, usize> = BTreeMap::new();
    for c in &classes {
        *class_counts.entry(c.clone()).or_default() += 1;
    }
    let results = Results {
        collection: args.collection.display().to_string(),
        shapes: n,
        classes: class_counts,
        seed: args.seed,
        fraction_range: args.area,
        detect_params: params.detect,
        describe_params: params.describe,
        match_params,
        verify_weight: args.verify_weight,
        d2_params,
        fpfh_params,
        fpfh_scales: fpfh_scales.iter().map(|&(_, k, s)| (k, s)).collect(),
        shapes_without_components: records
            .iter()
            .zip(&names)
            .filter(|(r, _)| r.components.is_empty())
            .map(|(_, s)| s.clone())
            .collect(),
        components_per_shape: records.iter().map(|r| r.components.len()).sum::<usize>() as f64
            / n as f64,
        query_sets: sets,
        partial_repeatability: repeatability_rows(&repeatability, args.area),
    };
    let json = serde_json::to_vec_pretty(&results).context("cannot serialise the results")?;
    output::write_bytes(&args.out.join("results.json"), &json)?;
    for set in &results.query_sets {
        let mut curves = vec![Curve {
            label: "key-components".into(),
            values: set.key_components.summary.mean.pr.clone(),
        }];
        for &(label, key) in &methods {
            curves.push(Curve {
                label: label.into(),
                values: set.baselines[key].summary.mean.pr.clone(),
            });
        }
        curves.push(Curve {
            label: "random".into(),
            values: set.random.summary.mean.pr.clone(),
        });
        let title = format!(
            "{} queries ({}) on {}",
            set.name,
            set.queries,
            stem(&args.collection)
        );
        output::write_bytes(
            &args.out.join(format!("pr-{}.svg", set.name)),
            pr_svg(&title, &curves).as_bytes(),
        )?;
    }
    let times = Times {
        detect: detect_s,
        fit: fit_s,
        total: t0.elapsed().as_secs_f64(),
    };
    let text = report_text(
        &results,
        &args,
        &detect.retrieval_preset().to_string(),
        hits,
        &methods,
        &times,
    )?;
    output::print_text(&text)?;
    Ok(ExitCode::SUCCESS)
}

/// A query's key-component answer: the shapes ranked ([`kc_ranking`]), its component count
/// and, when it could not be analysed (detection may fail on a fragment or a scan), why; its
/// ranking is then empty (random).
fn kc_answer(
    rec: &Result<Vec<ShapeRecord<DIM>>>,
    reader: &Reader,
    index_of: &HashMap<PathBuf, usize>,
    match_params: &MatchParams,
    verify: Option<f64>,
    canonical: bool,
) -> Result<(Vec<usize>, usize, Option<String>)> {
    Ok(match rec {
        Ok(r) => (
            kc_ranking(reader, r, index_of, match_params, verify, canonical)?,
            r.first().map_or(0, |r| r.components.len()),
            None,
        ),
        Err(e) => (Vec::new(), 0, Some(output::error_chain(e))),
    })
}

/// What an external query is measured against: the run's options, index and baselines.
struct Setting<'a> {
    args: &'a Args,
    cache: &'a RecordCache,
    params: &'a Profile,
    reader: &'a Reader,
    index_of: &'a HashMap<PathBuf, usize>,
    match_params: &'a MatchParams,
    baselines: &'a [Baseline],
    classes: &'a [String],
    names: &'a [String],
}

/// One external query (the `q`-th line of --truth) ranked by key-components as `keycomp query`
/// ranks the file (a point cloud on its canonical surface, whatever the index's profile) and
/// by each baseline. The baselines need triangles: they describe the file's mesh (a range grid
/// triangulated), or a point cloud's canonical surface.
fn external_query(t: &Truth, q: usize, s: &Setting<'_>) -> Result<QueryResult> {
    let n = s.names.len();
    let input = keycomp_mesh::read_input(&t.query)?;
    let points = matches!(input.geometry, keycomp_mesh::Geometry::Points(_));
    let descriptors: Vec<Vec<f64>> = if s.baselines.is_empty() {
        Vec::new()
    } else {
        let mesh = match input.geometry {
            keycomp_mesh::Geometry::Mesh(m) => m,
            g => {
                keycomp::analysis::canonical_surface(&g, &s.params.surface.unwrap_or_default())
                    .with_context(|| format!("{}: canonical surface", t.query.display()))?
                    .mesh
            }
        };
        s.baselines
            .iter()
            .map(|b| {
                (b.describe)(&mesh).with_context(|| format!("{}: {}", t.query.display(), b.label))
            })
            .collect::<Result<_>>()?
    };
    // detection may fail on a query: it then has no key-components (random ranking), reported
    let rec = ContentHash::of_file(&t.query)
        .map_err(anyhow::Error::from)
        .and_then(|hash| {
            s.cache
                .records(&t.query, hash, s.params, Role::Query)
                .map(|(r, _)| r)
        });
    let (returned, components, error) = kc_answer(
        &rec,
        s.reader,
        s.index_of,
        s.match_params,
        s.args.verify_weight,
        s.params.surface.is_some() || points,
    )?;
    let src = t.source;
    let class = t.class.as_ref().unwrap_or(&s.classes[src]);
    let seed = s.args.seed;
    let result = |order: &[usize], returned: usize| {
        method_result(order, returned, class, s.classes, s.names, Some(src))
    };
    let by_baseline = s
        .baselines
        .iter()
        .zip(&descriptors)
        .map(|(b, d)| (b.key, result(&b.ranking(d, None), n)))
        .collect();
    Ok(QueryResult {
        query: t.query.display().to_string(),
        class: class.clone(),
        source: Some(s.names[src].clone()),
        target_fraction: None,
        fraction: None,
        cut: None,
        components,
        error,
        key_components: result(
            &complete_ranking(
                &returned,
                n,
                None,
                sub_seed(seed, "external-tail", q as u64),
            ),
            returned.len(),
        ),
        baselines: by_baseline,
        random: result(
            &complete_ranking(&[], n, None, sub_seed(seed, "external-random", q as u64)),
            0,
        ),
    })
}

/// The summaries of one query set; `methods` are the baselines' (label, key) pairs.
fn query_set(name: &str, results: Vec<QueryResult>, methods: &[(&str, &'static str)]) -> QuerySet {
    let fr: Vec<f64> = results.iter().filter_map(|r| r.fraction).collect();
    let all: Vec<&QueryResult> = results.iter().collect();
    let answered: Vec<&QueryResult> = results
        .iter()
        .filter(|r| r.key_components.returned > 0)
        .collect();
    let per_baseline = |rs: &[&QueryResult]| -> BTreeMap<&'static str, MethodSummary> {
        methods
            .iter()
            .map(|&(_, key)| (key, summarize_method(rs, |r| &r.baselines[key])))
            .collect()
    };
    QuerySet {
        name: name.to_string(),
        queries: results.len(),
        mean_fraction: (!fr.is_empty()).then(|| fr.iter().sum::<f64>() / fr.len() as f64),
        key_components: summarize_method(&all, |r| &r.key_components),
        baselines: per_baseline(&all),
        random: summarize_method(&all, |r| &r.random),
        answered: Answered {
            key_components: summarize_method(&answered, |r| &r.key_components),
            baselines: per_baseline(&answered),
        },
        results,
    }
}

/// Wall-clock times of a run, in seconds.
struct Times {
    /// Analysing the collection (records, D2 histograms, FPFH points).
    detect: f64,
    /// Fitting the FPFH baselines (features of the collection, codebooks, idf).
    fit: f64,
    /// The whole run.
    total: f64,
}

/// The tables printed on stdout; `methods` are the baselines' (label, key) pairs, in order.
fn report_text(
    r: &Results,
    args: &Args,
    preset: &str,
    hits: usize,
    methods: &[(&str, &'static str)],
    times: &Times,
) -> Result<String> {
    let mut s = String::new();
    writeln!(
        s,
        "{}: {} shapes, {} classes ({}); {:.2} key-components per shape, {} shapes without any",
        r.collection,
        r.shapes,
        r.classes.len(),
        r.classes
            .iter()
            .map(|(c, k)| format!("{c} {k}"))
            .collect::<Vec<_>>()
            .join(", "),
        r.components_per_shape,
        r.shapes_without_components.len()
    )?;
    writeln!(
        s,
        "preset {}, seed {}, fragments keep {:.0}-{:.0} % of the area\n",
        preset,
        r.seed,
        100.0 * r.fraction_range.0,
        100.0 * r.fraction_range.1
    )?;
    writeln!(
        s,
        "| queries | n | area | method | NN | FT | ST | E | DCG | mAP | source rank | source 1st | source top 3 | source ahead | no result |"
    )?;
    writeln!(
        s,
        "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
    )?;
    for set in &r.query_sets {
        let mut rows = vec![("key-components", &set.key_components)];
        rows.extend(
            methods
                .iter()
                .map(|&(label, key)| (label, &set.baselines[key])),
        );
        rows.push(("random", &set.random));
        for (label, m) in rows {
            let x = &m.summary.mean;
            writeln!(
                s,
                "| {} | {} | {} | {label} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {} | {} | {} | {} |",
                set.name,
                m.summary.queries,
                set.mean_fraction
                    .map_or("100 %".to_string(), |f| format!("{:.0} %", 100.0 * f)),
                x.nn,
                x.ft,
                x.st,
                x.e,
                x.dcg,
                x.ap,
                m.mean_source_rank
                    .map_or("-".to_string(), |v| format!("{v:.1}")),
                m.source_first.map_or("-".to_string(), |v| format!("{v}")),
                m.source_top3.map_or("-".to_string(), |v| format!("{v}")),
                m.source_ahead.map_or("-".to_string(), |v| format!("{v}")),
                if label == "random" {
                    "-".to_string()
                } else {
                    m.empty.to_string()
                }
            )?;
        }
    }
    // the queries key-components answer
    writeln!(
        s,
        "\nqueries for which key-components return at least one shape (every method on the same \
         queries):\n"
    )?;
    writeln!(
        s,
        "| queries | answered | method | NN | FT | mAP | source rank |"
    )?;
    writeln!(s, "|---|---:|---|---:|---:|---:|---:|")?;
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:.3}")
        } else {
            "-".to_string()
        }
    };
    let rank = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.1}"));
    for set in &r.query_sets {
        let k = &set.answered.key_components;
        let mut rows = vec![("key-components", k)];
        rows.extend(
            methods
                .iter()
                .map(|&(label, key)| (label, &set.answered.baselines[key])),
        );
        for (label, m) in rows {
            writeln!(
                s,
                "| {} | {} of {} | {label} | {} | {} | {} | {} |",
                set.name,
                k.summary.queries + k.summary.undefined,
                set.queries,
                num(m.summary.mean.nn),
                num(m.summary.mean.ft),
                num(m.summary.mean.ap),
                rank(m.mean_source_rank),
            )?;
        }
    }
    if !r.partial_repeatability.is_empty() {
        writeln!(
            s,
            "\npartial repeatability (source parts with at least half their area in the fragment; mean best area overlap with the fragment's own parts):\n"
        )?;
        writeln!(
            s,
            "| kind | kept area | fragments | key-components | KC overlap | patches | patch overlap |\n|---|---|---:|---:|---:|---:|---:|"
        )?;
        for row in &r.partial_repeatability {
            writeln!(
                s,
                "| {} | {:.0}-{:.0} % | {} | {} | {:.3} | {} | {:.3} |",
                row.kind,
                row.area.0 * 100.0,
                row.area.1 * 100.0,
                row.fragments,
                row.kc_parts,
                row.kc_overlap,
                row.patch_parts,
                row.patch_overlap
            )?;
        }
    }
    // per class, whole-shape queries
    if let Some(whole) = r.query_sets.first() {
        writeln!(
            s,
            "\nwhole-shape queries per class (mean; components = key-components per shape):\n"
        )?;
        let columns: Vec<(&str, Option<&str>)> = std::iter::once(("KC", None))
            .chain(methods.iter().map(|&(label, key)| (label, Some(key))))
            .collect();
        let mut header = "| class | shapes | components |".to_string();
        let mut rule = "|---|---:|---:|".to_string();
        for (label, _) in &columns {
            write!(header, " {label} NN | {label} FT | {label} mAP |")?;
            rule.push_str("---:|---:|---:|");
        }
        writeln!(s, "{header}\n{rule}")?;
        for class in r.classes.keys() {
            let rs: Vec<&QueryResult> =
                whole.results.iter().filter(|q| &q.class == class).collect();
            let mean = |f: &dyn Fn(&QueryResult) -> Option<f64>| {
                let v: Vec<f64> = rs.iter().filter_map(|q| f(q)).collect();
                if v.is_empty() {
                    "-".to_string()
                } else {
                    format!("{:.3}", v.iter().sum::<f64>() / v.len() as f64)
                }
            };
            write!(
                s,
                "| {class} | {} | {} |",
                rs.len(),
                mean(&|q| Some(q.components as f64)).replace(".000", ""),
            )?;
            for &(_, key) in &columns {
                write!(
                    s,
                    " {} | {} | {} |",
                    mean(&|q| q.method(key).nn),
                    mean(&|q| q.method(key).ft),
                    mean(&|q| q.method(key).ap)
                )?;
            }
            writeln!(s)?;
        }
    }
    let undefined: usize = r
        .query_sets
        .iter()
        .map(|q| q.key_components.summary.undefined)
        .sum();
    if undefined > 0 {
        writeln!(
            s,
            "\n{undefined} queries left out of the means: their class has no other shape"
        )?;
    }
    writeln!(
        s,
        "\nPSB measures (micro-averaged over queries; macro-averages in results.json); \
         'random': a seeded shuffle, the chance level; 'no result': queries for which the \
         method returned no shape (ranked at random).\n\
         time: {:.1} s ({:.1} s analysing the collection, {hits} of {} records from the cache; \
         {:.1} s fitting the FPFH codebooks); wrote {}",
        times.total,
        times.detect,
        r.shapes,
        times.fit,
        args.out.join("results.json").display()
    )?;
    Ok(s)
}
