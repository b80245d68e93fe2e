//! The arguments of `keycomp bench retrieval` and the small helpers its steps share: the
//! detection options, the query counts, the area range, the mesh listing of a folder, the
//! per-query seeds and file stems.

use std::fs;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use keycomp_mesh::Format;

use crate::args::DetectArgs;

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
of another class ('source ahead': `--partial plane --area 0.5,0.5` measures halves), and how
often key-components' geometric verification measured it ('source verified': the candidate
recall of its shortlist). With
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
    /// The surface analysed, as `keycomp index add --surface` records it: canonical (each
    /// shape and fragment remade as one surface sampled at one density per unit of its
    /// source's area) or as-read (the meshes and fragments as they are).
    #[arg(long, default_value = "canonical", value_parser = ["canonical", "as-read"], value_name = "MODE")]
    pub surface: String,
    /// Ablation: the canonical surface's vertex budget per whole shape, with `--surface
    /// canonical` [default: 10,000].
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
    /// Ablation: describe meshes of more vertices than N on a proxy of N
    /// (`DescribeParams::proxy_vertices`; 0: every mesh on its own vertices) [default: the
    /// description's].
    #[arg(long, value_name = "N")]
    pub describe_vertices: Option<usize>,
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
pub(super) struct DetectOptions {
    #[command(flatten)]
    detect: DetectArgs,
}

pub(super) fn detect_args(options: Option<&str>) -> Result<DetectArgs> {
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

pub(super) fn parse_queries(s: &str) -> Result<Queries, String> {
    if !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit()) {
        s.parse()
            .map(Queries::PerKind)
            .map_err(|_| format!("'{s}': too large a count"))
    } else {
        Ok(Queries::Folder(PathBuf::from(s)))
    }
}

pub(super) fn parse_range(s: &str) -> Result<(f64, f64), String> {
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
pub(super) fn list_meshes(dir: &Path, option: &str) -> Result<Vec<PathBuf>> {
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
pub(super) fn sub_seed(seed: u64, tag: &str, i: u64) -> u64 {
    let mut b = Vec::with_capacity(tag.len() + 16);
    b.extend_from_slice(&seed.to_le_bytes());
    b.extend_from_slice(tag.as_bytes());
    b.extend_from_slice(&i.to_le_bytes());
    xxhash_rust::xxh3::xxh3_64(&b)
}

pub(super) fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}
