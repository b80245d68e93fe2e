//! The results of a run: per shape the components and their best overlaps, per preset the
//! tables and curves ([`Report`], written as `results.json`), and the run's timings and cache
//! use ([`RunStats`]).

use keycomp_components::{GeodesicOptions, SmacofParams};
use keycomp_harris::HarrisParams;
use keycomp_mser::MserParams;
use keycomp_surface::SurfaceParams;
use serde::Serialize;

use super::config::{Budget, PresetSpec};
use super::discover::NullSpec;
use crate::evaluate::CumulativeTable;
use crate::paper::PaperTable;

/// Format tag of the JSON [`Report`].
pub const REPORT_FORMAT: &str = "keycomp-repeatability v1";

/// One preset's components and scores on one shape.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PresetScores {
    /// Number of components detected.
    pub components: usize,
    /// Best overlap of each component with a component of the null shape (empty for a null
    /// shape).
    pub best_overlaps: Vec<f64>,
    /// Best overlap of each component's cluster with a cluster of the null shape, a cluster
    /// standing for the null vertices within [`CLUSTER_RADIUS`] of its keypoints (empty for a
    /// null shape and for the MSER methods).
    pub cluster_overlaps: Vec<f64>,
}

/// Unit lengths (square roots of the null shape's area) within which a transformed keypoint
/// counts as repeated when a null keypoint lies there ([`ShapeReport::keypoint_share`]).
pub const KEYPOINT_RADIUS: f64 = 0.02;
/// Unit lengths around its keypoints that stand for a cluster
/// ([`PresetScores::cluster_overlaps`]).
pub const CLUSTER_RADIUS: f64 = 0.05;

/// One shape of the run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShapeReport {
    /// Null shape name.
    pub null: String,
    /// `null`, a [`crate::transform::Kind`] name or `isometry`.
    pub kind: String,
    /// Strength 1..=5 (0 for the null shape).
    pub strength: u8,
    /// The pose file for isometry, the null file otherwise.
    pub source: String,
    /// Vertex count.
    pub vertices: usize,
    /// Face count.
    pub faces: usize,
    /// Keypoints detected.
    pub keypoints: usize,
    /// The share of its keypoints, carried to the null shape, within [`KEYPOINT_RADIUS`] of
    /// a keypoint of the null shape (none for a null shape or without keypoints).
    pub keypoint_share: Option<f64>,
    /// Per preset, in [`Report::presets`] order.
    pub presets: Vec<PresetScores>,
}

/// A shape that could not be evaluated, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Skipped {
    /// Null shape name.
    pub null: String,
    /// Transformation (or `null`).
    pub kind: String,
    /// Strength (0 for the null shape).
    pub strength: u8,
    /// Why.
    pub reason: String,
}

/// Where repeatability is lost, for one transformation (all strengths pooled): the mean
/// [`ShapeReport::keypoint_share`] of its shapes, the mean best overlap of the clusters
/// ([`PresetScores::cluster_overlaps`]) and of the components.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StageRow {
    /// Transformation name.
    pub kind: String,
    /// Mean share of keypoints repeated.
    pub keypoints: Option<f64>,
    /// Mean best overlap of the clusters.
    pub clusters: Option<f64>,
    /// Mean best overlap of the components.
    pub components: Option<f64>,
}

/// One curve of Figs. 7–9.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CurveReport {
    /// Transformation name.
    pub kind: String,
    /// Table label (`Micro holes`).
    pub label: String,
    /// Components pooled (all selected strengths, all null shapes).
    pub components: usize,
    /// Repeatability at each of [`Report::thresholds`].
    pub values: Vec<f64>,
}

/// Everything about one preset.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PresetReport {
    /// Name and parameters.
    pub preset: PresetSpec,
    /// The paper's Table 1 layout: mean best overlap per transformation and cumulative
    /// strength, and the mean of the rows.
    pub mean_overlap: CumulativeTable,
    /// Mean best overlap per transformation and *exact* strength (= 1 … = 5, not pooled). The
    /// paper's sampling row (0.62 at strength 1 but 0.00 at "≤ 5") is only consistent with this
    /// reading, so both are reported.
    pub mean_overlap_per_strength: CumulativeTable,
    /// Repeatability at overlap [`crate::experiment::PAPER_OVERLAP`] in the same layout.
    pub repeatability_at_0_8: CumulativeTable,
    /// Components pooled per transformation and cumulative strength (same layout).
    pub component_counts: Vec<(String, Vec<usize>)>,
    /// Repeatability-vs-overlap per transformation, all strengths pooled.
    pub curves: Vec<CurveReport>,
    /// Stage by stage, per transformation, all strengths pooled: keypoints, clusters,
    /// components.
    pub stages: Vec<StageRow>,
    /// The paper's table for this preset, if it is one of KC-1, KC-2, KC-3.
    pub paper: Option<&'static PaperTable>,
}

/// The result of [`crate::experiment::run`]; serialised as `results.json`. Deterministic for the same data,
/// configuration and seed (no timings in it: see [`RunStats`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// [`REPORT_FORMAT`].
    pub format: &'static str,
    /// Seed of the transformations.
    pub seed: u64,
    /// The keypoint budget in words.
    pub budget: String,
    /// The budget.
    pub budget_rule: Budget,
    /// Harris parameters (the selection is decided by the budget).
    pub harris: HarrisParams,
    /// SMACOF parameters.
    pub smacof: SmacofParams,
    /// Geodesic options of detection (full mesh or proxy).
    pub geodesic: GeodesicOptions,
    /// Parameters of the MSER methods (used by presets `MSER` and `MSER-KC` only).
    pub mser: MserParams,
    /// The canonical surface key-components were detected on ([`crate::experiment::Config::surface`]); absent:
    /// on the meshes themselves.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface: Option<SurfaceParams>,
    /// Overlap thresholds of the curves.
    pub thresholds: Vec<f64>,
    /// Null shapes and their poses.
    pub nulls: Vec<NullSpec>,
    /// Per preset: tables and curves.
    pub presets: Vec<PresetReport>,
    /// Every evaluated shape (null shapes first within each null's set).
    pub shapes: Vec<ShapeReport>,
    /// Shapes that could not be evaluated.
    pub skipped: Vec<Skipped>,
}

/// Timings and cache use of a run (not deterministic, kept out of [`Report`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct RunStats {
    /// Wall-clock seconds of [`crate::experiment::run`].
    pub seconds: f64,
    /// Shapes whose stage 1 came from the cache.
    pub cache_hits: usize,
    /// Shapes computed.
    pub computed: usize,
    /// Corrupt cache entries replaced.
    pub corrupt_entries: usize,
    /// Cache writes that failed (the run goes on without them).
    pub cache_write_errors: Vec<String>,
    /// Sum of per-shape seconds (transformation, detection, carrying).
    pub shape_seconds: f64,
}
