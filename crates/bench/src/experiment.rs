//! The repeatability experiment of Sipiran & Bustos (2013), Section 4, on generated data:
//! null shapes, their transformed versions with ground-truth maps, detection on all of them,
//! overlap of carried components, and the paper's tables and curves.
//!
//! **Data** ([`discover`]). A folder in the layout of `../shared/data` (it has a `tosca/` or
//! `kids/` subfolder) gives:
//! - TOSCA: per class (file-name prefix: `cat`, `centaur`, `dog`, `horse`, `wolf`, …) the null
//!   shape is pose 0 (`cat0.off`); the other poses, in increasing pose number, are its isometry
//!   transformations with strengths 1, 2, … (at most 5: `cat1`–`cat5`; `horse5, 6, 7, 10, 14`;
//!   `wolf1, 2` give strengths 1 and 2 only). Pose numbers carry no order of deformation, so
//!   the isometry strengths are just five different poses, as SHREC'10's five isometry shapes
//!   per null are.
//! - KIDS: `ID.null.0.EXT` is a null shape and `ID.isometry.K.EXT` (K = 1..5) its isometry of
//!   strength K.
//! - FAUST (with a `faust/` subfolder): subject 0's pose 0, `tr_reg_000`, is a null shape and
//!   its poses `tr_reg_001`–`tr_reg_005` its isometries of strengths 1–5.
//!
//! Poses share the null shape's vertex numbering, so their map is the identity (a pose whose
//! vertex count differs is skipped with a reason). Any other folder: every mesh file directly
//! in it (`.off`, `.obj`, `.ply`, `.stl`, by name) is a null shape, with no isometry.
//!
//! **Run** ([`run`]). Per null shape X: the selected [`Kind`]s × strengths are generated with
//! [`transform`] (seeded; a transformation that cannot be applied, such as `topology` on a convex
//! shape, is skipped with its reason). Every shape — X, each transformed Y, each pose — goes
//! through stage 1 of detection once ([`embed`]: Harris, fast marching, SMACOF; read
//! from the [`EmbeddingCache`] when present) and through stage 2 once per preset (clustering and
//! region growing). Each component of Y is carried to X ([`Pullback`]) and scored by its best
//! overlap with a component of X of the same preset ([`best_overlaps`]). Shapes run in parallel
//! (rayon, in the caller's thread pool) when [`Config::parallel_shapes`] is set.
//!
//! **Methods** ([`Method`]). Each [`PresetSpec`] names a detection method: key-components
//! (`kc`, the presets KC-1..3, stages as above) or the paper's comparison method of Section 4.4
//! (`mser`: every diffusion-geometric maximally stable component, Table 5; `mser-kc`: the MSER
//! key-components, Table 6; [`PresetSpec::mser`]). Both MSER presets read their components off
//! one `keycomp_mser::detect` per shape with [`Config::mser`] (Laplace–Beltrami spectrum of
//! the full mesh, no simplification), cached beside the stage-1 entries
//! ([`EmbeddingCache::load_mser`], keyed by content, MSER parameters and
//! [`crate::cache::MSER_VERSION`]). The keypoint budget does not apply to them (HKS keypoints
//! are the 2-ring maxima, however many).
//!
//! **Keypoint budget** ([`Budget`]). The paper's presets take 1 % of *each shape's own* vertex
//! count (`Budget::PerShape(Selection::Fraction(0.01))`), so a shape decimated to 12 % of its
//! vertices gets 12 % of the keypoints. `Budget::NullCalibrated(0.01)` gives every shape of a
//! null shape's set the same count, 1 % of the *null shape's* vertices: since every shape is
//! normalised to unit area before detection, this is a fixed number of keypoints per unit of
//! normalised area, independent of how the surface is tessellated. A fraction is resolved to a
//! count per shape before detection (`round(f · referenced vertices)`, at least 1, exactly as
//! Harris does), so shapes whose counts agree share cache entries across budgets.
//!
//! **Output** ([`Report`]): per preset the paper's Table 1 layout (mean best overlap per
//! transformation and cumulative strength, and the mean row), repeatability at overlap 0.8, the
//! repeatability-vs-overlap curve per transformation over all selected strengths (Figs. 7–9),
//! the paper's own table, and every shape's per-component best overlaps.
//!
//! Cost: stage 1 dominates, O(K·|V| log |V|) per shape; stage 2 and the overlaps are
//! milliseconds.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use keycomp_components::{ClusterParams, GeodesicOptions, SmacofParams, SphereRule};
use keycomp_harris::{HarrisParams, Selection};
use keycomp_mesh::geometry::vertex_areas;
use keycomp_mesh::{Format, Mesh, Topology, VertexId, read_mesh};
use keycomp_surface::{Input, SurfaceParams, canonical};
use rayon::prelude::*;
use serde::Serialize;

use crate::BenchError;
use crate::cache::{EmbeddingCache, Lookup, MserEntry, cache_key, mser_cache_key};
use crate::evaluate::{
    CumulativeTable, Pullback, Record, TableRow, best_overlaps, mean_overlap_table,
    repeatability_curve, repeatability_table,
};
use crate::paper::{PaperTable, paper_table, row_label, row_order};
use crate::staged::{Embedded, Extractor, embed};
use crate::transform::{Kind, MAX_STRENGTH, transform};
use keycomp_mser::{Method, MserParams, covering_set, detect as detect_mser};

/// Format tag of the JSON [`Report`].
pub const REPORT_FORMAT: &str = "keycomp-repeatability v1";

/// The overlap thresholds of the curves: 0, 0.05, …, 1.
pub fn thresholds() -> Vec<f64> {
    (0..=20).map(|i| f64::from(i) / 20.0).collect()
}

/// The overlap at which the paper quotes repeatability (Section 4.3, Fig. 6).
pub const PAPER_OVERLAP: f64 = 0.8;

/// The name of the real-pose transformation.
pub const ISOMETRY: &str = "isometry";

/// A real pose of a null shape, with the same vertex numbering.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PoseSpec {
    /// Isometry strength (1..=5).
    pub strength: u8,
    /// The pose's mesh file.
    pub path: PathBuf,
}

/// A null shape and its real poses.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct NullSpec {
    /// Short name (`cat0`, `kids-0001`, or the file stem).
    pub name: String,
    /// Mesh file.
    pub path: PathBuf,
    /// Isometry transformations (possibly none).
    pub poses: Vec<PoseSpec>,
}

fn data_error(path: &Path, message: impl Into<String>) -> BenchError {
    BenchError::Data {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Mesh files directly in `dir` (by extension), sorted by name.
fn mesh_files(dir: &Path) -> Result<Vec<PathBuf>, BenchError> {
    let entries = std::fs::read_dir(dir).map_err(|source| BenchError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut files = Vec::new();
    for e in entries {
        let e = e.map_err(|source| BenchError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        let path = e.path();
        let is_mesh = path
            .extension()
            .and_then(|x| x.to_str())
            .is_some_and(|x| Format::from_extension(x).is_some());
        if is_mesh && path.is_file() {
            files.push(path);
        }
    }
    files.sort();
    Ok(files)
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Finds the null shapes (and their poses) in `dir`; see the [module docs](self) for the two
/// layouts.
///
/// Errors: the folder cannot be read, or it holds no null shape.
pub fn discover(dir: &Path) -> Result<Vec<NullSpec>, BenchError> {
    if !dir.is_dir() {
        return Err(data_error(
            dir,
            "no such folder: pass --data DIR with the null shapes (the default is ../shared/data, \
             relative to the current folder)",
        ));
    }
    let tosca = dir.join("tosca");
    let kids = dir.join("kids");
    let faust = dir.join("faust");
    let mut nulls = Vec::new();
    if tosca.is_dir() || kids.is_dir() {
        if tosca.is_dir() {
            nulls.extend(discover_tosca(&tosca)?);
        }
        if kids.is_dir() {
            nulls.extend(discover_kids(&kids)?);
        }
        if faust.is_dir() {
            nulls.extend(discover_faust(&faust)?);
        }
    } else {
        for path in mesh_files(dir)? {
            nulls.push(NullSpec {
                name: stem(&path),
                path,
                poses: Vec::new(),
            });
        }
    }
    if nulls.is_empty() {
        return Err(data_error(
            dir,
            "no null shape found: expected mesh files (.off, .obj, .ply, .stl), or tosca/ and \
             kids/ subfolders laid out as in ../shared/data",
        ));
    }
    Ok(nulls)
}

/// TOSCA: `<class><pose>.<ext>`; pose 0 is the null shape.
fn discover_tosca(dir: &Path) -> Result<Vec<NullSpec>, BenchError> {
    let mut classes: BTreeMap<String, Vec<(u32, PathBuf)>> = BTreeMap::new();
    for path in mesh_files(dir)? {
        let s = stem(&path);
        let digits = s.len() - s.trim_end_matches(|c: char| c.is_ascii_digit()).len();
        let (class, number) = s.split_at(s.len() - digits);
        if class.is_empty() {
            continue;
        }
        if let Ok(n) = number.parse::<u32>() {
            classes.entry(class.to_owned()).or_default().push((n, path));
        }
    }
    let mut out = Vec::new();
    for (class, mut poses) in classes {
        poses.sort();
        let Some(pos) = poses.iter().position(|(n, _)| *n == 0) else {
            continue;
        };
        let (_, null) = poses.remove(pos);
        out.push(NullSpec {
            name: format!("{class}0"),
            path: null,
            poses: poses
                .into_iter()
                .take(usize::from(MAX_STRENGTH))
                .zip(1..)
                .map(|((_, path), strength)| PoseSpec { strength, path })
                .collect(),
        });
    }
    Ok(out)
}

/// KIDS / SHREC'10 names: `<id>.null.0.<ext>` and `<id>.isometry.<k>.<ext>`.
fn discover_kids(dir: &Path) -> Result<Vec<NullSpec>, BenchError> {
    let files = mesh_files(dir)?;
    let mut out = Vec::new();
    for path in &files {
        let s = stem(path);
        let Some(id) = s.strip_suffix(".null.0") else {
            continue;
        };
        let mut poses = Vec::new();
        for k in 1..=MAX_STRENGTH {
            let want = format!("{id}.isometry.{k}");
            if let Some(p) = files.iter().find(|p| stem(p) == want) {
                poses.push(PoseSpec {
                    strength: k,
                    path: p.clone(),
                });
            }
        }
        out.push(NullSpec {
            name: format!("kids-{id}"),
            path: path.clone(),
            poses,
        });
    }
    Ok(out)
}

/// FAUST registrations `tr_reg_NNN` (subject NNN / 10, pose NNN % 10, shared vertex
/// numbering): subject 0's pose 0 (`tr_reg_000`) is the null shape and its poses 1..=5
/// (`tr_reg_001`..`tr_reg_005`) are isometries of strengths 1..=5 — "poses of one subject".
fn discover_faust(dir: &Path) -> Result<Vec<NullSpec>, BenchError> {
    let files = mesh_files(dir)?;
    let find = |n: u32| files.iter().find(|p| stem(p) == format!("tr_reg_{n:03}"));
    let Some(null) = find(0) else {
        return Ok(Vec::new());
    };
    let poses = (1..=MAX_STRENGTH)
        .filter_map(|k| {
            find(u32::from(k)).map(|p| PoseSpec {
                strength: k,
                path: p.clone(),
            })
        })
        .collect();
    Ok(vec![NullSpec {
        name: "faust-000".to_string(),
        path: null.clone(),
        poses,
    }])
}

/// How many keypoints each shape gets (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Budget {
    /// Every shape uses this selection on its own vertices (the paper: `Fraction(0.01)`).
    PerShape(Selection),
    /// Every shape of a null shape's set gets `round(fraction × the null shape's referenced
    /// vertices)` keypoints: a fixed count per unit of normalised area.
    NullCalibrated(f64),
}

impl Budget {
    /// One-line description for reports.
    pub fn describe(&self) -> String {
        match *self {
            Budget::PerShape(Selection::Fraction(f)) => {
                let rule = if f == 0.01 {
                    "the paper's rule"
                } else {
                    "the paper's rule takes 1 %"
                };
                format!("{} % of each shape's own vertices ({rule})", f * 100.0)
            }
            Budget::PerShape(Selection::Count(n)) => {
                format!("{n} keypoints on every shape (fixed count per unit normalised area)")
            }
            Budget::PerShape(s) => format!("{s:?} on every shape"),
            Budget::NullCalibrated(f) => format!(
                "{} % of the null shape's vertices on the null and each of its transformed \
                 shapes (tessellation-independent)",
                f * 100.0
            ),
        }
    }
}

/// `round(f × n)`, at least 1: Harris' own rule for [`Selection::Fraction`].
fn fraction_count(f: f64, referenced: usize) -> usize {
    ((f * referenced as f64).round() as usize).max(1)
}

/// Vertices that some face refers to.
fn referenced(mesh: &Mesh) -> usize {
    let mut used = vec![false; mesh.num_vertices()];
    for f in &mesh.faces {
        for &v in f {
            used[v as usize] = true;
        }
    }
    used.iter().filter(|u| **u).count()
}

/// A named set of clustering parameters (one of the paper's presets, possibly modified).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PresetSpec {
    /// Name shown in tables (`KC-1`, …, `MSER`, `MSER-KC`); the paper's table of that name is
    /// printed beside ours. A trailing `*` marks a preset modified by options (the paper's table
    /// of the unmodified preset is still shown).
    pub name: String,
    /// The detection method; `cluster` and `sigma` are used by [`Method::Kc`] only.
    pub method: Method,
    /// R, T, N, Iter.
    pub cluster: ClusterParams,
    /// Region-growing factor σ.
    pub sigma: f64,
    /// The sphere that σ scales (the paper's enclosing sphere, or the robust preset's spread
    /// sphere).
    pub sphere: SphereRule,
    /// The paper's table read beside ours (`KC-1`, …, `MSER-KC`): the preset's own for the
    /// paper's presets, KC-1's for the robust preset (KC-1's clustering), none if unknown.
    pub paper_name: String,
}

impl PresetSpec {
    /// The preset of an MSER method, named as the paper's table (`MSER`, `MSER-KC`); `None`
    /// for [`Method::Kc`], whose presets are KC-1..3.
    pub fn mser(method: Method) -> Option<PresetSpec> {
        let name = match method {
            Method::Kc => return None,
            Method::Mser => "MSER",
            Method::MserKc => "MSER-KC",
        };
        Some(PresetSpec {
            name: name.to_owned(),
            method,
            cluster: ClusterParams::default(),
            sigma: 0.0,
            sphere: SphereRule::Enclosing,
            paper_name: name.to_owned(),
        })
    }
}

/// What to run.
#[derive(Debug, Clone)]
pub struct Config {
    /// Presets to evaluate (stage 2 runs once per preset).
    pub presets: Vec<PresetSpec>,
    /// Harris parameters; `selection` is replaced according to `budget`.
    pub harris: HarrisParams,
    /// Keypoint budget.
    pub budget: Budget,
    /// SMACOF parameters (shared by all presets).
    pub smacof: SmacofParams,
    /// Parameters of the MSER methods (shared by `MSER` and `MSER-KC`; part of their cache
    /// key).
    pub mser: MserParams,
    /// Geodesic options of detection (full mesh or proxy; part of the cache key).
    pub geodesic: GeodesicOptions,
    /// Generated transformations to run.
    pub kinds: Vec<Kind>,
    /// Whether to run the real-pose isometry transformations.
    pub isometry: bool,
    /// Strengths to run (each in 1..=5).
    pub strengths: Vec<u8>,
    /// Seed of the generated transformations.
    pub seed: u64,
    /// Cache of stage-1 results (`None`: no cache).
    pub cache: Option<EmbeddingCache>,
    /// Run shapes in parallel (each detection parallelises internally as well).
    pub parallel_shapes: bool,
    /// Detect on each shape's canonical surface ([`keycomp_surface::canonical`]) instead of
    /// the mesh as generated, the components carried back to the mesh's vertices
    /// ([`Pullback::nearest`]); `None`: on the mesh itself. Key-components only.
    pub surface: Option<SurfaceParams>,
}

/// Progress of a run, reported after each shape.
#[derive(Debug, Clone, Copy)]
pub struct Progress<'a> {
    /// Shapes finished.
    pub done: usize,
    /// Shapes in the run.
    pub total: usize,
    /// The shape just finished (`cat0 holes 3`).
    pub shape: &'a str,
}

/// Where a shape came from.
#[derive(Debug, Clone, PartialEq)]
enum Source {
    Null,
    Generated(Kind, u8),
    Pose(u8, PathBuf),
}

struct Job {
    null: usize,
    source: Source,
}

impl Job {
    fn kind(&self) -> &str {
        match &self.source {
            Source::Null => "null",
            Source::Generated(k, _) => k.name(),
            Source::Pose(..) => ISOMETRY,
        }
    }
    fn strength(&self) -> u8 {
        match &self.source {
            Source::Null => 0,
            Source::Generated(_, s) | Source::Pose(s, _) => *s,
        }
    }
}

struct LoadedNull {
    spec: NullSpec,
    mesh: Mesh,
    topo: Topology,
    areas: Vec<f64>,
    referenced: usize,
}

impl CacheUse {
    /// The less favourable of two uses (a shape with two cached stages is a hit only if both
    /// were): Corrupt, then Miss, then Off, then Hit.
    fn worse(self, other: CacheUse) -> CacheUse {
        let rank = |c: CacheUse| match c {
            CacheUse::Hit => 0,
            CacheUse::Off => 1,
            CacheUse::Miss => 2,
            CacheUse::Corrupt => 3,
        };
        if rank(other) > rank(self) {
            other
        } else {
            self
        }
    }
}

/// How a shape's stage-1 result was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CacheUse {
    /// Read from the cache.
    Hit,
    /// Computed (and stored).
    Miss,
    /// Computed because the cached entry was corrupt (and overwritten).
    Corrupt,
    /// Computed, no cache in use.
    Off,
}

struct Outcome {
    vertices: usize,
    faces: usize,
    keypoints: usize,
    cache: CacheUse,
    cache_error: Option<String>,
    seconds: f64,
    /// Per preset: the components as null-vertex sets (carried, for transformed shapes).
    components: Vec<Vec<Vec<VertexId>>>,
}

/// One preset's components and scores on one shape.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PresetScores {
    /// Number of components detected.
    pub components: usize,
    /// Best overlap of each component with a component of the null shape (empty for a null
    /// shape).
    pub best_overlaps: Vec<f64>,
}

/// One shape of the run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ShapeReport {
    /// Null shape name.
    pub null: String,
    /// `null`, a [`Kind`] name or `isometry`.
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
    /// Repeatability at overlap [`PAPER_OVERLAP`] in the same layout.
    pub repeatability_at_0_8: CumulativeTable,
    /// Components pooled per transformation and cumulative strength (same layout).
    pub component_counts: Vec<(String, Vec<usize>)>,
    /// Repeatability-vs-overlap per transformation, all strengths pooled.
    pub curves: Vec<CurveReport>,
    /// The paper's table for this preset, if it is one of KC-1, KC-2, KC-3.
    pub paper: Option<&'static PaperTable>,
}

/// The result of [`run`]; serialised as `results.json`. Deterministic for the same data,
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
    /// The canonical surface key-components were detected on ([`Config::surface`]); absent:
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
    /// Wall-clock seconds of [`run`].
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

impl Config {
    fn selection_for(&self, shape: &Mesh, null_referenced: usize) -> Selection {
        match self.budget {
            Budget::PerShape(Selection::Fraction(f)) => {
                Selection::Count(fraction_count(f, referenced(shape)))
            }
            Budget::PerShape(s) => s,
            Budget::NullCalibrated(f) => Selection::Count(fraction_count(f, null_referenced)),
        }
    }

    fn stage1(
        &self,
        mesh: &Mesh,
        null: &LoadedNull,
    ) -> Result<(Embedded, CacheUse, Option<String>), String> {
        let harris = HarrisParams {
            selection: self.selection_for(mesh, null.referenced),
            ..self.harris
        };
        let compute = || {
            embed(mesh, &harris, &self.smacof, &self.geodesic)
                .map_err(|e| format!("detection failed: {e}"))
        };
        let Some(cache) = &self.cache else {
            return Ok((compute()?, CacheUse::Off, None));
        };
        let key = cache_key(mesh, &harris, &self.smacof, &self.geodesic);
        let state = match cache.load(key, mesh.num_vertices()) {
            Lookup::Hit(e) => return Ok((e, CacheUse::Hit, None)),
            Lookup::Miss => CacheUse::Miss,
            Lookup::Corrupt => CacheUse::Corrupt,
        };
        let e = compute()?;
        let err = cache.store(key, &e).err().map(|e| e.to_string());
        Ok((e, state, err))
    }

    /// The MSER detection of `mesh` (HKS keypoints and maximally stable components), from the
    /// cache when present.
    fn mser_stage(&self, mesh: &Mesh) -> Result<(MserEntry, CacheUse, Option<String>), String> {
        let compute = || {
            detect_mser(mesh, &self.mser)
                .map(|d| MserEntry {
                    keypoints: d.keypoints,
                    components: d.components,
                })
                .map_err(|e| format!("MSER detection failed: {e}"))
        };
        let Some(cache) = &self.cache else {
            return Ok((compute()?, CacheUse::Off, None));
        };
        let key = mser_cache_key(mesh, &self.mser);
        let state = match cache.load_mser(key, mesh.num_vertices()) {
            Lookup::Hit(e) => return Ok((e, CacheUse::Hit, None)),
            Lookup::Miss => CacheUse::Miss,
            Lookup::Corrupt => CacheUse::Corrupt,
        };
        let e = compute()?;
        let err = cache.store_mser(key, &e).err().map(|e| e.to_string());
        Ok((e, state, err))
    }

    fn run_job(&self, job: &Job, nulls: &[LoadedNull]) -> Result<Outcome, String> {
        let t0 = Instant::now();
        let null = &nulls[job.null];
        let (mesh, map): (Cow<'_, Mesh>, Option<Vec<Option<VertexId>>>) = match &job.source {
            Source::Null => (Cow::Borrowed(&null.mesh), None),
            Source::Generated(kind, s) => {
                let t = transform(&null.mesh, *kind, *s, self.seed).map_err(|e| e.to_string())?;
                (Cow::Owned(t.mesh), Some(t.map))
            }
            Source::Pose(_, path) => {
                let m = read_mesh(path).map_err(|e| e.to_string())?.mesh;
                if m.num_vertices() != null.mesh.num_vertices() {
                    return Err(format!(
                        "{}: {} vertices but the null shape has {}: not the same vertex \
                         numbering, so no ground truth",
                        path.display(),
                        m.num_vertices(),
                        null.mesh.num_vertices()
                    ));
                }
                let identity = (0..m.num_vertices() as VertexId).map(Some).collect();
                (Cow::Owned(m), Some(identity))
            }
        };
        let wants = |kc: bool| self.presets.iter().any(|p| (p.method == Method::Kc) == kc);
        // key-components on the canonical surface when asked, carried back to `mesh`
        let surface = match &self.surface {
            Some(params) if wants(true) => Some(
                canonical(Input::Mesh(&mesh), params)
                    .map_err(|e| format!("canonical surface: {e}"))?
                    .mesh,
            ),
            _ => None,
        };
        // canonical vertex -> the mesh's vertices nearest it (Pullback::nearest)
        let carrier = surface.as_ref().map(|s| Pullback::nearest(&mesh, s));
        let detected: &Mesh = surface.as_ref().unwrap_or(&mesh);
        let (embedded, mut cache, mut cache_error) = if wants(true) {
            let (e, c, err) = self.stage1(detected, null)?;
            (Some(e), c, err)
        } else {
            (None, CacheUse::Hit, None)
        };
        let mser = if wants(false) {
            let (m, c, err) = self.mser_stage(&mesh)?;
            cache = cache.worse(c);
            cache_error = cache_error.or(err);
            Some(m)
        } else {
            None
        };
        let extractor = embedded.as_ref().map(|_| Extractor::new(detected));
        let vertex_area = mser.as_ref().map(|_| vertex_areas(&mesh));
        let mut components = Vec::with_capacity(self.presets.len());
        for p in &self.presets {
            let comps = match (p.method, &embedded, &extractor, &mser, &vertex_area) {
                (Method::Kc, Some(e), Some(x), _, _) => {
                    let found = x
                        .components(e, &p.cluster, p.sigma, p.sphere)
                        .map_err(|e| format!("{}: component extraction failed: {e}", p.name))?;
                    match &carrier {
                        Some(carrier) => found.iter().map(|c| carrier.carry(c)).collect(),
                        None => found,
                    }
                }
                (Method::Mser, _, _, Some(m), _) => m.components.clone(),
                (Method::MserKc, _, _, Some(m), Some(va)) => {
                    let areas: Vec<f64> = m
                        .components
                        .iter()
                        .map(|c| c.iter().map(|&v| va[v as usize]).sum())
                        .collect();
                    let (chosen, _) = covering_set(&m.components, &areas, &m.keypoints)
                        .map_err(|e| format!("{}: {e}", p.name))?;
                    chosen.iter().map(|&i| m.components[i].clone()).collect()
                }
                _ => return Err(format!("{}: internal error: stage missing", p.name)),
            };
            components.push(comps);
        }
        let keypoints = match (&embedded, &mser) {
            (Some(e), _) => e.keypoints.len(),
            (None, Some(m)) => m.keypoints.len(),
            (None, None) => 0,
        };
        if let Some(map) = map {
            let pullback =
                Pullback::new(&null.mesh, &null.topo, &map).map_err(|e| e.to_string())?;
            for per_preset in &mut components {
                for c in per_preset.iter_mut() {
                    *c = pullback.carry(c);
                }
            }
        }
        Ok(Outcome {
            vertices: mesh.num_vertices(),
            faces: mesh.num_faces(),
            keypoints,
            cache,
            cache_error,
            seconds: t0.elapsed().as_secs_f64(),
            components,
        })
    }
}

/// Runs the experiment on `nulls` (see the [module docs](self)); `progress` is called after
/// every shape, from worker threads.
///
/// Errors: a null shape's file cannot be read, or a strength is out of range. Failures of
/// single shapes (a transformation that does not apply, a detection error) are reported in
/// [`Report::skipped`] instead.
pub fn run(
    config: &Config,
    nulls: &[NullSpec],
    progress: &(dyn Fn(Progress<'_>) + Sync),
) -> Result<(Report, RunStats), BenchError> {
    let t0 = Instant::now();
    if let Some(&strength) = config
        .strengths
        .iter()
        .find(|s| !(1..=MAX_STRENGTH).contains(*s))
    {
        return Err(BenchError::InvalidStrength { strength });
    }
    let loaded: Vec<LoadedNull> = nulls
        .iter()
        .map(|spec| -> Result<LoadedNull, BenchError> {
            let mesh = read_mesh(&spec.path)?.mesh;
            let topo = Topology::new(&mesh);
            let areas = vertex_areas(&mesh);
            let referenced = referenced(&mesh);
            Ok(LoadedNull {
                spec: spec.clone(),
                mesh,
                topo,
                areas,
                referenced,
            })
        })
        .collect::<Result<_, _>>()?;

    let mut jobs = Vec::new();
    for (i, null) in loaded.iter().enumerate() {
        jobs.push(Job {
            null: i,
            source: Source::Null,
        });
        if config.isometry {
            for pose in &null.spec.poses {
                if config.strengths.contains(&pose.strength) {
                    jobs.push(Job {
                        null: i,
                        source: Source::Pose(pose.strength, pose.path.clone()),
                    });
                }
            }
        }
        for &kind in &config.kinds {
            for &s in &config.strengths {
                jobs.push(Job {
                    null: i,
                    source: Source::Generated(kind, s),
                });
            }
        }
    }

    let done = AtomicUsize::new(0);
    let total = jobs.len();
    let work = |job: &Job| {
        let out = config.run_job(job, &loaded);
        let name = match job.source {
            Source::Null => loaded[job.null].spec.name.clone(),
            _ => format!(
                "{} {} {}",
                loaded[job.null].spec.name,
                job.kind(),
                job.strength()
            ),
        };
        progress(Progress {
            done: done.fetch_add(1, Ordering::Relaxed) + 1,
            total,
            shape: &name,
        });
        out
    };
    let outcomes: Vec<Result<Outcome, String>> = if config.parallel_shapes {
        jobs.par_iter().map(work).collect()
    } else {
        jobs.iter().map(work).collect()
    };

    // the null shapes' components, per null and preset
    let mut null_components: Vec<Option<&Vec<Vec<Vec<VertexId>>>>> = vec![None; loaded.len()];
    for (job, out) in jobs.iter().zip(&outcomes) {
        if let (Source::Null, Ok(o)) = (&job.source, out) {
            null_components[job.null] = Some(&o.components);
        }
    }
    let mut stats = RunStats::default();
    let mut shapes = Vec::new();
    let mut skipped = Vec::new();
    for (job, out) in jobs.iter().zip(&outcomes) {
        let null = &loaded[job.null];
        let skip = |reason: String| Skipped {
            null: null.spec.name.clone(),
            kind: job.kind().to_owned(),
            strength: job.strength(),
            reason,
        };
        let o = match (out, null_components[job.null]) {
            (Err(reason), _) => {
                skipped.push(skip(reason.clone()));
                continue;
            }
            (Ok(_), None) => {
                skipped.push(skip("the null shape itself could not be evaluated".into()));
                continue;
            }
            (Ok(o), Some(_)) => o,
        };
        match o.cache {
            CacheUse::Hit => stats.cache_hits += 1,
            CacheUse::Corrupt => {
                stats.corrupt_entries += 1;
                stats.computed += 1;
            }
            CacheUse::Miss | CacheUse::Off => stats.computed += 1,
        }
        stats.cache_write_errors.extend(o.cache_error.clone());
        stats.shape_seconds += o.seconds;
        let presets = o
            .components
            .iter()
            .enumerate()
            .map(|(p, comps)| PresetScores {
                components: comps.len(),
                best_overlaps: match (&job.source, null_components[job.null]) {
                    (Source::Null, _) | (_, None) => Vec::new(),
                    (_, Some(nc)) => best_overlaps(&nc[p], comps, &null.areas),
                },
            })
            .collect();
        shapes.push(ShapeReport {
            null: null.spec.name.clone(),
            kind: job.kind().to_owned(),
            strength: job.strength(),
            source: match &job.source {
                Source::Pose(_, p) => p.display().to_string(),
                _ => null.spec.path.display().to_string(),
            },
            vertices: o.vertices,
            faces: o.faces,
            keypoints: o.keypoints,
            presets,
        });
    }

    let thresholds = thresholds();
    let presets = config
        .presets
        .iter()
        .enumerate()
        .map(|(p, spec)| preset_report(spec, p, &shapes, &thresholds))
        .collect();
    stats.seconds = t0.elapsed().as_secs_f64();
    let report = Report {
        format: REPORT_FORMAT,
        seed: config.seed,
        budget: config.budget.describe(),
        budget_rule: config.budget,
        harris: config.harris,
        smacof: config.smacof.clone(),
        geodesic: config.geodesic,
        mser: config.mser,
        surface: config.surface,
        thresholds,
        nulls: nulls.to_vec(),
        presets,
        shapes,
        skipped,
    };
    Ok((report, stats))
}

/// The records of preset `p`, in the paper's row order (then strength).
fn records(shapes: &[ShapeReport], p: usize) -> Vec<Record> {
    let mut r: Vec<Record> = shapes
        .iter()
        .filter(|s| s.kind != "null")
        .map(|s| Record {
            kind: s.kind.clone(),
            strength: s.strength,
            best_overlaps: s.presets[p].best_overlaps.clone(),
        })
        .collect();
    r.sort_by_key(|r| (row_order(&r.kind), r.kind.clone(), r.strength));
    r
}

fn preset_report(
    spec: &PresetSpec,
    p: usize,
    shapes: &[ShapeReport],
    thresholds: &[f64],
) -> PresetReport {
    let records = records(shapes, p);
    let mean_overlap = mean_overlap_table(&records);
    let mean_overlap_per_strength = per_strength_table(&records, &mean_overlap);
    let repeatability_at_0_8 = repeatability_table(&records, PAPER_OVERLAP);
    let component_counts = mean_overlap
        .rows
        .iter()
        .map(|row| {
            let counts = (1..=MAX_STRENGTH)
                .map(|s| {
                    records
                        .iter()
                        .filter(|r| r.kind == row.kind && (1..=s).contains(&r.strength))
                        .map(|r| r.best_overlaps.len())
                        .sum()
                })
                .collect();
            (row.kind.clone(), counts)
        })
        .collect();
    let curves = mean_overlap
        .rows
        .iter()
        .map(|row| {
            let pooled: Vec<f64> = records
                .iter()
                .filter(|r| r.kind == row.kind)
                .flat_map(|r| r.best_overlaps.iter().copied())
                .collect();
            CurveReport {
                kind: row.kind.clone(),
                label: row_label(&row.kind).to_owned(),
                components: pooled.len(),
                values: repeatability_curve(&pooled, thresholds),
            }
        })
        .collect();
    PresetReport {
        preset: spec.clone(),
        mean_overlap,
        mean_overlap_per_strength,
        repeatability_at_0_8,
        component_counts,
        curves,
        paper: paper_table(&spec.paper_name),
    }
}

/// Mean best overlap per kind (the rows of `layout`) and exact strength, with the mean row.
fn per_strength_table(records: &[Record], layout: &CumulativeTable) -> CumulativeTable {
    let mean = |b: &[f64]| (!b.is_empty()).then(|| b.iter().sum::<f64>() / b.len() as f64);
    let rows: Vec<TableRow> = layout
        .rows
        .iter()
        .map(|row| TableRow {
            kind: row.kind.clone(),
            values: (1..=MAX_STRENGTH)
                .map(|s| {
                    let pooled: Vec<f64> = records
                        .iter()
                        .filter(|r| r.kind == row.kind && r.strength == s)
                        .flat_map(|r| r.best_overlaps.iter().copied())
                        .collect();
                    mean(&pooled)
                })
                .collect(),
        })
        .collect();
    let average = (0..usize::from(MAX_STRENGTH))
        .map(|c| {
            let present: Vec<f64> = rows.iter().filter_map(|r| r.values[c]).collect();
            mean(&present)
        })
        .collect();
    CumulativeTable { rows, average }
}

fn cell(v: Option<f64>) -> String {
    v.map_or_else(|| "–".to_owned(), |x| format!("{x:.2}"))
}

impl Report {
    /// A preset's parameters in words: `R 0.15, T 0.3, N 30, σ 1.5` for key-components, the
    /// weights, times, eigenpairs and stability parameters for the MSER methods.
    pub fn preset_parameters(&self, p: &PresetSpec) -> String {
        match p.method {
            Method::Kc => {
                let sphere = match p.sphere {
                    SphereRule::Enclosing => String::new(),
                    SphereRule::Spread { factor } => format!(", spread sphere ×{factor}"),
                };
                let smoothing = match self.harris.smoothing_iterations {
                    0 => String::new(),
                    n => format!(", Harris after {n} Taubin pairs"),
                };
                format!(
                    "R {}, T {}, N {}, σ {}{sphere}{smoothing}",
                    p.cluster.r, p.cluster.t, p.cluster.n_min, p.sigma
                )
            }
            Method::Mser | Method::MserKc => {
                let m = &self.mser;
                format!(
                    "{} weights, t {}·area, {} eigenpairs, Δ {}, area {}–{}, max variation {}, \
                     min diversity {}; HKS keypoints at t {}·area",
                    m.weighting,
                    m.time,
                    m.eigenpairs,
                    m.stable.delta,
                    m.stable.min_area,
                    m.stable.max_area,
                    m.stable.max_variation,
                    m.stable.min_diversity,
                    m.keypoint_time
                )
            }
        }
    }

    /// The tables as markdown: per preset, the paper's Table 1 layout with "ours / paper" in
    /// each cell, repeatability at overlap 0.8, and the null shapes' detections; then the
    /// skipped shapes.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        // writing into a String cannot fail
        let _ = writeln!(s, "Keypoint budget: {}.", self.budget);
        let _ = writeln!(
            s,
            "Null shapes: {}; {} shapes evaluated, {} skipped; transformation seed {}.\n",
            self.nulls
                .iter()
                .map(|n| n.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            self.shapes.len(),
            self.skipped.len(),
            self.seed
        );
        for (p, pr) in self.presets.iter().enumerate() {
            let source = pr.paper.map_or("", |t| t.source);
            let _ = writeln!(
                s,
                "### {} ({}): average overlap{}\n",
                pr.preset.name,
                self.preset_parameters(&pr.preset),
                if pr.paper.is_some() {
                    format!(", ours / paper ({source})")
                } else {
                    String::new()
                }
            );
            let _ = writeln!(
                s,
                "| Transform. | 1 | ≤ 2 | ≤ 3 | ≤ 4 | ≤ 5 | components (≤ 5) | repeatability at 0.8 (≤ 5) |"
            );
            let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|");
            for (i, row) in pr.mean_overlap.rows.iter().enumerate() {
                let paper = pr.paper.and_then(|t| t.row(&row.kind));
                let cells: Vec<String> = row
                    .values
                    .iter()
                    .enumerate()
                    .map(|(c, v)| match paper {
                        Some(pv) => format!("{} / {:.2}", cell(*v), pv[c]),
                        None => cell(*v),
                    })
                    .collect();
                let count = pr
                    .component_counts
                    .get(i)
                    .and_then(|(_, v)| v.last())
                    .copied();
                let rep = pr
                    .repeatability_at_0_8
                    .rows
                    .get(i)
                    .and_then(|r| r.values.last().copied().flatten());
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} |",
                    row_label(&row.kind),
                    cells.join(" | "),
                    count.unwrap_or(0),
                    cell(rep)
                );
            }
            let avg: Vec<String> = pr
                .mean_overlap
                .average
                .iter()
                .enumerate()
                .map(|(c, v)| match pr.paper {
                    Some(t) => format!("{} / {:.2}", cell(*v), t.average[c]),
                    None => cell(*v),
                })
                .collect();
            let rep_avg = pr.repeatability_at_0_8.average.last().copied().flatten();
            let _ = writeln!(s, "| Average | {} | | {} |", avg.join(" | "), cell(rep_avg));
            let _ = writeln!(
                s,
                "\n{}, ours per exact strength (= s, not pooled; components per strength):\n",
                pr.preset.name
            );
            let _ = writeln!(s, "| Transform. | = 1 | = 2 | = 3 | = 4 | = 5 |");
            let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|");
            let table = &pr.mean_overlap_per_strength;
            for (i, row) in table.rows.iter().enumerate() {
                let counts = pr.component_counts.get(i).map(|(_, v)| v.as_slice());
                let cells: Vec<String> = row
                    .values
                    .iter()
                    .enumerate()
                    .map(|(c, v)| {
                        // counts are cumulative: this strength's is the difference
                        let n = counts.map_or(0, |k| {
                            let upto = |i: usize| k.get(i).copied().unwrap_or(0);
                            upto(c).saturating_sub(if c > 0 { upto(c - 1) } else { 0 })
                        });
                        format!("{} ({n})", cell(*v))
                    })
                    .collect();
                let _ = writeln!(s, "| {} | {} |", row_label(&row.kind), cells.join(" | "));
            }
            let avg: Vec<String> = table.average.iter().map(|v| cell(*v)).collect();
            let _ = writeln!(s, "| Average | {} |", avg.join(" | "));
            let _ = writeln!(s);
            // the null shapes' own detections explain empty or weak rows
            let nulls: Vec<String> = self
                .shapes
                .iter()
                .filter(|sh| sh.kind == "null")
                .map(|sh| format!("{} {}", sh.null, sh.presets[p].components))
                .collect();
            let _ = writeln!(s, "Components on the null shapes: {}.\n", nulls.join(", "));
        }
        if !self.skipped.is_empty() {
            let _ = writeln!(s, "Skipped:");
            for k in &self.skipped {
                let _ = writeln!(s, "- {} {} {}: {}", k.null, k.kind, k.strength, k.reason);
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_components::Preset;
    use keycomp_mesh::{synth, write_off};

    /// The paper's presets with N = 8, so the small test shape has components.
    fn presets() -> Vec<PresetSpec> {
        Preset::ALL
            .iter()
            .map(|p| {
                let c = p.component_params();
                PresetSpec {
                    name: format!("{p}*"),
                    method: Method::Kc,
                    cluster: ClusterParams {
                        n_min: 8,
                        ..c.cluster
                    },
                    sigma: c.sigma,
                    sphere: c.sphere,
                    paper_name: p.to_string(),
                }
            })
            .collect()
    }

    fn config(kinds: Vec<Kind>, strengths: Vec<u8>, cache: Option<EmbeddingCache>) -> Config {
        Config {
            presets: presets(),
            harris: HarrisParams::default(),
            budget: Budget::PerShape(Selection::Fraction(0.01)),
            smacof: SmacofParams::default(),
            geodesic: GeodesicOptions::default(),
            mser: MserParams::default(),
            kinds,
            isometry: true,
            strengths,
            seed: 3,
            cache,
            parallel_shapes: true,
            surface: None,
        }
    }

    #[test]
    fn discovers_the_shared_layout_and_flat_folders() {
        let dir = tempfile::tempdir().unwrap();
        let tosca = dir.path().join("tosca");
        let kids = dir.path().join("kids");
        std::fs::create_dir_all(&tosca).unwrap();
        std::fs::create_dir_all(&kids).unwrap();
        for f in [
            "cat0.off",
            "cat1.off",
            "cat10.off",
            "cat2.off",
            "cat3.off",
            "cat4.off",
            "cat5.off",
            "cat6.off",
            "wolf0.off",
            "wolf2.off",
            "lion3.off",
            "notes.txt",
        ] {
            std::fs::write(tosca.join(f), "").unwrap();
        }
        for f in [
            "0001.null.0.off",
            "0001.isometry.2.off",
            "0001.isometry.1.off",
        ] {
            std::fs::write(kids.join(f), "").unwrap();
        }
        let faust = dir.path().join("faust");
        std::fs::create_dir_all(&faust).unwrap();
        for f in [
            "tr_reg_000.ply",
            "tr_reg_001.ply",
            "tr_reg_003.ply",
            "tr_reg_010.ply",
        ] {
            std::fs::write(faust.join(f), "").unwrap();
        }
        let nulls = discover(dir.path()).unwrap();
        let names: Vec<&str> = nulls.iter().map(|n| n.name.as_str()).collect();
        assert_eq!(names, ["cat0", "wolf0", "kids-0001", "faust-000"]);
        let fp: Vec<u8> = nulls[3].poses.iter().map(|p| p.strength).collect();
        assert_eq!(
            fp,
            [1, 3],
            "subject 0's poses 1 and 3; tr_reg_010 is subject 1"
        );
        let cat: Vec<(u8, String)> = nulls[0]
            .poses
            .iter()
            .map(|p| (p.strength, stem(&p.path)))
            .collect();
        // numeric order, at most five
        assert_eq!(
            cat,
            [
                (1, "cat1"),
                (2, "cat2"),
                (3, "cat3"),
                (4, "cat4"),
                (5, "cat5")
            ]
            .map(|(s, n)| (s, n.to_owned()))
        );
        assert_eq!(nulls[1].poses.len(), 1);
        assert_eq!(nulls[1].poses[0].strength, 1);
        assert_eq!(nulls[2].poses.len(), 2);
        assert_eq!(stem(&nulls[2].poses[1].path), "0001.isometry.2");

        // a flat folder: every mesh is a null shape
        let flat = dir.path().join("flat");
        std::fs::create_dir_all(&flat).unwrap();
        std::fs::write(flat.join("b.off"), "").unwrap();
        std::fs::write(flat.join("a.ply"), "").unwrap();
        std::fs::write(flat.join("readme.md"), "").unwrap();
        let nulls = discover(&flat).unwrap();
        assert_eq!(
            nulls.iter().map(|n| n.name.as_str()).collect::<Vec<_>>(),
            ["a", "b"]
        );
        assert!(nulls.iter().all(|n| n.poses.is_empty()));

        let empty = dir.path().join("empty");
        std::fs::create_dir_all(&empty).unwrap();
        let e = discover(&empty).unwrap_err().to_string();
        assert!(e.contains("empty") && e.contains("no null shape"), "{e}");
        let e = discover(&dir.path().join("missing"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing") && e.contains("no such folder"), "{e}");
    }

    #[test]
    fn fraction_budgets_resolve_to_the_same_keypoints_as_harris() {
        let mesh = synth::textured_protrusion_sphere(4);
        let f = HarrisParams::default();
        let cfg = config(vec![], vec![1], None);
        let resolved = HarrisParams {
            selection: cfg.selection_for(&mesh, 0),
            ..f
        };
        assert!(matches!(resolved.selection, Selection::Count(_)));
        let s = SmacofParams::default();
        assert_eq!(
            embed(&mesh, &f, &s, &cfg.geodesic).unwrap(),
            embed(&mesh, &resolved, &s, &cfg.geodesic).unwrap()
        );
        let calibrated = Config {
            budget: Budget::NullCalibrated(0.01),
            ..cfg
        };
        assert_eq!(
            calibrated.selection_for(&mesh, 12_345),
            Selection::Count(123)
        );
        assert_eq!(fraction_count(0.01, 10), 1);
    }

    #[test]
    fn canonical_surfaces_carry_components_back_to_the_shapes_vertices() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = synth::textured_protrusion_sphere(5);
        write_off(&mesh, &dir.path().join("proto.off")).unwrap();
        let nulls = discover(dir.path()).unwrap();
        let cfg = Config {
            surface: Some(SurfaceParams {
                vertices: 3000,
                ..SurfaceParams::default()
            }),
            ..config(vec![Kind::Scale], vec![1], None)
        };
        let (report, _) = run(&cfg, &nulls, &|_| {}).unwrap();
        assert!(report.skipped.is_empty(), "{:?}", report.skipped);
        assert_eq!(report.surface, cfg.surface);
        // KC-1* and KC-2* find a component on the sphere's canonical surface and again on its
        // scaled copy's (grid rounding makes the two surfaces differ by a few vertices)
        for pr in &report.presets[..2] {
            let scale = pr.mean_overlap.rows[0].values[0].unwrap();
            assert!(scale > 0.8, "{}: {scale}", pr.preset.name);
        }
        let n = mesh.num_vertices() as VertexId;
        for s in &report.shapes {
            assert!(s.presets[0].components > 0, "{} has no component", s.kind);
            assert_eq!(
                s.vertices,
                mesh.num_vertices(),
                "counts are the shape's own"
            );
        }
        // the carried components are sets of the null shape's vertices
        let outcome = cfg
            .run_job(
                &Job {
                    null: 0,
                    source: Source::Null,
                },
                &[LoadedNull {
                    spec: nulls[0].clone(),
                    topo: Topology::new(&mesh),
                    areas: vertex_areas(&mesh),
                    referenced: referenced(&mesh),
                    mesh: mesh.clone(),
                }],
            )
            .unwrap();
        let c = &outcome.components[0][0];
        assert!(!c.is_empty() && c.windows(2).all(|w| w[0] < w[1]) && c[c.len() - 1] < n);
    }

    #[test]
    fn scale_repeats_perfectly_and_the_cache_reproduces_the_run() {
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        std::fs::create_dir_all(&data).unwrap();
        write_off(
            &synth::textured_protrusion_sphere(5),
            &data.join("proto.off"),
        )
        .unwrap();
        let nulls = discover(&data).unwrap();
        let cache = EmbeddingCache::new(dir.path().join("cache"));
        let cfg = config(vec![Kind::Scale, Kind::Noise], vec![1, 2], Some(cache));
        let calls = AtomicUsize::new(0);
        let count = |p: Progress<'_>| {
            assert_eq!(p.total, 5);
            calls.fetch_add(1, Ordering::Relaxed);
        };
        let (report, stats) = run(&cfg, &nulls, &count).unwrap();
        assert_eq!(calls.load(Ordering::Relaxed), 5);
        assert_eq!(stats.computed, 5);
        assert_eq!(report.shapes.len(), 5);
        assert!(report.skipped.is_empty(), "{:?}", report.skipped);
        for pr in &report.presets {
            // rows in the paper's order: scale before noise
            let scale = &pr.mean_overlap.rows[0];
            assert_eq!(scale.kind, "scale");
            // scale invariance: the same components, exactly
            let v = scale.values[1].unwrap();
            assert!(v > 0.999, "{}: {v}", pr.preset.name);
            assert_eq!(pr.curves.len(), 2);
            assert_eq!(pr.curves[0].values.len(), report.thresholds.len());
            assert_eq!(pr.curves[0].values[0], 1.0);
        }
        assert_eq!(report.presets[0].paper.unwrap().preset, "KC-1");
        // second run: everything from the cache, identical report
        let (again, stats) = run(&cfg, &nulls, &|_| {}).unwrap();
        assert_eq!(stats.cache_hits, 5);
        assert_eq!(stats.computed, 0);
        assert_eq!(again, report);
        // sequential gives the same report
        let seq = Config {
            parallel_shapes: false,
            cache: None,
            ..cfg
        };
        assert_eq!(run(&seq, &nulls, &|_| {}).unwrap().0, report);
        let md = report.markdown();
        assert!(md.contains("| Scale | 1.00 / 0.95"), "{md}");
        assert!(md.contains("| Average |"), "{md}");
    }

    #[test]
    fn mser_methods_run_beside_key_components_and_are_cached() {
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        std::fs::create_dir_all(&data).unwrap();
        write_off(&synth::protrusion_sphere(4, 0.8, 0.25), &data.join("p.off")).unwrap();
        let nulls = discover(&data).unwrap();
        let cache = EmbeddingCache::new(dir.path().join("cache"));
        let mut cfg = config(vec![Kind::Scale], vec![1], Some(cache));
        cfg.presets = [Method::Mser, Method::MserKc]
            .into_iter()
            .filter_map(PresetSpec::mser)
            .collect();
        let (report, stats) = run(&cfg, &nulls, &|_| {}).unwrap();
        assert!(report.skipped.is_empty(), "{:?}", report.skipped);
        assert_eq!(stats.computed, 2);
        let null = &report.shapes[0];
        assert_eq!(null.kind, "null");
        // six protrusions: six HKS keypoints, at least six MSER components, and the covering
        // set is one component per protrusion
        assert_eq!(null.keypoints, 6);
        assert!(null.presets[0].components >= 6, "{null:?}");
        assert_eq!(null.presets[1].components, 6, "{null:?}");
        for pr in &report.presets {
            let v = pr.mean_overlap.rows[0].values[0].unwrap();
            assert!(v > 0.99, "{}: scale overlap {v}", pr.preset.name);
        }
        assert_eq!(
            report.presets[0].paper.unwrap().source,
            "Sipiran & Bustos 2013, Table 5"
        );
        assert_eq!(
            report.presets[1].paper.unwrap().source,
            "Sipiran & Bustos 2013, Table 6"
        );
        let md = report.markdown();
        assert!(md.contains("### MSER-KC (edge weights"), "{md}");
        // second run from the cache: same report
        let (again, stats) = run(&cfg, &nulls, &|_| {}).unwrap();
        assert_eq!(stats.cache_hits, 2);
        assert_eq!(again, report);
    }

    #[test]
    fn per_strength_table_does_not_pool() {
        let rec = |kind: &str, strength, b: Vec<f64>| Record {
            kind: kind.into(),
            strength,
            best_overlaps: b,
        };
        let records = vec![
            rec("sampling", 1, vec![0.6, 0.8]),
            rec("sampling", 2, vec![0.1]),
            rec("noise", 1, vec![1.0]),
        ];
        let cumulative = mean_overlap_table(&records);
        let t = per_strength_table(&records, &cumulative);
        assert_eq!(t.rows[0].kind, "sampling");
        assert!((t.rows[0].values[0].unwrap() - 0.7).abs() < 1e-12);
        assert!((t.rows[0].values[1].unwrap() - 0.1).abs() < 1e-12);
        assert_eq!(t.rows[0].values[2], None);
        // pooled ≤ 2 is (0.6 + 0.8 + 0.1) / 3
        assert!((cumulative.rows[0].values[1].unwrap() - 0.5).abs() < 1e-12);
        assert!((t.average[0].unwrap() - 0.85).abs() < 1e-12);
        assert!((t.average[1].unwrap() - 0.1).abs() < 1e-12);
    }

    #[test]
    fn inapplicable_transformations_are_skipped_with_a_reason() {
        let dir = tempfile::tempdir().unwrap();
        write_off(&synth::icosphere(3, 1.0), &dir.path().join("ball.off")).unwrap();
        let nulls = discover(dir.path()).unwrap();
        let cfg = config(vec![Kind::Topology], vec![1], None);
        let (report, _) = run(&cfg, &nulls, &|_| {}).unwrap();
        assert_eq!(report.skipped.len(), 1);
        assert_eq!(report.skipped[0].kind, "topology");
        assert!(
            report.skipped[0].reason.contains("weld"),
            "{:?}",
            report.skipped
        );
        let bad = Config {
            strengths: vec![6],
            ..cfg
        };
        assert!(matches!(
            run(&bad, &nulls, &|_| {}),
            Err(BenchError::InvalidStrength { strength: 6 })
        ));
    }
}
