//! Key-component detection end to end (Sipiran & Bustos 2013, Section 3):
//!
//! 1. Normalise the mesh to surface area 1 (Section 4.1), keeping the scale factor `s`.
//! 2. Harris 3D keypoints and per-vertex responses (Section 3.1; `keycomp_harris`).
//! 3. Geodesic distances between every pair of keypoints by fast marching, one front per
//!    keypoint in parallel, symmetrised (Section 3.2; `keycomp_geodesic`).
//! 4. SMACOF embedding of the K×K matrix in the plane (Eq. 1; [`crate::smacof`]).
//! 5. Adaptive clustering of the 2-D points (Algorithm 1; [`crate::cluster`]).
//! 6. Per cluster: geodesic centre (Eq. 2), smallest enclosing sphere of its keypoints (Welzl)
//!    and region growing bounded by σ·r (Algorithm 2; [`crate::grow`]).
//!
//! Cost: Harris O(|V|·n) for neighbourhoods of n points; fast marching O(K·|V| log |V|) (the
//! dominant term: K ≈ |V|/100 fronts); SMACOF O(starts·iterations·K²); clustering
//! O(Iter·K·m) for m clusters; extraction O(component size).
//!
//! Results are deterministic for the same mesh and parameters (including the SMACOF seed),
//! whatever the number of threads. Positions and radii are reported in the file's units.

use std::time::Instant;

use keycomp_geodesic::{GeodesicError, GeodesicSolver, distance_matrix};
use keycomp_harris::{HarrisError, HarrisParams};
use keycomp_mesh::{Mesh, Point3, Topology, VertexId, geometry};
use serde::{Deserialize, Serialize};

use crate::{
    ComponentParams, ComponentsError, Embedding, RegionGrower, Sphere, adaptive_clustering,
    geodesic_center, min_enclosing_sphere, smacof,
};

/// All parameters of detection: the keypoint detector and the components stage. The default is
/// the paper's KC-1 (1 % of the vertices as keypoints, R = 0.15, T = 0.30, N = 30, σ = 1.5).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DetectParams {
    /// Harris 3D keypoints (neighbourhood, k, how many keypoints).
    pub harris: HarrisParams,
    /// Clustering, region growing and SMACOF.
    pub components: ComponentParams,
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
    /// Fast-marching distance matrix.
    pub geodesic: f64,
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
    /// Keypoints in no cluster (sorted vertex ids).
    pub unclustered: Vec<VertexId>,
    /// The key-components.
    pub components: Vec<KeyComponent>,
    /// Time per stage.
    pub timings: Timings,
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
    params.harris.validate()?;
    params.components.validate()?;

    let t = Instant::now();
    let area = geometry::total_area(mesh);
    let (norm, scale) = geometry::normalize_unit_area(mesh);
    let topo = Topology::new(&norm);
    let harris = keycomp_harris::detect(&norm, &topo, &params.harris)?;
    let t_harris = ms(t);

    let t = Instant::now();
    let solver = GeodesicSolver::new(&norm, &topo)?;
    let dist = distance_matrix(&solver, &harris.keypoints)?;
    let t_geodesic = ms(t);

    let t = Instant::now();
    let k = harris.keypoints.len();
    let embedding = smacof(dist.as_slice(), k, &params.components.smacof)?;
    let t_mds = ms(t);

    let t = Instant::now();
    let clustering = adaptive_clustering(&embedding.points, &params.components.cluster)?;
    let t_cluster = ms(t);

    let t = Instant::now();
    let face_areas = geometry::face_areas(&norm);
    let total: f64 = face_areas.iter().sum();
    let mut grower = RegionGrower::new(&norm, &topo)?;
    let mut components = Vec::with_capacity(clustering.clusters.len());
    for (id, cluster) in clustering.clusters.iter().enumerate() {
        let center = harris.keypoints[geodesic_center(&cluster.members, &embedding.points)?];
        let mut keypoints: Vec<VertexId> = cluster
            .members
            .iter()
            .map(|&i| harris.keypoints[i])
            .collect();
        keypoints.sort_unstable();
        let points: Vec<Point3<f64>> = keypoints
            .iter()
            .map(|&v| norm.positions[v as usize])
            .collect();
        let sphere: Sphere = min_enclosing_sphere(&points)?;
        let grown = grower.grow(center, &keypoints, &sphere, params.components.sigma)?;
        let area_fraction: f64 = grown.faces.iter().map(|&f| face_areas[f as usize]).sum();
        components.push(KeyComponent {
            id,
            center,
            sphere_center: (sphere.center.coords / scale).into(),
            sphere_radius: sphere.radius / scale,
            keypoints,
            vertices: grown.vertices,
            faces: grown.faces,
            area: area_fraction / total,
            missed_keypoints: grown.missed_keypoints,
        });
    }
    let mut unclustered: Vec<VertexId> = clustering
        .unassigned
        .iter()
        .map(|&i| harris.keypoints[i])
        .collect();
    unclustered.sort_unstable();
    let t_extract = ms(t);

    Ok(Detection {
        area,
        scale,
        response: harris.response,
        keypoints: harris.keypoints,
        embedding,
        disconnected_pairs: dist.disconnected_pairs(),
        unclustered,
        components,
        timings: Timings {
            harris: t_harris,
            geodesic: t_geodesic,
            mds: t_mds,
            cluster: t_cluster,
            extract: t_extract,
        },
    })
}
