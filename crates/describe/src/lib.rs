//! Descriptors of a shape's parts, for retrieval and part-to-part matching.
//!
//! A shape is described by *parts* built on its key-components (Sipiran & Bustos,
//! "Key-components: detection of salient regions on 3D meshes", The Visual Computer 29, 2013):
//! each part gets one fixed-length vector of [`DIM`] numbers built from the Harris response
//! inside it, geodesic statistics around its centre, curvature and point-pair statistics, and
//! the shape gets a *layout*: the geodesic distances between its parts' centres, used to check
//! that matched parts sit in the same arrangement (DESIGN "Retrieval").
//!
//! # Parts
//!
//! 1. **Key-components** (level 0): the components of the detection, as found.
//! 2. **Patches** (levels 1..=L): for each radius r of [`DescribeParams::levels`] (in the
//!    length unit, see [`Units`]), geodesic balls of radius r centred on the detection's
//!    keypoints, best response first, skipping a keypoint closer than r to a centre already
//!    taken, then (when the keypoints run out) on the vertex farthest from every centre, up to
//!    [`DescribeParams::patches_per_level`] per level. The radii form a geometric series
//!    (factor 1.5), so a fragment scaled to its own unit area still finds, one or two levels
//!    lower, patches of the size of the whole shape's; the descriptors are scale-free, so parts
//!    of different levels are compared directly and the layout check estimates the scale. A
//!    query with a boundary is described one and two steps up the ladder, two scale
//!    hypotheses ([`DescribeParams::for_query`]), so that its radii meet the collection's at
//!    the kept fractions fragments usually have.
//! 3. **The whole surface** (level L + 1), centred on the vertex nearest the area-weighted
//!    centroid, unless [`DescribeParams::whole`] is off. Its layout distances are
//!    [`NO_DISTANCE`].
//!
//! With [`DescribeParams::complete_only`] (off by default: it made fragment retrieval worse,
//! BENCHMARKS.md), parts that reach the mesh's boundary are left out (patch centres that give
//! one are skipped, at most twice the level's budget of fronts is spent), unless the mesh has
//! no complete part at all.
//!
//! So every shape with at least one vertex has parts, whether or not the detection found
//! key-components, and a shape has tens of them instead of the detection's 0–5.
//!
//! # The descriptor, bin by bin
//!
//! Every entry but entry 31 in file units is invariant to rigid motion and to uniform scale: histograms are of ratios, and
//! the scalars are ratios of lengths or areas measured on the part itself, never on the whole
//! shape. Histograms are area-weighted (barycentric vertex areas; pairs are drawn by area) and
//! each sums to 1, so they do not depend on the tessellation's density.
//!
//! | bins | what | why |
//! |---|---|---|
//! | 0–7 | Harris response (recomputed on the smoothed surface, see *Smoothing*) `h/h_max` inside the part (`h_max` = its largest response), on a log scale: bin `b` holds `log10(h/h_max) ∈ [−(8−b)/2, −(7−b)/2)`, bin 0 also everything below 10⁻⁴ and `h ≤ 0` | how concentrated the salient features are: a sharp tip has a few strong responses, a textured region many similar ones |
//! | 8–15 | geodesic distance from the centre divided by the part's geodesic radius (largest such distance), 8 equal bins over [0, 1] | how area grows with distance: a disc grows linearly, a finger stays flat, a cone grows fast |
//! | 16–23 | `‖x − c‖ / d_geo(c, x)` for vertices beyond 20 % of the radius, 8 equal bins over [0, 1] | bending: 1 on a flat patch, lower the more the surface curls back (a fingertip, an ear) |
//! | 24–27 | angle between each vertex normal and the part's mean normal, 4 equal bins over [0, π] | how much the surface turns: flat, cap, tube, or wrapped |
//! | 28 | `ln(radius / √area)` of the part, shifted by `ln(1/√π)` (0 for a flat disc) | elongation along the surface |
//! | 29 | `λ2/λ1` of the part's vertex covariance | in-space elongation |
//! | 30 | `λ3/λ1` of the same | flatness (0 flat, 1 ball-like) |
//! | 31 | scale-free: keypoint density `(K_c/V_c)/(K/V)` mapped by `x/(1+x)`; file units: [`SIZE_WEIGHT`]` · ln(radius)`, the radius in the length unit | how much of the shape's saliency the part gathers; in file units, how big the part is (the one entry that is not scale-invariant, since sizes are comparable there) |
//! | 32–39 | shape index `(2/π)·atan2(κ1 + κ2, κ1 − κ2)` (Koenderink & van Doorn 1992), principal curvatures from the Harris quadratic fit (the same fit as bins 0–7) oriented by the vertex normal, 8 equal bins over [−1, 1] | the local surface type: cup, rut, saddle, ridge, cap |
//! | 40–47 | curvedness `√((κ1² + κ2²)/2)` times the part's radius, `log10` in 8 equal bins over [−2, 1] | how curved the surface is relative to the part's size |
//! | 48–55 | Euclidean distance of [`PAIRS`] area-sampled point pairs over twice the radius, 8 equal bins over [0, 1] (D2 of Osada et al. 2002, inside the part) | the part's extent in space: compact or spread |
//! | 56–63 | angle between the normals of the same pairs, 8 equal bins over [0, π] | how the part's orientations are distributed (a surflet-pair statistic, Wahl et al. 2003) |
//!
//! Scalars are weighted ([`SCALAR_WEIGHT`]) so that each is worth about one histogram bin
//! difference at most. Euclidean distance between descriptors is the dissimilarity. The pairs
//! are drawn by a generator seeded by the part's centre and level: the same mesh gives the same
//! numbers.
//!
//! # Smoothing
//!
//! Everything above is measured on a smoothed copy of the surface (the shape in its length
//! unit, then [`DescribeParams::smoothing_iterations`] = 30 Taubin λ|μ pairs, [`smooth`]), with
//! the Harris fit recomputed there; key-components' vertices, the keypoints and the centres
//! come from the detection on the surface as it is. Per-vertex responses and normals are what
//! Gaussian noise scrambles, and noise lengthens geodesics: described on the raw surface,
//! corresponding components under the benchmark's noise (strength 3) were as far apart as
//! unrelated ones (median 0.91 vs 0.99); on the smoothed copy 0.28 vs 0.53 (BENCHMARKS.md,
//! *Descriptors under the benchmark transformations*, measured with the 32-value descriptor of
//! version 2). Smoothing before measuring is a choice of ours, not the paper's (the paper does
//! not describe components).
//!
//! Cost: 60 smoothing passes over the whole mesh, a Harris fit per vertex as costly as
//! detection's own, one fast-marching front per distinct part centre (kept for the layout: with
//! the defaults about 100 fronts of |V| `f64` each, about 100 MB at 134k vertices; the
//! parameters are bounded by [`MAX_LEVELS`], [`MAX_PATCHES_PER_LEVEL`] and
//! [`MAX_SMOOTHING_ITERATIONS`]),
//! plus linear passes over each part's vertices and [`PAIRS`] draws per part. The levels choose
//! their centres in parallel and the parts' fronts and descriptors are computed in parallel
//! (rayon); a front asked for by two threads runs once, and the result does not depend on the
//! thread count.
//!
//! Describing on a simplified proxy instead of the mesh was tried and left out (BENCHMARKS.md
//! section 2, *Description on a proxy*): it made description much cheaper but lowered the
//! retrieval of TOSCA fragments, whose own descriptions are made at full resolution.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use keycomp_components::Detection;
use keycomp_geodesic::{GeodesicError, GeodesicSolver};
use keycomp_harris::LocalFit;
use keycomp_mesh::{Mesh, Topology, Vector3, geometry};
use nalgebra::Matrix3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Taubin λ|μ smoothing, now in `keycomp_mesh` (re-exported here for existing callers).
pub use keycomp_mesh::smooth;

/// Version of the descriptor's definition: bumped whenever the same mesh and detection would
/// give other numbers, so that an index never compares descriptors made two ways (the CLI
/// records it in the index's profile). Version 3: 64 values per part, parts at several scales
/// (see *Parts*); version 2 (32 values, the detection's key-components only) is no longer made.
pub const DESCRIPTOR_VERSION: u32 = 3;

/// The length unit shapes are measured in before description.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Units {
    /// Scale-free: every mesh is scaled to unit area on its own, so a fragment is measured in
    /// units of its own size (the default).
    #[default]
    ScaleFree,
    /// Known units: every mesh is measured in file units divided by `length` (the collection's
    /// typical size, e.g. the square root of its median area), so a fragment keeps its
    /// source's scale.
    File {
        /// The length unit, in file units (> 0).
        length: f64,
    },
}

/// Parameters of [`describe_with`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DescribeParams {
    /// Taubin λ|μ pairs applied to the surface before describing (see *Smoothing*). Default 30;
    /// 0 describes the surface as it is.
    pub smoothing_iterations: usize,
    /// Harris 3D settings of the response and curvature histograms, computed on the smoothed
    /// surface. Default: the detector's defaults, whatever the detection used, so that every
    /// shape of an index is described alike.
    pub harris: keycomp_harris::HarrisParams,
    /// Geodesic radii of the patch levels, in the length unit of [`DescribeParams::units`]
    /// (see *Parts*). Default 0.06, 0.09, 0.135, 0.2, 0.3, 0.45 (factor 1.5).
    pub levels: Vec<f64>,
    /// Most patches per level. Default 16 (on SHREC'07 Watertight, 6, 10 and 16 gave fragment NN
    /// 0.670, 0.760 and 0.870 for balls and 0.395, 0.430, 0.565 for scans: BENCHMARKS.md).
    pub patches_per_level: usize,
    /// Adds the whole surface as one more part. Default true.
    pub whole: bool,
    /// Length unit. Default [`Units::ScaleFree`].
    pub units: Units,
    /// Leaves out parts that reach the mesh's boundary, unless no part is complete (see
    /// *Parts*). Default false: on SHREC'07 Watertight fragments (with 6 patches per level and
    /// inverse-frequency weights) it lowered NN from 0.625 to 0.550 (balls), 0.825 to 0.730
    /// (plane cuts) and 0.395 to 0.280 (scans) (BENCHMARKS.md, *Ablation*).
    pub complete_only: bool,
    /// How far (in the length unit) the fronts from patch centres run, at least their level's
    /// radius; `None` runs every front over the whole mesh. Layout distances beyond the reach
    /// are [`NO_DISTANCE`] (matching checks only the pairs it has), and a level's centres
    /// beyond the reach of every centre taken are chosen by Euclidean distance. Fronts from
    /// key-components and the whole surface always run over the whole mesh.
    pub layout_reach: Option<f64>,
}

impl Default for DescribeParams {
    fn default() -> Self {
        DescribeParams {
            smoothing_iterations: 30,
            harris: keycomp_harris::HarrisParams::default(),
            levels: vec![0.06, 0.09, 0.135, 0.2, 0.3, 0.45],
            patches_per_level: 16,
            whole: true,
            units: Units::ScaleFree,
            complete_only: false,
            layout_reach: None,
        }
    }
}

/// Factors on a scale-free fragment query's patch radii, one per scale hypothesis
/// ([`DescribeParams::for_query`]): one and two steps of the default ladder of radii.
pub const FRAGMENT_LEVEL_FACTORS: [f64; 2] = [1.5, 2.25];

impl DescribeParams {
    /// The parameters a query `mesh` is described with against shapes described with `self`:
    /// one set, or one per scale hypothesis (the query is then ranked under each, and each
    /// shape keeps its best score: `keycomp_retrieval::rank_hypotheses`).
    ///
    /// Scale-free, every mesh is scaled to unit area on its own, so a fragment that keeps the
    /// share f of its source's area is magnified by 1/√f against its source: 1.3 to 2.2 for
    /// f from 60 % down to 20 %. Its patches of radius r cover what patches of radius r·√f
    /// cover on the source, so its smallest level holds patches smaller than any of the
    /// source's and the source's largest levels have no counterpart. A query with a boundary
    /// (a fragment, a scan) is therefore described with its radii multiplied by each of
    /// [`FRAGMENT_LEVEL_FACTORS`] (1/√f for f = 44 % and 20 %; steps of the default ladder,
    /// so most of its radii are the collection's, and a shape with holes queried whole still
    /// meets its own patches). A closed mesh, and every mesh in file units (where a fragment
    /// keeps its source's scale), is described with `self`.
    pub fn for_query(&self, mesh: &Mesh) -> Vec<DescribeParams> {
        self.for_query_with_boundary(!Topology::new(mesh).boundary_vertices().is_empty())
    }

    /// [`DescribeParams::for_query`] for a query that has a boundary or not (as an index
    /// record says, `boundary_vertices > 0`).
    pub fn for_query_with_boundary(&self, boundary: bool) -> Vec<DescribeParams> {
        match self.units {
            Units::ScaleFree if boundary => FRAGMENT_LEVEL_FACTORS
                .iter()
                .map(|f| DescribeParams {
                    levels: self.levels.iter().map(|r| r * f).collect(),
                    ..self.clone()
                })
                .collect(),
            _ => vec![self.clone()],
        }
    }
}

/// Number of values in a component descriptor.
pub const DIM: usize = 64;

/// The descriptor's histograms, as `(first, end)` entry ranges: each sums to 1 (or is all 0
/// when the part has nothing to count); the other entries (28–31) are scalars.
pub const HISTOGRAMS: [(usize, usize); 8] = [
    (0, 8),
    (8, 16),
    (16, 24),
    (24, 28),
    (32, 40),
    (40, 48),
    (48, 56),
    (56, 64),
];

/// Weight of the four scalar entries (28–31) relative to histogram bins.
pub const SCALAR_WEIGHT: f32 = 0.5;

/// Weight of entry 31 in file units, `ln(radius)`: parts of neighbouring levels (radii 1.5
/// apart) differ there by 0.3, against the 0.7 at which matching similarity reaches 0.
pub const SIZE_WEIGHT: f32 = 0.75;

/// Random point pairs drawn per part for the pair histograms (bins 48–63).
pub const PAIRS: usize = 512;

/// Most patch levels [`describe_with`] accepts.
pub const MAX_LEVELS: usize = 12;
/// Most patches per level [`describe_with`] accepts.
pub const MAX_PATCHES_PER_LEVEL: usize = 64;
/// Most smoothing iterations [`describe_with`] accepts.
pub const MAX_SMOOTHING_ITERATIONS: usize = 1000;

/// Points of a description's surface sample ([`ShapeDescription::sample`]).
pub const SAMPLE_POINTS: usize = 512;

/// Seed of the surface sample's random stream.
pub const SAMPLE_SEED: u64 = 0x005a_3b1e;

/// Layout entry of a pair of parts without a meaningful distance (the whole-surface part).
pub const NO_DISTANCE: f32 = -1.0;

/// A key-component's descriptor.
pub type Descriptor = [f32; DIM];

/// Anything that stops description.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DescribeError {
    /// Geodesic distances failed (the detection does not belong to this mesh).
    #[error(transparent)]
    Geodesic(#[from] GeodesicError),
    /// The detection refers to vertices the mesh does not have.
    #[error(
        "the detection does not belong to this mesh: vertex {vertex} out of range ({vertices} vertices)"
    )]
    Mismatch {
        /// The offending id.
        vertex: u32,
        /// Vertices of the mesh.
        vertices: usize,
    },
    /// The parameters cannot describe anything.
    #[error("invalid description parameters: {0}")]
    Params(String),
}

/// One described part.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComponentDescription {
    /// The descriptor (see the module documentation).
    #[serde(with = "serde_big_array::BigArray")]
    pub descriptor: Descriptor,
    /// The part's centre (vertex id).
    pub center: u32,
    /// Position of the centre in the layout's frame and length unit (the mesh scaled as
    /// [`DescribeParams::units`] says, then smoothed): what matching's pose check compares.
    pub position: [f32; 3],
    /// Area of the part as a fraction of the shape's area.
    pub area: f64,
    /// Number of detection keypoints in the part.
    pub keypoints: usize,
    /// Largest geodesic distance from the centre to a vertex of the part, in the length unit.
    pub radius: f64,
    /// 0: a key-component of the detection; 1..=L: a patch of level L; L + 1: the whole
    /// surface (see *Parts*).
    pub level: u8,
    /// The part's vertices.
    pub vertices: Vec<u32>,
}

/// A shape's parts and their layout.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeDescription {
    /// Key-components first (in detection order), then patches level by level, then the whole
    /// surface.
    pub components: Vec<ComponentDescription>,
    /// Geodesic distances between part centres, `m × m` row-major, in the length unit
    /// (symmetrised; pairs on different connected pieces get twice the largest finite value;
    /// pairs with the whole-surface part get [`NO_DISTANCE`]).
    pub layout: Vec<f32>,
    /// [`SAMPLE_POINTS`] points drawn uniformly by area on the described surface, in the
    /// frame and length unit of the parts' positions (for geometric verification: aligning a
    /// query onto a shape and measuring how much of it lies on the shape); empty for a mesh
    /// without area.
    pub sample: Vec<[f32; 3]>,
    /// Vertices on the mesh's boundary: 0 for a closed surface, more for a fragment or a scan.
    pub boundary_vertices: usize,
}

impl ShapeDescription {
    /// Distance between the centres of components `i` and `j`.
    pub fn layout_distance(&self, i: usize, j: usize) -> f32 {
        self.layout[i * self.components.len() + j]
    }
}

fn area_weighted_normals(mesh: &Mesh) -> Vec<Vector3<f64>> {
    let mut n = vec![Vector3::zeros(); mesh.num_vertices()];
    for (f, tri) in mesh.faces.iter().enumerate() {
        let [a, b, c] = mesh.triangle(f);
        let fnorm = (b - a).cross(&(c - a)); // length = 2·area: area weighting
        for &v in tri {
            n[v as usize] += fnorm;
        }
    }
    for v in &mut n {
        let len = v.norm();
        if len > 0.0 {
            *v /= len;
        }
    }
    n
}

fn bin(x: f64, lo: f64, hi: f64, bins: usize) -> usize {
    let t = ((x - lo) / (hi - lo) * bins as f64).floor();
    if t.is_nan() || t < 0.0 {
        0
    } else {
        (t as usize).min(bins - 1)
    }
}

fn normalise(h: &mut [f32]) {
    let s: f32 = h.iter().sum();
    if s > 0.0 {
        for x in h {
            *x /= s;
        }
    }
}

/// Per-vertex quantities of the smoothed, rescaled surface.
struct Surface {
    mesh: Mesh,
    response: Vec<f64>,
    /// Koenderink's shape index in [−1, 1], NaN without a fit.
    shape_index: Vec<f64>,
    /// Curvedness √((κ1² + κ2²)/2) in inverse length units, NaN without a fit.
    curvedness: Vec<f64>,
    areas: Vec<f64>,
    normals: Vec<Vector3<f64>>,
    total_keypoints: f64,
    vertices: f64,
    /// Entry 31 holds the part's size in the length unit instead of its keypoint density.
    file_units: bool,
    /// Vertices without a Harris response (fits reaching the boundary, `skip_boundary`) are
    /// left out of the response histogram instead of counted in its lowest bin.
    skip_unfitted: bool,
}

/// Principal curvatures of a fit, oriented by `normal` (κ1 ≥ κ2), in the fit's units.
fn curvatures(fit: &LocalFit, normal: &Vector3<f64>) -> (f64, f64) {
    let [p1, p2, p3, ..] = fit.coefficients;
    let mean = 0.5 * (p1 + p3);
    let dev = (0.25 * (p1 - p3) * (p1 - p3) + p2 * p2).sqrt();
    let (k1, k2) = (mean + dev, mean - dev);
    if fit.frame[2].dot(normal) < 0.0 {
        (-k2, -k1)
    } else {
        (k1, k2)
    }
}

/// A front from a part centre: distances up to `limit` (+∞ beyond), `complete` when it covered
/// its whole connected piece.
struct Front {
    limit: f64,
    complete: bool,
    d: Vec<f64>,
}

impl Front {
    /// Whether this front measures everything a front stopped at `limit` measures.
    fn covers(&self, limit: f64) -> bool {
        self.complete || self.limit >= limit
    }
}

/// Fronts from part centres, computed once per centre (again only when a longer reach is
/// asked), from any thread: a thread asking for a centre another is running waits for that
/// front instead of running it twice, and the cache keeps the longest front of each centre, so
/// what it holds once a set of fronts has been asked for does not depend on the order they ran
/// in.
struct Fronts<'a> {
    solver: &'a GeodesicSolver,
    /// Workspaces not in use (one per thread that ran a front).
    spare: Mutex<Vec<keycomp_geodesic::Workspace>>,
    /// Per centre, its longest front so far.
    done: Mutex<HashMap<u32, Arc<Slot>>>,
}

/// A centre's longest front so far, locked while a front from it runs.
type Slot = Mutex<Option<Arc<Front>>>;

impl<'a> Fronts<'a> {
    fn new(solver: &'a GeodesicSolver) -> Self {
        Fronts {
            solver,
            spare: Mutex::new(Vec::new()),
            done: Mutex::new(HashMap::new()),
        }
    }

    /// The front from `c` up to at least `limit`.
    fn get(&self, c: u32, limit: f64) -> Result<Arc<Front>, DescribeError> {
        let slot = lock(&self.done).entry(c).or_default().clone();
        let mut slot = lock(&slot);
        if let Some(f) = slot.as_ref().filter(|f| f.covers(limit)) {
            return Ok(f.clone());
        }
        let spare = lock(&self.spare).pop();
        let mut ws = spare.unwrap_or_else(|| self.solver.workspace());
        let complete = self.solver.solve_within(c, limit, &mut ws)?;
        let front = Front {
            limit,
            complete,
            d: ws.distances().to_vec(),
        };
        lock(&self.spare).push(ws);
        let front = Arc::new(front);
        // what the slot held did not cover `limit`: this front reaches farther
        *slot = Some(front.clone());
        Ok(front)
    }
}

/// Locks `m`, whether or not another thread panicked while holding it (the data are plain
/// caches, complete after every write).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// A part before description.
struct Part {
    center: u32,
    /// How far its centre's front must run (+∞: the whole mesh).
    reach: f64,
    vertices: Vec<u32>,
    keypoints: usize,
    level: u8,
}

/// Describes every key-component of `det`, which must be the detection of `mesh`, with the
/// default [`DescribeParams`].
pub fn describe(mesh: &Mesh, det: &Detection) -> Result<ShapeDescription, DescribeError> {
    describe_with(mesh, det, &DescribeParams::default())
}

/// Describes the parts of `mesh` (see *Parts*): the key-components of `det`, which must be the
/// detection of `mesh`, patches around its keypoints at every level, and the whole surface.
pub fn describe_with(
    mesh: &Mesh,
    det: &Detection,
    params: &DescribeParams,
) -> Result<ShapeDescription, DescribeError> {
    describe_all(mesh, det, std::slice::from_ref(params))?
        .pop()
        .ok_or_else(|| DescribeError::Params("no description parameters".into()))
}

/// [`describe_with`] under each of `all`, in order (a query's scale hypotheses,
/// [`DescribeParams::for_query`]); none for an empty `all`. Parameters that differ from the
/// first only in their levels share its smoothed surface, Harris fits and geodesic fronts,
/// computed once: another ladder of radii costs only the fronts of its new patch centres.
/// Other parameters are described on their own.
pub fn describe_all(
    mesh: &Mesh,
    det: &Detection,
    all: &[DescribeParams],
) -> Result<Vec<ShapeDescription>, DescribeError> {
    let Some(first) = all.first() else {
        return Ok(Vec::new());
    };
    for params in all {
        check(mesh, det, params)?;
    }
    let (surface, boundary, solver) = prepare(mesh, det, first)?;
    let fronts = Fronts::new(&solver);
    all.iter()
        .map(|params| {
            let same_surface = DescribeParams {
                levels: params.levels.clone(),
                ..first.clone()
            } == *params;
            if same_surface {
                describe_parts(&surface, &boundary, det, params, &fronts)
            } else {
                describe_with(mesh, det, params)
            }
        })
        .collect()
}

/// Refuses a detection that is not `mesh`'s and parameters that ask for unbounded work.
fn check(mesh: &Mesh, det: &Detection, params: &DescribeParams) -> Result<(), DescribeError> {
    let n = mesh.num_vertices();
    for &v in det
        .components
        .iter()
        .flat_map(|c| c.vertices.iter().chain(std::iter::once(&c.center)))
        .chain(&det.keypoints)
    {
        if v as usize >= n {
            return Err(DescribeError::Mismatch {
                vertex: v,
                vertices: n,
            });
        }
    }
    // the parameters may come from an index's profile: bound the work and memory they ask for
    // (one front of |V| distances is kept per part centre)
    if params.levels.len() > MAX_LEVELS
        || params.levels.iter().any(|r| !(r.is_finite() && *r > 0.0))
    {
        return Err(DescribeError::Params(format!(
            "levels must be at most {MAX_LEVELS} positive radii, got {:?}",
            params.levels
        )));
    }
    if params.patches_per_level > MAX_PATCHES_PER_LEVEL {
        return Err(DescribeError::Params(format!(
            "at most {MAX_PATCHES_PER_LEVEL} patches per level, got {}",
            params.patches_per_level
        )));
    }
    if params.smoothing_iterations > MAX_SMOOTHING_ITERATIONS {
        return Err(DescribeError::Params(format!(
            "at most {MAX_SMOOTHING_ITERATIONS} smoothing iterations, got {}",
            params.smoothing_iterations
        )));
    }
    if let Units::File { length } = params.units
        && !(length.is_finite() && length > 0.0)
    {
        return Err(DescribeError::Params(format!(
            "the length unit must be positive, got {length}"
        )));
    }
    Ok(())
}

/// The surface `params` describe `mesh` on (scaled to the length unit, smoothed, with its
/// Harris fits), which vertices lie on its boundary, and its geodesic solver.
fn prepare(
    mesh: &Mesh,
    det: &Detection,
    params: &DescribeParams,
) -> Result<(Surface, Vec<bool>, GeodesicSolver), DescribeError> {
    let n = mesh.num_vertices();
    let area = geometry::total_area(mesh);
    let scale = match params.units {
        Units::ScaleFree => {
            if area > 0.0 {
                1.0 / area.sqrt()
            } else {
                1.0
            }
        }
        Units::File { length } => 1.0 / length,
    };
    let mut norm = Mesh {
        positions: mesh.positions.iter().map(|p| p * scale).collect(),
        faces: mesh.faces.clone(),
    };
    let topo = Topology::new(&norm);
    norm.positions = smooth::taubin(&norm, &topo, params.smoothing_iterations);
    let normals = area_weighted_normals(&norm);
    let fits = keycomp_harris::local_fits(&norm, &topo, &params.harris);
    // Fits are in units of the smoothed mesh scaled to unit area; curvatures scale back.
    let norm_area = geometry::total_area(&norm);
    let to_len = if norm_area > 0.0 {
        1.0 / norm_area.sqrt()
    } else {
        1.0
    };
    let mut response = vec![f64::NAN; n];
    let mut shape_index = vec![f64::NAN; n];
    let mut curvedness = vec![f64::NAN; n];
    for (v, f) in fits.iter().enumerate() {
        if let Some(f) = f {
            let h = keycomp_harris::response_from_coefficients(&f.coefficients, params.harris.k);
            response[v] = if h.is_finite() { h } else { f64::NAN };
            let (k1, k2) = curvatures(f, &normals[v]);
            shape_index[v] = (2.0 / std::f64::consts::PI) * (k1 + k2).atan2(k1 - k2);
            curvedness[v] = ((k1 * k1 + k2 * k2) / 2.0).sqrt() * to_len;
        }
    }
    let solver = GeodesicSolver::new(&norm, &topo)?;
    let surface = Surface {
        areas: geometry::vertex_areas(&norm),
        mesh: norm,
        response,
        shape_index,
        curvedness,
        normals,
        total_keypoints: det.keypoints.len().max(1) as f64,
        vertices: n.max(1) as f64,
        file_units: matches!(params.units, Units::File { .. }),
        skip_unfitted: params.harris.skip_boundary,
    };
    let boundary: Vec<bool> = (0..n as u32).map(|v| topo.is_boundary(v)).collect();
    Ok((surface, boundary, solver))
}

/// What every patch level reads (see *Parts*).
struct Levels<'a> {
    surface: &'a Surface,
    boundary: &'a [bool],
    det: &'a Detection,
    /// Whether each vertex is one of the detection's keypoints.
    is_keypoint: &'a [bool],
    params: &'a DescribeParams,
    fronts: &'a Fronts<'a>,
}

/// The patches of one level of radius `radius` (level number `level`), in order, and the
/// clipped ones (see *Parts*).
fn level_patches(
    at: &Levels,
    radius: f64,
    level: u8,
) -> Result<(Vec<Part>, Vec<Part>), DescribeError> {
    let Levels {
        surface,
        boundary,
        det,
        is_keypoint,
        params,
        fronts,
    } = *at;
    let n = surface.mesh.num_vertices();
    let clipped = |vs: &[u32]| params.complete_only && vs.iter().any(|&v| boundary[v as usize]);
    let (mut parts, mut clipped_parts) = (Vec::new(), Vec::new());
    let reach = params.layout_reach.map_or(f64::INFINITY, |r| r.max(radius));
    let mut nearest = vec![f64::INFINITY; n];
    // Euclidean distance to the nearest centre, ranking the vertices beyond the reach
    let mut euclid = vec![f64::INFINITY; n];
    let mut rejected = vec![false; n];
    let (mut chosen, mut fronts_run) = (0, 0);
    let mut candidates = det.keypoints.iter().copied();
    // a front per candidate centre; clipped candidates cost one too, so they are bounded
    while chosen < params.patches_per_level && fronts_run < 2 * params.patches_per_level {
        // keypoints best first, then the vertex farthest from every chosen centre
        let next = candidates
            .by_ref()
            .find(|&k| nearest[k as usize] >= radius && !rejected[k as usize])
            .or_else(|| {
                let far = |v: usize| {
                    if nearest[v].is_finite() || euclid[v].is_infinite() {
                        nearest[v]
                    } else {
                        reach + euclid[v]
                    }
                };
                let (v, d) = (0..n)
                    .filter(|&v| !rejected[v])
                    .map(|v| (v, far(v)))
                    .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))?;
                (d >= radius).then_some(v as u32)
            });
        let Some(c) = next else { break };
        fronts_run += 1;
        let front = fronts.get(c, reach)?;
        // only what a front stopped at `reach` measures, whatever the cache holds
        let d = |v: usize| {
            let x = front.d[v];
            if x <= reach { x } else { f64::INFINITY }
        };
        let vertices: Vec<u32> = (0..n as u32).filter(|&v| d(v as usize) <= radius).collect();
        let part = Part {
            center: c,
            reach,
            keypoints: vertices
                .iter()
                .filter(|&&v| is_keypoint[v as usize])
                .count(),
            vertices,
            level,
        };
        if clipped(&part.vertices) {
            rejected[c as usize] = true;
            if part.vertices.len() >= 3 {
                clipped_parts.push(part);
            }
            continue;
        }
        for (v, m) in nearest.iter_mut().enumerate() {
            *m = m.min(d(v));
        }
        nearest[c as usize] = 0.0;
        if reach.is_finite() {
            let pc = surface.mesh.positions[c as usize];
            for (e, p) in euclid.iter_mut().zip(&surface.mesh.positions) {
                *e = e.min((p - pc).norm());
            }
        }
        chosen += 1;
        if part.vertices.len() >= 3 {
            parts.push(part);
        }
    }
    Ok((parts, clipped_parts))
}

/// The parts of the prepared `surface` under `params` (see *Parts*), their descriptors, layout
/// and the surface sample; fronts come from (and go to) `fronts`.
fn describe_parts(
    surface: &Surface,
    boundary: &[bool],
    det: &Detection,
    params: &DescribeParams,
    fronts: &Fronts,
) -> Result<ShapeDescription, DescribeError> {
    let n = surface.mesh.num_vertices();
    let clipped = |vs: &[u32]| params.complete_only && vs.iter().any(|&v| boundary[v as usize]);
    // parts reaching the boundary, used only when the mesh has no complete part
    let mut clipped_parts: Vec<Part> = Vec::new();
    let total: f64 = surface.areas.iter().sum();
    let mut is_keypoint = vec![false; n];
    for &k in &det.keypoints {
        is_keypoint[k as usize] = true;
    }

    let whole_level = (params.levels.len() + 1).min(255) as u8;
    let mut parts: Vec<Part> = Vec::new();
    for c in &det.components {
        let p = Part {
            center: c.center,
            reach: f64::INFINITY,
            vertices: c.vertices.clone(),
            keypoints: c.keypoints.len(),
            level: 0,
        };
        if clipped(&p.vertices) {
            clipped_parts.push(p);
        } else {
            parts.push(p);
        }
    }
    if n > 0 {
        // the levels choose their centres independently of each other: in parallel
        let at = Levels {
            surface,
            boundary,
            det,
            is_keypoint: &is_keypoint,
            params,
            fronts,
        };
        let levels: Vec<(Vec<Part>, Vec<Part>)> = params
            .levels
            .par_iter()
            .enumerate()
            .map(|(l, &radius)| {
                let level = (l + 1).min(254) as u8;
                level_patches(&at, radius, level)
            })
            .collect::<Result<_, _>>()?;
        for (p, c) in levels {
            parts.extend(p);
            clipped_parts.extend(c);
        }
        if params.whole {
            // centre: the vertex nearest the area-weighted centroid
            let centroid = surface
                .mesh
                .positions
                .iter()
                .zip(&surface.areas)
                .fold(Vector3::zeros(), |acc, (p, a)| acc + p.coords * *a)
                / total.max(f64::MIN_POSITIVE);
            let center = (0..n)
                .min_by(|&a, &b| {
                    let da = (surface.mesh.positions[a].coords - centroid).norm_squared();
                    let db = (surface.mesh.positions[b].coords - centroid).norm_squared();
                    da.total_cmp(&db).then(a.cmp(&b))
                })
                .unwrap_or(0) as u32;
            let whole = Part {
                center,
                reach: f64::INFINITY,
                vertices: (0..n as u32).collect(),
                keypoints: det.keypoints.len(),
                level: whole_level,
            };
            if clipped(&whole.vertices) {
                clipped_parts.push(whole);
            } else {
                parts.push(whole);
            }
        }
    }
    if parts.is_empty() {
        // nothing complete (an open surface, a small fragment): describe what there is
        clipped_parts.sort_by_key(|p| p.level);
        parts = clipped_parts;
    }

    // every front the parts need, in parallel, each as far as its farthest use: what each part
    // reads below then does not depend on the order the fronts ran in
    let mut reach: HashMap<u32, f64> = HashMap::new();
    for p in &parts {
        let r = reach.entry(p.center).or_insert(p.reach);
        *r = r.max(p.reach);
    }
    let mut needed: Vec<(u32, f64)> = reach.into_iter().collect();
    needed.sort_by_key(|&(c, _)| c);
    needed
        .par_iter()
        .map(|&(c, r)| fronts.get(c, r).map(|_| ()))
        .collect::<Result<(), _>>()?;

    let m = parts.len();
    let centers: Vec<u32> = parts.iter().map(|p| p.center).collect();
    // per part: its layout row, whether its front covered its whole piece (+∞ then means
    // another piece), and its description
    let described: Vec<(Vec<f32>, bool, ComponentDescription)> = parts
        .into_par_iter()
        .map(|p| {
            let front = fronts.get(p.center, p.reach)?;
            let d = &front.d;
            let row: Vec<f32> = centers.iter().map(|&o| d[o as usize] as f32).collect();
            let (descriptor, radius, area) = describe_part(surface, &p, d);
            let at = surface.mesh.positions[p.center as usize];
            Ok((
                row,
                front.complete,
                ComponentDescription {
                    descriptor,
                    center: p.center,
                    position: [at.x as f32, at.y as f32, at.z as f32],
                    area: if total > 0.0 { area / total } else { 0.0 },
                    keypoints: p.keypoints,
                    radius,
                    level: p.level,
                    vertices: p.vertices,
                },
            ))
        })
        .collect::<Result<_, DescribeError>>()?;
    let mut layout = Vec::with_capacity(m * m);
    let mut complete = Vec::with_capacity(m);
    let mut components = Vec::with_capacity(m);
    for (row, c, desc) in described {
        layout.extend(row);
        complete.push(c);
        components.push(desc);
    }
    // symmetrise the layout; disconnected pairs get twice the largest finite distance, pairs
    // beyond the reach of both fronts none
    let finite_max = layout
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .fold(0f32, f32::max);
    for i in 0..m {
        for j in 0..i {
            let (a, b) = (layout[i * m + j], layout[j * m + i]);
            let v = if params.whole
                && (components[i].level == whole_level || components[j].level == whole_level)
            {
                NO_DISTANCE
            } else if a.is_finite() && b.is_finite() {
                0.5 * (a + b)
            } else if a.is_finite() || b.is_finite() {
                a.min(b)
            } else if complete[i] || complete[j] {
                2.0 * finite_max
            } else {
                NO_DISTANCE
            };
            layout[i * m + j] = v;
            layout[j * m + i] = v;
        }
        layout[i * m + i] = 0.0;
    }
    let sample = surface_sample(&surface.mesh);
    Ok(ShapeDescription {
        components,
        layout,
        sample,
        boundary_vertices: boundary.iter().filter(|&&b| b).count(),
    })
}

/// [`SAMPLE_POINTS`] points uniform by area on `mesh` (ChaCha8 seeded with [`SAMPLE_SEED`]: the
/// same mesh gives the same points); none when the mesh has no area.
fn surface_sample(mesh: &Mesh) -> Vec<[f32; 3]> {
    let Some(sampler) = keycomp_mesh::sample::AreaSampler::new(mesh) else {
        return Vec::new();
    };
    let mut rng = ChaCha8Rng::seed_from_u64(SAMPLE_SEED);
    (0..SAMPLE_POINTS)
        .map(|_| {
            let (p, _) = sampler.sample(&mut rng);
            [p.x as f32, p.y as f32, p.z as f32]
        })
        .collect()
}

/// The descriptor of one part, its geodesic radius and its area (`d`: distances from its
/// centre).
fn describe_part(s: &Surface, part: &Part, d: &[f64]) -> (Descriptor, f64, f64) {
    let pos = &s.mesh.positions;
    let vs = &part.vertices;
    let center = pos[part.center as usize];
    let radius = vs
        .iter()
        .map(|&v| d[v as usize])
        .filter(|x| x.is_finite())
        .fold(0.0f64, f64::max);
    let comp_area: f64 = vs.iter().map(|&v| s.areas[v as usize]).sum();
    let h_max = vs
        .iter()
        .map(|&v| s.response[v as usize])
        .filter(|h| h.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);

    let mut desc = [0f32; DIM];
    let mut mean_normal = Vector3::zeros();
    let mut mean = Vector3::zeros();
    for &v in vs {
        let a = s.areas[v as usize];
        mean_normal += s.normals[v as usize] * a;
        mean += pos[v as usize].coords * a;
    }
    if mean_normal.norm() > 0.0 {
        mean_normal.normalize_mut();
    }
    if comp_area > 0.0 {
        mean /= comp_area;
    }
    let mut cov = Matrix3::zeros();
    for &v in vs {
        let vi = v as usize;
        let w = s.areas[vi];
        let a = w as f32;
        // Harris response, log scale relative to the part's maximum
        let h = s.response[vi];
        if h.is_finite() || !s.skip_unfitted {
            let b = if h > 0.0 && h_max > 0.0 {
                bin((h / h_max).log10(), -4.0, 0.0, 8)
            } else {
                0
            };
            desc[b] += a;
        }
        // geodesic distance from the centre, relative to the radius
        let dg = d[vi];
        if dg.is_finite() && radius > 0.0 {
            desc[8 + bin(dg / radius, 0.0, 1.0, 8)] += a;
            if dg > 0.2 * radius {
                let ratio = (pos[vi] - center).norm() / dg;
                desc[16 + bin(ratio, 0.0, 1.0 + 1e-9, 8)] += a;
            }
        }
        // normal turning
        let ang = s.normals[vi].dot(&mean_normal).clamp(-1.0, 1.0).acos();
        desc[24 + bin(ang, 0.0, std::f64::consts::PI + 1e-9, 4)] += a;
        let p = pos[vi].coords - mean;
        cov += p * p.transpose() * w;
        // curvature: shape index, and curvedness relative to the part's size
        let si = s.shape_index[vi];
        if si.is_finite() {
            desc[32 + bin(si, -1.0, 1.0 + 1e-9, 8)] += a;
        }
        let c = s.curvedness[vi] * radius;
        if c.is_finite() {
            let b = if c > 0.0 {
                bin(c.log10(), -2.0, 1.0, 8)
            } else {
                0
            };
            desc[40 + b] += a;
        }
    }
    // pair statistics over area-sampled point pairs (vertices stand for their areas)
    if comp_area > 0.0 && radius > 0.0 && vs.len() >= 2 {
        let mut cdf = Vec::with_capacity(vs.len());
        let mut acc = 0.0;
        for &v in vs {
            acc += s.areas[v as usize];
            cdf.push(acc);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(((part.center as u64) << 8) | part.level as u64);
        let draw = |rng: &mut ChaCha8Rng| {
            let x = rng.random::<f64>() * acc;
            vs[cdf.partition_point(|&c| c < x).min(vs.len() - 1)] as usize
        };
        for _ in 0..PAIRS {
            let (i, j) = (draw(&mut rng), draw(&mut rng));
            let e = (pos[i] - pos[j]).norm() / (2.0 * radius);
            desc[48 + bin(e, 0.0, 1.0 + 1e-9, 8)] += 1.0;
            let ang = s.normals[i].dot(&s.normals[j]).clamp(-1.0, 1.0).acos();
            desc[56 + bin(ang, 0.0, std::f64::consts::PI + 1e-9, 8)] += 1.0;
        }
    }
    for (lo, hi) in HISTOGRAMS {
        normalise(&mut desc[lo..hi]);
    }
    let compact = if comp_area > 0.0 && radius > 0.0 {
        (radius / comp_area.sqrt()).ln() - (1.0 / std::f64::consts::PI.sqrt()).ln()
    } else {
        0.0
    };
    let mut eig: Vec<f64> = cov.symmetric_eigenvalues().iter().copied().collect();
    eig.sort_by(|a, b| b.total_cmp(a));
    let (r21, r31) = if eig[0] > 0.0 {
        (eig[1].max(0.0) / eig[0], eig[2].max(0.0) / eig[0])
    } else {
        (0.0, 0.0)
    };
    let density = if !vs.is_empty() {
        (part.keypoints as f64 / vs.len() as f64) / (s.total_keypoints / s.vertices)
    } else {
        0.0
    };
    desc[28] = SCALAR_WEIGHT * (compact.clamp(-2.0, 2.0) / 2.0) as f32;
    desc[29] = SCALAR_WEIGHT * r21 as f32;
    desc[30] = SCALAR_WEIGHT * r31 as f32;
    desc[31] = if s.file_units {
        SIZE_WEIGHT * (radius.max(1e-6).ln().clamp(-10.0, 10.0)) as f32
    } else {
        SCALAR_WEIGHT * (density / (1.0 + density)) as f32
    };
    (desc, radius, comp_area)
}

/// Euclidean distance between two descriptors.
pub fn distance(a: &Descriptor, b: &Descriptor) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f32>()
        .sqrt()
}
