//! Descriptors of key-components, for retrieval and part-to-part matching.
//!
//! Each key-component found by `keycomp_components::detect` (Sipiran & Bustos, "Key-components:
//! detection of salient regions on 3D meshes", The Visual Computer 29, 2013) gets one
//! fixed-length vector of [`DIM`] numbers built from the Harris response inside it and from
//! geodesic statistics around its geodesic centre, and the shape gets a *layout*: the geodesic
//! distances between its components' centres, used to check that matched components sit in the
//! same arrangement (DESIGN "Retrieval").
//!
//! # The descriptor, bin by bin
//!
//! Every part is invariant to rigid motion and to uniform scale: histograms are of ratios, and
//! the scalars are ratios of lengths or areas measured on the component itself, never on the
//! whole shape (a fragment of a shape has a different total area, and its components must still
//! match the full shape's). All histograms are area-weighted (barycentric vertex areas) and sum
//! to 1, so they do not depend on the tessellation's density.
//!
//! | bins | what | why |
//! |---|---|---|
//! | 0–7 | Harris response (recomputed on the smoothed surface, see *Smoothing*) `h/h_max` inside the component (`h_max` = its largest response), on a log scale: bin `b` holds `log10(h/h_max) ∈ [−(8−b)/2, −(7−b)/2)`, bin 0 also everything below 10⁻⁴ and `h ≤ 0` | how concentrated the salient features are: a sharp tip has a few strong responses, a textured region many similar ones |
//! | 8–15 | geodesic distance from the centre divided by the component's geodesic radius (largest such distance), 8 equal bins over [0, 1] | how area grows with distance: a disc grows linearly, a finger stays flat, a cone grows fast |
//! | 16–23 | `‖x − c‖ / d_geo(c, x)` for vertices beyond 20 % of the radius, 8 equal bins over [0, 1] | bending: 1 on a flat patch, lower the more the surface curls back (a fingertip, an ear) |
//! | 24–27 | angle between each vertex normal and the component's mean normal, 4 equal bins over [0, π] | how much the surface turns: flat, cap, tube, or wrapped |
//! | 28 | `ln(radius / √area)` of the component, shifted by `ln(1/√π)` (0 for a flat disc) | elongation along the surface |
//! | 29 | `λ2/λ1` of the component's vertex covariance | in-space elongation |
//! | 30 | `λ3/λ1` of the same | flatness (0 flat, 1 ball-like) |
//! | 31 | keypoint density: `(K_c/V_c)/(K/V)` mapped by `x/(1+x)` | how much of the shape's saliency the component gathers, relative to the shape's average |
//!
//! Scalars are weighted ([`SCALAR_WEIGHT`]) so that each is worth about one histogram bin
//! difference at most. Euclidean distance between descriptors is the dissimilarity.
//!
//! # Smoothing
//!
//! Everything above is measured on a smoothed copy of the surface (the shape scaled to unit
//! area, then [`DescribeParams::smoothing_iterations`] = 30 Taubin λ|μ pairs, [`smooth`]), with
//! the Harris response recomputed there; the component's vertices, keypoints and centre come
//! from the detection on the surface as it is. Per-vertex responses and normals are what
//! Gaussian noise scrambles, and noise lengthens geodesics: described on the raw surface,
//! corresponding components under the benchmark's noise (strength 3) were as far apart as
//! unrelated ones (median 0.91 vs 0.99); on the smoothed copy 0.28 vs 0.53, with the other
//! transformations and the TOSCA pose test unchanged (BENCHMARKS.md, *Descriptors under the
//! benchmark transformations*, lists 0, 10, 20 and 30 pairs). Smoothing before measuring is a
//! choice of ours, not the paper's (the paper does not describe components).
//!
//! Cost: 60 smoothing passes over the whole mesh and a Harris response pass as costly as
//! detection's own (BENCHMARKS.md section 2), one fast-marching front per component (the distances from its centre), plus
//! linear passes over its vertices.

use keycomp_components::Detection;
use keycomp_geodesic::{GeodesicError, GeodesicSolver};
use keycomp_mesh::{Mesh, Topology, Vector3, geometry};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

pub mod smooth;

/// Version of the descriptor's definition: bumped whenever the same mesh and detection would
/// give other numbers, so that an index never compares descriptors made two ways (the CLI
/// records it in the index's profile). 1: session 1 (raw surface); 2: smoothed surface with
/// the Harris response recomputed there.
pub const DESCRIPTOR_VERSION: u32 = 2;

/// Parameters of [`describe_with`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DescribeParams {
    /// Taubin λ|μ pairs applied to the surface before describing (see *Smoothing*). Default 30;
    /// 0 describes the surface as it is.
    pub smoothing_iterations: usize,
    /// Harris 3D settings of the response histogram (bins 0–7), computed on the smoothed
    /// surface. Default: the detector's defaults, whatever the detection used, so that every
    /// shape of an index is described alike.
    pub harris: keycomp_harris::HarrisParams,
}

impl Default for DescribeParams {
    fn default() -> Self {
        DescribeParams {
            smoothing_iterations: 30,
            harris: keycomp_harris::HarrisParams::default(),
        }
    }
}

/// Number of values in a component descriptor.
pub const DIM: usize = 32;

/// Weight of the four scalar entries (28–31) relative to histogram bins.
pub const SCALAR_WEIGHT: f32 = 0.5;

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
}

/// One described key-component.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComponentDescription {
    /// The descriptor (see the module documentation).
    pub descriptor: Descriptor,
    /// The component's geodesic centre (vertex id).
    pub center: u32,
    /// Area of the component as a fraction of the shape's area.
    pub area: f64,
    /// Number of keypoints in the component's cluster.
    pub keypoints: usize,
    /// Largest geodesic distance from the centre to a vertex of the component, in units of the
    /// shape scaled to unit area.
    pub radius: f64,
}

/// A shape's components and their layout.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeDescription {
    /// One entry per key-component, in detection order.
    pub components: Vec<ComponentDescription>,
    /// Geodesic distances between component centres, `m × m` row-major, in units of the shape
    /// scaled to unit area (symmetrised; pairs on different connected pieces get `f32::INFINITY`
    /// replaced by twice the largest finite value, or 0 when there is none).
    pub layout: Vec<f32>,
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

/// Describes every key-component of `det`, which must be the detection of `mesh`, with the
/// default [`DescribeParams`].
pub fn describe(mesh: &Mesh, det: &Detection) -> Result<ShapeDescription, DescribeError> {
    describe_with(mesh, det, &DescribeParams::default())
}

/// Describes every key-component of `det`, which must be the detection of `mesh`.
pub fn describe_with(
    mesh: &Mesh,
    det: &Detection,
    params: &DescribeParams,
) -> Result<ShapeDescription, DescribeError> {
    let n = mesh.num_vertices();
    for c in &det.components {
        if let Some(&v) = c
            .vertices
            .iter()
            .chain(std::iter::once(&c.center))
            .find(|&&v| v as usize >= n)
        {
            return Err(DescribeError::Mismatch {
                vertex: v,
                vertices: n,
            });
        }
    }
    let (mut norm, _) = geometry::normalize_unit_area(mesh);
    let topo = Topology::new(&norm);
    norm.positions = smooth::taubin(&norm, &topo, params.smoothing_iterations);
    let response = keycomp_harris::harris_response(&norm, &topo, &params.harris);
    let solver = GeodesicSolver::new(&norm, &topo)?;
    let areas = geometry::vertex_areas(&norm);
    let normals = area_weighted_normals(&norm);
    let total_keypoints = det.keypoints.len().max(1) as f64;
    let referenced = n.max(1) as f64;

    let m = det.components.len();
    let centers: Vec<u32> = det.components.iter().map(|c| c.center).collect();
    let mut layout = vec![0f32; m * m];
    let mut ws = solver.workspace();
    let mut components = Vec::with_capacity(m);
    for (ci, c) in det.components.iter().enumerate() {
        solver.solve(c.center, &mut ws)?;
        let d = ws.distances();
        for (cj, &o) in centers.iter().enumerate() {
            layout[ci * m + cj] = d[o as usize] as f32;
        }
        let center = norm.positions[c.center as usize];
        let radius = c
            .vertices
            .iter()
            .map(|&v| d[v as usize])
            .filter(|x| x.is_finite())
            .fold(0.0f64, f64::max);
        let comp_area: f64 = c.vertices.iter().map(|&v| areas[v as usize]).sum();
        let h_max = c
            .vertices
            .iter()
            .map(|&v| response[v as usize])
            .filter(|h| h.is_finite())
            .fold(f64::NEG_INFINITY, f64::max);

        let mut desc = [0f32; DIM];
        let mut mean_normal = Vector3::zeros();
        let mut mean = Vector3::zeros();
        for &v in &c.vertices {
            let a = areas[v as usize];
            mean_normal += normals[v as usize] * a;
            mean += norm.positions[v as usize].coords * a;
        }
        if mean_normal.norm() > 0.0 {
            mean_normal.normalize_mut();
        }
        if comp_area > 0.0 {
            mean /= comp_area;
        }
        let mut cov = Matrix3::zeros();
        for &v in &c.vertices {
            let a = areas[v as usize] as f32;
            let w = a as f64;
            let vi = v as usize;
            // Harris response, log scale relative to the component's maximum
            let h = response[vi];
            let b = if h.is_finite() && h > 0.0 && h_max > 0.0 {
                bin((h / h_max).log10(), -4.0, 0.0, 8)
            } else {
                0
            };
            desc[b] += a;
            // geodesic distance from the centre, relative to the radius
            let dg = d[vi];
            if dg.is_finite() && radius > 0.0 {
                desc[8 + bin(dg / radius, 0.0, 1.0, 8)] += a;
                if dg > 0.2 * radius {
                    let ratio = (norm.positions[vi] - center).norm() / dg;
                    desc[16 + bin(ratio, 0.0, 1.0 + 1e-9, 8)] += a;
                }
            }
            // normal turning
            let ang = normals[vi].dot(&mean_normal).clamp(-1.0, 1.0).acos();
            desc[24 + bin(ang, 0.0, std::f64::consts::PI + 1e-9, 4)] += a;
            let p = norm.positions[vi].coords - mean;
            cov += p * p.transpose() * w;
        }
        normalise(&mut desc[0..8]);
        normalise(&mut desc[8..16]);
        normalise(&mut desc[16..24]);
        normalise(&mut desc[24..28]);
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
        let density = if !c.vertices.is_empty() {
            (c.keypoints.len() as f64 / c.vertices.len() as f64) / (total_keypoints / referenced)
        } else {
            0.0
        };
        desc[28] = SCALAR_WEIGHT * (compact.clamp(-2.0, 2.0) / 2.0) as f32;
        desc[29] = SCALAR_WEIGHT * r21 as f32;
        desc[30] = SCALAR_WEIGHT * r31 as f32;
        desc[31] = SCALAR_WEIGHT * (density / (1.0 + density)) as f32;
        components.push(ComponentDescription {
            descriptor: desc,
            center: c.center,
            area: c.area,
            keypoints: c.keypoints.len(),
            radius,
        });
    }
    // symmetrise the layout; disconnected pairs get twice the largest finite distance
    let finite_max = layout
        .iter()
        .copied()
        .filter(|x| x.is_finite())
        .fold(0f32, f32::max);
    for i in 0..m {
        for j in 0..i {
            let (a, b) = (layout[i * m + j], layout[j * m + i]);
            let v = if a.is_finite() && b.is_finite() {
                0.5 * (a + b)
            } else {
                2.0 * finite_max
            };
            layout[i * m + j] = v;
            layout[j * m + i] = v;
        }
        layout[i * m + i] = 0.0;
    }
    Ok(ShapeDescription { components, layout })
}

/// Euclidean distance between two descriptors.
pub fn distance(a: &Descriptor, b: &Descriptor) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f32>()
        .sqrt()
}
