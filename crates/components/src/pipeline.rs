//! Key-component detection end to end (Sipiran & Bustos 2013, Section 3):
//!
//! 1. Normalise the mesh to surface area 1 (Section 4.1), keeping the scale factor `s`.
//! 2. Harris 3D keypoints and per-vertex responses (Section 3.1; `keycomp_harris`).
//! 3. Geodesic distances between every pair of keypoints by fast marching, one front per
//!    keypoint in parallel, symmetrised (Section 3.2; `keycomp_geodesic`); by default only
//!    100 landmark keypoints run a full front when there are more (see *Landmark fronts*). With
//!    [`GeodesicOptions::proxy_vertices`] = N > 0 and a mesh of more than N referenced vertices,
//!    the fronts run on a *proxy*: the mesh simplified to N vertices by half-edge collapse
//!    (`keycomp_mesh::simplify`) with the keypoints protected, so every keypoint is a vertex
//!    of the proxy at its exact position and no snapping is needed (see *Geodesic proxy*).
//! 4. SMACOF embedding of the K×K matrix in the plane (Eq. 1; [`mod@crate::smacof`]), by
//!    default from two starts, one of them the classical scaling of the matrix.
//! 5. Adaptive clustering of the 2-D points (Algorithm 1; [`crate::cluster`]).
//! 6. Per cluster: geodesic centre (Eq. 2), smallest enclosing sphere of its keypoints (Welzl;
//!    or, with [`SphereRule::Spread`], a sphere from their mean and RMS spread) and region
//!    growing bounded by σ·r (Algorithm 2; [`crate::grow`]).
//!
//! Cost: Harris O(|V|·n) for neighbourhoods of n points; fast marching O(K·|V| log |V|) (the
//! dominant term: K ≈ |V|/100 fronts), O(K·N log N) on a proxy of N vertices plus
//! O(|V| log |V|) to build it; SMACOF O(starts·iterations·K²); clustering
//! O(Iter·K·m) for m clusters; extraction O(component size).
//!
//! Results are deterministic for the same mesh and parameters (including the SMACOF seed),
//! whatever the number of threads. Positions and radii are reported in the file's units.
//!
//! # Geodesic proxy (a deviation from the paper, on by default)
//!
//! The paper computes the distances on the mesh itself. By default the fronts run on a
//! simplified proxy of at most 10,000 vertices ([`GeodesicOptions::DEFAULT_PROXY_VERTICES`]),
//! for speed: a front costs O(|V| log |V|) and there are K ≈ |V|/100 of them, so a proxy of N
//! vertices divides the dominant term by about |V|/N, for the price of one simplification
//! (O(|V| log |V|), about 0.1 s for 60k vertices on one thread; by default split into cells
//! of at least 10,000 vertices simplified in parallel, then the seams,
//! [`GeodesicOptions::proxy_cell_vertices`]). The proxy keeps the survivors'
//! exact positions and the surface's topology (link condition), so its distances differ from
//! the mesh's by the discretisation error of fast marching on longer edges plus the shortcut of
//! flattened detail. The K×K matrix of a 20,000-vertex proxy differs from the full mesh's by
//! 0.4–0.9 % on average (`cat0` 0.43 %, `nefertiti` 0.50 %, KIDS 0.94 %); on `icosphere(6)`
//! its mean error against great circles is 0.95 % (full mesh 0.49 %); TOSCA cat poses keep
//! their mean best IoU (0.863 both ways) and the repeatability benchmark's KC-1 average
//! overlap stays within the noise of the SMACOF seed of the full mesh's (strength ≤ 5:
//! 0.844 vs 0.847 with seed 0, 0.839 vs 0.840 with seed 1) for 2.6× (50k vertices) to 2.7×
//! (60k) fewer CPU cycles. The 10,000-vertex default against a
//! 20,000-vertex proxy: KC-1 average overlap at strength ≤ 5 0.848 vs 0.850 (no row more than
//! 0.019 lower), the retrieval tables on Watertight and TOSCA within 0.01, `keycomp detect`
//! in 0.76× (nefertiti) and 0.79× (KIDS) the wall time (BENCHMARKS.md, *Detection* and
//! *Repeatability*; the matrix errors by `cargo bench -p keycomp-components --bench
//! geodesic_proxy`). Meshes of at most 10,000 referenced vertices are not affected.
//! [`GeodesicOptions::full_mesh`] (`proxy_vertices` = 0; `keycomp detect --geodesic-vertices
//! 0`) is the paper's method. Only step 3 sees the proxy: Harris, region growing and every
//! reported id use the mesh.
//!
//! # Landmark fronts (a deviation from the paper, on by default)
//!
//! With K keypoints, the K fronts of step 3 are most of detection's time. By default
//! ([`GeodesicOptions::landmarks`] = 100) only 100 keypoints, spread by farthest-point
//! sampling, run a full front; the others run a front stopped at twice the covering radius
//! (the largest distance from a keypoint to its nearest landmark), and a pair that neither
//! front measured gets the shortest path through one landmark
//! (`keycomp_geodesic::landmark_distance_matrix`). Shapes with at most 100 keypoints (meshes
//! under about 10,000 vertices) are unaffected. The matrix of a 50–60k-vertex mesh then
//! differs from the full one by 0.75–1.3 % on average. Together with SMACOF's classical
//! start (see [`mod@crate::smacof`]), against a full front per keypoint and four random
//! starts on a 20,000-vertex proxy: the repeatability benchmark's KC-1 average overlap at
//! strength ≤ 5 is 0.848 against 0.844, no row more than 0.015 lower, and `keycomp detect`
//! takes 0.41× (`nefertiti.obj`) and 0.37× (KIDS `0001.null.0`) the wall time
//! (BENCHMARKS.md, *Detection* and *Repeatability*). `--landmarks 0 --smacof-starts 4
//! --smacof-init random --geodesic-vertices 0` is the paper's method. The robust preset
//! measures each short front in its own keypoint's distance to the nearest landmark instead
//! ([`GeodesicOptions::local_landmark_radius`]): the covering radius is the largest of those
//! distances, so the few keypoints farthest from every landmark set the reach of every short
//! front (the time and the repeatability are in BENCHMARKS.md, *Detection* and
//! *Repeatability*).

use std::sync::Arc;
use std::time::Instant;

use keycomp_geodesic::{
    DistanceMatrix, GeodesicError, GeodesicParams, GeodesicSolver, ShortRadius, distance_matrix,
    landmark_distance_matrix,
};
use keycomp_harris::{HarrisError, HarrisParams, UnitArea};
use keycomp_mesh::{Mesh, Point3, Topology, VertexId, geometry, simplify};
use serde::{Deserialize, Serialize};

use crate::cluster::{ClusterParams, adaptive_clustering};
use crate::error::ComponentsError;
use crate::grow::{Component, RegionGrower, geodesic_center};
use crate::params::{ComponentParams, Grouping, Preset};
use crate::saliency::{SaliencyParams, salient_components};
use crate::smacof::{Embedding, UpperTriangle, smacof_upper};
use crate::sphere::{Sphere, SphereRule};

/// All parameters of detection: the keypoint detector, the components stage and the geodesic
/// options. The default is the paper's KC-1 (1 % of the vertices as keypoints, R = 0.15,
/// T = 0.30, N = 30, σ = 1.5) with the fronts on a proxy of at most 10,000 vertices, landmark
/// fronts and SMACOF's classical start (see *Geodesic proxy* and *Landmark fronts* in the
/// module docs).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DetectParams {
    /// Harris 3D keypoints (neighbourhood, k, how many keypoints).
    pub harris: HarrisParams,
    /// Clustering, region growing and SMACOF.
    pub components: ComponentParams,
    /// Where and how the fast-marching fronts run (full mesh or proxy; obtuse-angle splitting).
    pub geodesic: GeodesicOptions,
}

impl DetectParams {
    /// Checks every part (Harris, components, geodesic options).
    pub fn validate(&self) -> Result<(), DetectError> {
        self.harris.validate()?;
        self.components.validate()?;
        self.geodesic.validate()?;
        Ok(())
    }
}

/// Options of the geodesic step (step 3 of the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GeodesicOptions {
    /// Run the fronts on a proxy of at most this many vertices when the mesh has more referenced
    /// vertices (the keypoints are protected, so a proxy can keep more when there are many);
    /// 0: always the full mesh, as in the paper. Any other value must be at least
    /// [`GeodesicOptions::MIN_PROXY_VERTICES`]. Default
    /// [`GeodesicOptions::DEFAULT_PROXY_VERTICES`] (10,000; a deviation from the paper, see
    /// *Geodesic proxy* in the module docs).
    pub proxy_vertices: usize,
    /// Obtuse corners of at least this angle (degrees, in [90, 180]) are split by unfolding
    /// (`keycomp_geodesic::GeodesicParams::min_split_angle_degrees`; 90 splits every obtuse
    /// corner, 180 none).
    pub min_split_angle_degrees: f64,
    /// Landmark fronts (see *Landmark fronts* in the module docs): when there are more than
    /// this many keypoints, only this many of them (spread by farthest-point sampling) run a
    /// full front, the others a front stopped at [`GeodesicOptions::landmark_radius`] covering
    /// radii, and the pairs no front measured get the shortest path through one landmark.
    /// Default [`GeodesicOptions::DEFAULT_LANDMARKS`] (a deviation from the paper). 0:
    /// every keypoint runs a full front, as in the paper (also what a recorded parameter set
    /// without the field reads as).
    #[serde(default)]
    pub landmarks: usize,
    /// Where the short fronts of the non-landmark keypoints stop, in covering radii (the
    /// largest distance from a keypoint to its nearest landmark); > 0. Only used with
    /// [`GeodesicOptions::landmarks`] > 0.
    #[serde(default = "default_landmark_radius")]
    pub landmark_radius: f64,
    /// Measure [`GeodesicOptions::landmark_radius`] in each keypoint's own distance to its
    /// nearest landmark (at least the 90th percentile of those distances) instead of the covering
    /// radius (`keycomp_geodesic::ShortRadius::Local`): one keypoint far from every landmark
    /// then lengthens its own front only. Off by default and in a recorded parameter set
    /// without the field; on in the robust preset ([`Preset::geodesic_options`]).
    #[serde(default)]
    pub local_landmark_radius: bool,
    /// The proxy's simplification runs in parallel in 2^d cells (pieces of the connectivity,
    /// see `keycomp_mesh::simplify`), d the largest that
    /// leaves at least this many referenced vertices per cell (at most
    /// [`GeodesicOptions::MAX_PROXY_CELLS`] cells), then once more over the whole to close
    /// the seams (`keycomp_mesh::simplify::simplify_in_cells`); 0 or a mesh of fewer than
    /// twice this many vertices: one cell, a single decimation of the whole mesh. The cells
    /// are a function of the mesh, never of the number of threads. Otherwise at least
    /// [`GeodesicOptions::MIN_PROXY_CELL_VERTICES`]. Default
    /// [`GeodesicOptions::DEFAULT_PROXY_CELL_VERTICES`]; a recorded parameter set without
    /// the field reads as 0 (one cell).
    #[serde(default)]
    pub proxy_cell_vertices: usize,
}

fn default_landmark_radius() -> f64 {
    GeodesicOptions::DEFAULT_LANDMARK_RADIUS
}

impl GeodesicOptions {
    /// The smallest non-zero [`GeodesicOptions::proxy_vertices`].
    pub const MIN_PROXY_VERTICES: usize = 100;
    /// The default [`GeodesicOptions::proxy_vertices`]: 10,000, chosen by the measurements in
    /// the module docs (*Geodesic proxy*): repeatability and retrieval within 0.02 of a 20k
    /// proxy's, detection of a 50–60k-vertex mesh in about 0.8× a 20k proxy's wall time.
    pub const DEFAULT_PROXY_VERTICES: usize = 10_000;
    /// The default [`GeodesicOptions::landmarks`]: 100 (meshes of more than about 10,000
    /// vertices, whose 1 % of keypoints exceeds it, get landmark fronts; see *Landmark fronts*
    /// in the module docs).
    pub const DEFAULT_LANDMARKS: usize = 100;
    /// The default [`GeodesicOptions::landmark_radius`].
    pub const DEFAULT_LANDMARK_RADIUS: f64 = 2.0;
    /// The default [`GeodesicOptions::proxy_cell_vertices`].
    pub const DEFAULT_PROXY_CELL_VERTICES: usize = 10_000;
    /// The smallest non-zero [`GeodesicOptions::proxy_cell_vertices`].
    pub const MIN_PROXY_CELL_VERTICES: usize = 1_000;
    /// The most cells the proxy's simplification is split into.
    pub const MAX_PROXY_CELLS: usize = 64;

    /// The options of the paper: full mesh, every obtuse corner split, a full front from every
    /// keypoint.
    pub fn full_mesh() -> GeodesicOptions {
        GeodesicOptions {
            proxy_vertices: 0,
            min_split_angle_degrees: GeodesicParams::default().min_split_angle_degrees,
            landmarks: 0,
            landmark_radius: Self::DEFAULT_LANDMARK_RADIUS,
            local_landmark_radius: false,
            proxy_cell_vertices: 0,
        }
    }

    /// The number of cells the proxy's simplification of a mesh of `referenced` vertices is
    /// split into (see [`GeodesicOptions::proxy_cell_vertices`]).
    pub fn proxy_cells(&self, referenced: usize) -> usize {
        if self.proxy_cell_vertices == 0 {
            return 1;
        }
        let mut cells = 1;
        while cells < Self::MAX_PROXY_CELLS && referenced / (2 * cells) >= self.proxy_cell_vertices
        {
            cells *= 2;
        }
        cells
    }

    /// Checks that `proxy_vertices` is 0 or at least [`GeodesicOptions::MIN_PROXY_VERTICES`]
    /// and that the angle is a number in [90, 180].
    pub fn validate(&self) -> Result<(), ComponentsError> {
        if self.proxy_vertices != 0 && self.proxy_vertices < Self::MIN_PROXY_VERTICES {
            return Err(ComponentsError::param(
                "geodesic.proxy_vertices",
                self.proxy_vertices,
                "must be 0 (full mesh) or at least 100",
            ));
        }
        if self.proxy_cell_vertices != 0 && self.proxy_cell_vertices < Self::MIN_PROXY_CELL_VERTICES
        {
            return Err(ComponentsError::param(
                "geodesic.proxy_cell_vertices",
                self.proxy_cell_vertices,
                "must be 0 (one cell) or at least 1000",
            ));
        }
        if !(self.landmark_radius.is_finite() && self.landmark_radius > 0.0) {
            return Err(ComponentsError::param(
                "geodesic.landmark_radius",
                self.landmark_radius,
                "must be a positive number of covering radii",
            ));
        }
        if !(90.0..=180.0).contains(&self.min_split_angle_degrees) {
            return Err(ComponentsError::param(
                "geodesic.min_split_angle_degrees",
                self.min_split_angle_degrees,
                "must be an angle in [90, 180] degrees",
            ));
        }
        Ok(())
    }

    fn solver_params(&self) -> GeodesicParams {
        GeodesicParams {
            min_split_angle_degrees: self.min_split_angle_degrees,
            ..GeodesicParams::default()
        }
    }
}

impl Preset {
    /// The geodesic options of this preset: the defaults ([`GeodesicOptions::default`]), with
    /// [`GeodesicOptions::local_landmark_radius`] in the robust preset.
    pub fn geodesic_options(self) -> GeodesicOptions {
        GeodesicOptions {
            local_landmark_radius: matches!(self, Preset::Robust),
            ..GeodesicOptions::default()
        }
    }
}

impl Default for GeodesicOptions {
    fn default() -> Self {
        GeodesicOptions {
            proxy_vertices: Self::DEFAULT_PROXY_VERTICES,
            landmarks: Self::DEFAULT_LANDMARKS,
            proxy_cell_vertices: Self::DEFAULT_PROXY_CELL_VERTICES,
            ..GeodesicOptions::full_mesh()
        }
    }
}

/// Anything that stops detection.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DetectError {
    /// Keypoint detection failed (bad parameters).
    #[error(transparent)]
    Harris(#[from] HarrisError),
    /// Geodesic distances failed.
    #[error(transparent)]
    Geodesic(#[from] GeodesicError),
    /// SMACOF, clustering or extraction failed (bad parameters or degenerate input).
    #[error(transparent)]
    Components(#[from] ComponentsError),
}

/// One key-component.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KeyComponent {
    /// Index of the component in the detection (0-based, in cluster order).
    pub id: usize,
    /// The geodesic centre: the cluster's keypoint whose 2-D image is closest to the cluster's
    /// 2-D centroid (Eq. 2).
    pub center: VertexId,
    /// Centre of the smallest sphere enclosing the cluster's keypoints, in file units.
    pub sphere_center: [f64; 3],
    /// Radius of that sphere, in file units.
    pub sphere_radius: f64,
    /// The cluster's keypoints (sorted vertex ids).
    pub keypoints: Vec<VertexId>,
    /// Vertices of the component (sorted).
    pub vertices: Vec<VertexId>,
    /// Faces of the component: every face touching one of its vertices (sorted face indices).
    pub faces: Vec<u32>,
    /// Area of `faces` as a fraction of the mesh's total area.
    pub area: f64,
    /// Keypoints of the cluster that region growing did not reach (normally none; see
    /// [`crate::grow`]).
    pub missed_keypoints: Vec<VertexId>,
}

/// Wall-clock time of each stage, in milliseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// Normalisation, adjacency and Harris 3D.
    pub harris: f64,
    /// Fast-marching distance matrix, including the proxy's simplification if there is one.
    pub geodesic: f64,
    /// The part of `geodesic` spent simplifying the mesh to the proxy (0 without a proxy).
    pub simplify: f64,
    /// SMACOF.
    pub mds: f64,
    /// Algorithm 1.
    pub cluster: f64,
    /// Centres, spheres and region growing.
    pub extract: f64,
}

/// The result of [`detect`].
#[derive(Debug, Clone)]
pub struct Detection {
    /// Total surface area in file units squared.
    pub area: f64,
    /// The normalisation factor s (normalised = s · file coordinates).
    pub scale: f64,
    /// Harris response per vertex (NaN where there is none).
    pub response: Vec<f64>,
    /// Keypoints, best first.
    pub keypoints: Vec<VertexId>,
    /// The keypoints' 2-D images (same order as `keypoints`).
    pub embedding: Embedding,
    /// Pairs of keypoints on different connected pieces (their distance was filled in).
    pub disconnected_pairs: usize,
    /// Vertices of the mesh the fronts ran on: the proxy's, or the mesh's own count.
    pub geodesic_vertices: usize,
    /// Keypoints in no cluster (sorted vertex ids).
    pub unclustered: Vec<VertexId>,
    /// The key-components.
    pub components: Vec<KeyComponent>,
    /// The proxy the fronts ran on, when they ran on one (shared with description).
    pub proxy: Option<Arc<Proxy>>,
    /// Time per stage.
    pub timings: Timings,
}

impl Detection {
    /// A detection whose components were found without the paper's embedding (salient regions,
    /// MSER): no 2-D images, no fronts between keypoints, no proxy; the keypoints in no
    /// component's list are the unclustered ones.
    pub fn without_embedding(
        area: f64,
        scale: f64,
        response: Vec<f64>,
        keypoints: Vec<VertexId>,
        components: Vec<KeyComponent>,
        timings: Timings,
    ) -> Detection {
        let mut clustered: Vec<VertexId> = components
            .iter()
            .flat_map(|c| c.keypoints.iter().copied())
            .collect();
        clustered.sort_unstable();
        let mut unclustered: Vec<VertexId> = keypoints
            .iter()
            .copied()
            .filter(|k| clustered.binary_search(k).is_err())
            .collect();
        unclustered.sort_unstable();
        Detection {
            area,
            scale,
            response,
            keypoints,
            embedding: Embedding {
                points: Vec::new(),
                stress: 0.0,
                iterations: 0,
            },
            disconnected_pairs: 0,
            geodesic_vertices: 0,
            unclustered,
            components,
            proxy: None,
            timings,
        }
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Detects the key-components of `mesh` (see the module documentation for the steps).
///
/// The mesh must be valid (as returned by `keycomp_mesh::read_mesh` or `Mesh::from_raw`).
/// Fewer than two keypoints, or no cluster reaching N keypoints, give a detection with no
/// components, not an error.
pub fn detect(mesh: &Mesh, params: &DetectParams) -> Result<Detection, DetectError> {
    detect_in(mesh, params, UnitArea::Own)
}

/// [`detect`] with `unit` as the area that counts as 1 (step 1) instead of the mesh's own
/// area: R, T, the sphere radii, the Harris responses, `LengthReference::Unit` radii,
/// `Selection::PerArea` budgets and smoothing lengths are then measured in the unit of the
/// shape `unit` stands for. A fragment that keeps the share f of its source and is given its
/// source's area is analysed as that part of the source would be; with [`UnitArea::Own`] it is
/// magnified by 1/√f, as the paper's per-shape normalisation does. Not in the paper.
pub fn detect_in(
    mesh: &Mesh,
    params: &DetectParams,
    unit: UnitArea,
) -> Result<Detection, DetectError> {
    params.validate()?;

    let t = Instant::now();
    let area = geometry::total_area(mesh);
    let (norm, scale, harris_unit) = match unit {
        UnitArea::Own => {
            let (norm, scale) = geometry::normalize_unit_area(mesh);
            (norm, scale, UnitArea::Own)
        }
        UnitArea::Given(a) => {
            if !(a.is_finite() && a > 0.0) {
                return Err(DetectError::Components(ComponentsError::param(
                    "unit_area",
                    a,
                    "must be a positive area",
                )));
            }
            let s = 1.0 / a.sqrt();
            let norm = Mesh {
                positions: mesh.positions.iter().map(|p| p * s).collect(),
                faces: mesh.faces.clone(),
            };
            (norm, s, UnitArea::Given(1.0))
        }
    };
    let topo = Topology::new(&norm);
    let harris = keycomp_harris::detect_in(&norm, &topo, &params.harris, harris_unit)?;
    let t_harris = ms(t);

    if let Grouping::Salient(sp) = &params.components.grouping {
        return salient_detection(&norm, &topo, harris, sp, area, scale, t_harris);
    }

    let t = Instant::now();
    let (dist, geodesic_vertices, t_simplify, proxy) =
        keypoint_distances_with_proxy(&norm, &topo, &harris.keypoints, &params.geodesic)?;
    let t_geodesic = ms(t);

    let t = Instant::now();
    // SMACOF reads the upper triangle, packed in the square matrix's own memory (the largest of
    // detection's on meshes with thousands of keypoints)
    let disconnected_pairs = dist.disconnected_pairs();
    let upper = UpperTriangle::from_distances(dist);
    let embedding = smacof_upper(&upper, &params.components.smacof)?;
    drop(upper);
    let t_mds = ms(t);

    let t = Instant::now();
    let face_areas = geometry::face_areas(&norm);
    let total: f64 = face_areas.iter().sum();
    let mut grower = RegionGrower::new(&norm, &topo)?;
    let extracted = extract_components(
        &norm,
        &mut grower,
        &harris.keypoints,
        &embedding.points,
        &params.components.cluster,
        params.components.sigma,
        params.components.sphere,
    )?;
    let t_cluster = extracted.cluster_ms;
    let components: Vec<KeyComponent> = extracted
        .components
        .into_iter()
        .enumerate()
        .map(|(id, c)| {
            let area_fraction: f64 = c.grown.faces.iter().map(|&f| face_areas[f as usize]).sum();
            KeyComponent {
                id,
                center: c.center,
                sphere_center: (c.sphere.center.coords / scale).into(),
                sphere_radius: c.sphere.radius / scale,
                keypoints: c.keypoints,
                vertices: c.grown.vertices,
                faces: c.grown.faces,
                area: area_fraction / total,
                missed_keypoints: c.grown.missed_keypoints,
            }
        })
        .collect();
    let unclustered = extracted.unclustered;
    let t_extract = (ms(t) - t_cluster).max(0.0);

    Ok(Detection {
        area,
        scale,
        response: harris.response,
        keypoints: harris.keypoints,
        embedding,
        disconnected_pairs,
        geodesic_vertices,
        unclustered,
        components,
        proxy: proxy.map(Arc::new),
        timings: Timings {
            harris: t_harris,
            geodesic: t_geodesic,
            simplify: t_simplify,
            mds: t_mds,
            cluster: t_cluster,
            extract: t_extract,
        },
    })
}

/// Detection with [`Grouping::Salient`]: the salient regions of the response on the
/// unit-area mesh `norm` ([`crate::saliency`]) instead of steps 3–6.
fn salient_detection(
    norm: &Mesh,
    topo: &Topology,
    harris: keycomp_harris::HarrisResult,
    params: &SaliencyParams,
    area: f64,
    scale: f64,
    t_harris: f64,
) -> Result<Detection, DetectError> {
    let t = Instant::now();
    let found = salient_components(norm, topo, &harris.response, &harris.keypoints, params)?;
    let face_areas = geometry::face_areas(norm);
    let total: f64 = face_areas.iter().sum();
    let components: Vec<KeyComponent> = found
        .into_iter()
        .enumerate()
        .map(|(id, c)| {
            let area_fraction: f64 = c.faces.iter().map(|&f| face_areas[f as usize]).sum();
            let at = norm.positions[c.peak as usize];
            KeyComponent {
                id,
                center: c.peak,
                sphere_center: (at.coords / scale).into(),
                sphere_radius: c.reach / scale,
                keypoints: c.keypoints,
                vertices: c.vertices,
                faces: c.faces,
                area: if total > 0.0 {
                    area_fraction / total
                } else {
                    0.0
                },
                missed_keypoints: Vec::new(),
            }
        })
        .collect();
    let timings = Timings {
        harris: t_harris,
        cluster: ms(t),
        ..Timings::default()
    };
    Ok(Detection::without_embedding(
        area,
        scale,
        harris.response,
        harris.keypoints,
        components,
        timings,
    ))
}

/// One cluster's key-component, as [`extract_components`] returns it (unit-area units).
#[derive(Debug, Clone)]
pub struct ExtractedComponent {
    /// The geodesic centre (Eq. 2), a keypoint.
    pub center: VertexId,
    /// The cluster's keypoints (sorted vertex ids).
    pub keypoints: Vec<VertexId>,
    /// The sphere of the keypoints that bounded growing (see [`SphereRule`]), on the
    /// unit-area mesh.
    pub sphere: Sphere,
    /// What region growing (Algorithm 2) reached.
    pub grown: Component,
}

/// The result of [`extract_components`].
#[derive(Debug, Clone)]
pub struct Extracted {
    /// One entry per surviving cluster, in cluster order.
    pub components: Vec<ExtractedComponent>,
    /// Keypoints in no cluster (sorted vertex ids).
    pub unclustered: Vec<VertexId>,
    /// Milliseconds spent in Algorithm 1.
    pub cluster_ms: f64,
}

/// Steps 5–6 of the [module docs](self): adaptive clustering of the keypoints' 2-D images
/// `points` (Algorithm 1), then per cluster its geodesic centre (Eq. 2), the sphere of its
/// keypoints that `sphere` names (the paper's smallest enclosing one, or
/// [`SphereRule::Spread`]) and region growing bounded by `sigma` times its radius
/// (Algorithm 2), on the unit-area mesh `grower` was built on. `keypoints[i]` is the vertex
/// whose image is `points[i]`.
///
/// Errors: invalid parameters, a keypoint that is not a vertex of the mesh, or a point count
/// other than the keypoint count.
pub fn extract_components(
    norm: &Mesh,
    grower: &mut RegionGrower<'_>,
    keypoints: &[VertexId],
    points: &[[f64; 2]],
    cluster: &ClusterParams,
    sigma: f64,
    sphere: SphereRule,
) -> Result<Extracted, ComponentsError> {
    sphere.validate()?;
    let n = norm.num_vertices();
    if points.len() != keypoints.len() {
        return Err(ComponentsError::IndexOutOfRange {
            what: "embedded point count",
            index: points.len(),
            len: keypoints.len(),
        });
    }
    if let Some(&v) = keypoints.iter().find(|&&v| v as usize >= n) {
        return Err(ComponentsError::IndexOutOfRange {
            what: "keypoint vertex",
            index: v as usize,
            len: n,
        });
    }
    let t = Instant::now();
    let clustering = adaptive_clustering(points, cluster)?;
    let cluster_ms = ms(t);
    let mut components = Vec::with_capacity(clustering.clusters.len());
    for c in &clustering.clusters {
        let center = keypoints[geodesic_center(&c.members, points)?];
        let mut members: Vec<VertexId> = c.members.iter().map(|&i| keypoints[i]).collect();
        members.sort_unstable();
        let positions: Vec<Point3<f64>> = members
            .iter()
            .map(|&v| norm.positions[v as usize])
            .collect();
        let bound = sphere.sphere(&positions)?;
        let grown = grower.grow(center, &members, &bound, sigma)?;
        components.push(ExtractedComponent {
            center,
            keypoints: members,
            sphere: bound,
            grown,
        });
    }
    let mut unclustered: Vec<VertexId> = clustering
        .unassigned
        .iter()
        .map(|&i| keypoints[i])
        .collect();
    unclustered.sort_unstable();
    Ok(Extracted {
        components,
        unclustered,
        cluster_ms,
    })
}

/// The simplified proxy a detection's fronts ran on (see *Geodesic proxy* in the module docs):
/// the unit-area mesh simplified to [`Proxy::target`] vertices in [`Proxy::cells`] cells with
/// the keypoints protected. Description runs on it too (`keycomp_describe`), so the two share
/// one simplification.
#[derive(Debug, Clone)]
pub struct Proxy {
    /// The vertex budget it was simplified to ([`GeodesicOptions::proxy_vertices`]).
    pub target: usize,
    /// How many cells the simplification ran in ([`GeodesicOptions::proxy_cells`]).
    pub cells: usize,
    /// The simplified mesh and, per proxy vertex, the input vertex it is.
    pub simplified: simplify::Simplified,
}

/// The proxy of the unit-area mesh `norm` (adjacency `topo`) with `keypoints` protected, as
/// `options` ask for it; `None` when they ask for none or the mesh has at most
/// [`GeodesicOptions::proxy_vertices`] referenced vertices, and when a keypoint lost all its
/// faces to simplification (a dangling face on non-manifold input: the fronts then run on the
/// mesh itself).
pub fn geodesic_proxy(
    norm: &Mesh,
    topo: &Topology,
    keypoints: &[VertexId],
    options: &GeodesicOptions,
) -> Option<Proxy> {
    if options.proxy_vertices == 0 {
        return None;
    }
    let referenced = (0..norm.num_vertices() as VertexId)
        .filter(|&v| !topo.faces_of(v).is_empty())
        .count();
    if referenced <= options.proxy_vertices {
        return None;
    }
    let cells = options.proxy_cells(referenced);
    let simplified =
        simplify::simplify_in_cells(norm, topo, options.proxy_vertices, keypoints, cells);
    keypoints
        .iter()
        .all(|&k| simplified.proxy_vertex(k).is_some())
        .then_some(Proxy {
            target: options.proxy_vertices,
            cells,
            simplified,
        })
}

/// Step 3: the K×K distance matrix of `keypoints` on `mesh` or on its proxy (see the module
/// docs), with the vertex count of the mesh the fronts ran on and the milliseconds spent
/// simplifying. Falls back to the full mesh in the one case where a protected keypoint can lose
/// all its faces to simplification (a dangling face on non-manifold input).
pub fn keypoint_distances(
    mesh: &Mesh,
    topo: &Topology,
    keypoints: &[VertexId],
    options: &GeodesicOptions,
) -> Result<(DistanceMatrix, usize, f64), DetectError> {
    keypoint_distances_with_proxy(mesh, topo, keypoints, options).map(|(d, n, t, _)| (d, n, t))
}

/// [`keypoint_distances`], also returning the proxy the fronts ran on (if any).
fn keypoint_distances_with_proxy(
    mesh: &Mesh,
    topo: &Topology,
    keypoints: &[VertexId],
    options: &GeodesicOptions,
) -> Result<(DistanceMatrix, usize, f64, Option<Proxy>), DetectError> {
    options.validate()?;
    let params = options.solver_params();
    let t = Instant::now();
    let proxy = geodesic_proxy(mesh, topo, keypoints, options);
    let t_simplify = if proxy.is_some() { ms(t) } else { 0.0 };
    if let Some(p) = proxy {
        let sources: Vec<VertexId> = keypoints
            .iter()
            .filter_map(|&k| p.simplified.proxy_vertex(k))
            .collect();
        let pmesh = &p.simplified.mesh;
        let ptopo = Topology::new(pmesh);
        let solver = GeodesicSolver::with_params(pmesh, &ptopo, params)?;
        let dist = matrix(&solver, pmesh, &sources, options)?;
        let nv = pmesh.num_vertices();
        return Ok((dist, nv, t_simplify, Some(p)));
    }
    let solver = GeodesicSolver::with_params(mesh, topo, params)?;
    Ok((
        matrix(&solver, mesh, keypoints, options)?,
        mesh.num_vertices(),
        t_simplify,
        None,
    ))
}

/// The K×K matrix of `sources` on the solver's `mesh`: every front full, or landmark fronts
/// when [`GeodesicOptions::landmarks`] asks for fewer than K.
fn matrix(
    solver: &GeodesicSolver,
    mesh: &Mesh,
    sources: &[VertexId],
    options: &GeodesicOptions,
) -> Result<DistanceMatrix, GeodesicError> {
    if options.landmarks == 0 || options.landmarks >= sources.len() {
        return distance_matrix(solver, sources);
    }
    let points: Vec<Point3<f64>> = sources
        .iter()
        .map(|&v| mesh.positions[v as usize])
        .collect();
    let landmarks = farthest_points(&points, options.landmarks);
    let short = if options.local_landmark_radius {
        ShortRadius::Local(options.landmark_radius)
    } else {
        ShortRadius::Covering(options.landmark_radius)
    };
    landmark_distance_matrix(solver, sources, &landmarks, short).map(|(m, _)| m)
}

/// `count` indices into `points` spread by farthest-point sampling (Euclidean): the first
/// point, then repeatedly the point farthest from those chosen (ties: the lowest index),
/// stopping early when every point left coincides with a chosen one. O(count · n).
pub fn farthest_points(points: &[Point3<f64>], count: usize) -> Vec<usize> {
    let n = points.len();
    let count = count.min(n);
    let mut chosen = Vec::with_capacity(count);
    if count == 0 {
        return chosen;
    }
    let mut nearest = vec![f64::INFINITY; n];
    let mut next = 0;
    loop {
        chosen.push(next);
        if chosen.len() == count {
            break;
        }
        let p = points[next];
        let mut best = (0.0, 0);
        for (i, q) in points.iter().enumerate() {
            let d = (q - p).norm_squared();
            if d < nearest[i] {
                nearest[i] = d;
            }
            if nearest[i] > best.0 {
                best = (nearest[i], i);
            }
        }
        if best.0 <= 0.0 {
            break; // every other point coincides with a chosen one
        }
        next = best.1;
    }
    chosen
}
