//! Harris 3D keypoints on triangle meshes: a response per vertex and the keypoints chosen from
//! it (the first stage of key-component detection, Section 3.1 of the 2013 paper).
//!
//! Per vertex v, on the mesh scaled to unit surface area (so responses and keypoints do not
//! depend on the mesh's units, position or orientation):
//!
//! 0. **Smoothing** (optional, off by default; not in the paper): with
//!    [`HarrisParams::smoothing_iterations`] = n > 0, steps 1–5 run on a copy of the mesh
//!    smoothed by n Taubin λ|μ pairs (`keycomp_mesh::smooth`), so that noise of a few edge
//!    lengths does not make responses of its own. Selection (step 6) is on the same vertices.
//! 1. **Neighbourhood.** Whole rings around v, breadth first. Adaptive (default): grow until the
//!    last ring's longest edge path from v exceeds `0.01 × diagonal`, where the diagonal is the
//!    rotation-invariant [`moment_diagonal`] by default or, as in the authors' code, the
//!    bounding-box diagonal (box of the vertices themselves). Or a fixed number of rings. Either way at least
//!    [`HarrisParams::min_rings`] rings (adaptive) and [`HarrisParams::min_points`] vertices,
//!    so the 6-coefficient fit is always over-determined.
//! 2. **Frame.** Centre the points on their centroid; PCA of the 3 × 3 covariance: the
//!    eigenvector of the smallest eigenvalue is the normal z (oriented so v lies on its positive
//!    side), the largest is x, y = z × x. v is the origin.
//! 3. **Fit.** Least squares `z = p1/2·x² + p2·xy + p3/2·y² + p4·x + p5·y + p6`
//!    ([`fit_quadratic`], Householder QR of the scaled design matrix).
//! 4. **Smoothed derivatives** (Gaussian, σ² = 2): `A = p4² + 2p1² + 2p2²`,
//!    `B = p5² + 2p2² + 2p3²`, `C = p4·p5 + 2p1·p2 + 2p2·p3`.
//! 5. **Response** `h = A·B − C² − k·(A + B)²` ([`response_from_coefficients`]). A vertex no
//!    face refers to, whose connected piece has fewer than `min_points` vertices, or whose
//!    fit is rank deficient has no response: `f64::NAN` in the response vector.
//! 6. **Selection** ([`select_keypoints`]): candidates are vertices whose response is ≥ that of
//!    every 1-ring neighbour (ties count); then the best `fraction × |V|`, a fixed count, or a
//!    greedy spacing rule. Keypoints come best first (response descending, then vertex id).
//!
//! Complexity: O(|V| · m) for neighbourhoods of m vertices on average (each needs a BFS, a 3 × 3
//! eigen-decomposition and an m × 6 QR), parallel over vertices with rayon; selection is
//! O(|E| + c log c) for c candidates (spacing adds O(c · K) for K keypoints).
//!
//! Differences from the authors' code (each a fix): the bounding box never includes the origin,
//! and by default the radius is relative to a rotation-invariant size instead;
//! the computation is on the unit-area mesh (their response mixes slope and curvature terms, so
//! rescaling a mesh changes its keypoints); neighbourhoods have at least 2 rings and 12 points
//! (theirs are often the 1-ring, about 7 points for 6 unknowns); `p5²` in B (a `p4²` typo in
//! their first release); ties, NaN and the selection budget are handled exactly.
//!
//! References:
//! - I. Sipiran and B. Bustos, "Harris 3D: a robust extension of the Harris operator for
//!   interest point detection on 3D meshes", *The Visual Computer* 27(11), 963–976, 2011.
//! - I. Sipiran and B. Bustos, "Key-components: detection of salient regions on 3D meshes",
//!   *The Visual Computer* 29(12), 1319–1332, 2013.

mod fit;
mod params;
mod response;
mod select;
mod size;

use std::borrow::Cow;

use keycomp_mesh::{Mesh, Topology, VertexId};

pub use fit::{fit_quadratic, response_from_coefficients};
pub use params::{HarrisError, HarrisParams, LengthReference, Neighborhood, Selection, UnitArea};
pub use response::LocalFit;
pub use select::{local_maxima, select_keypoints, select_keypoints_in};
pub use size::{moment_diagonal, reference_length};

/// Responses and keypoints of one mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct HarrisResult {
    /// Harris response per vertex (on the unit-area mesh; unitless), `f64::NAN` where a vertex
    /// has none (see the crate docs, step 5).
    pub response: Vec<f64>,
    /// Keypoint vertex ids, best first.
    pub keypoints: Vec<VertexId>,
}

/// Harris response of every vertex (steps 1–5), computed as if the mesh were scaled to unit
/// area; NaN where a vertex has no response. Parallel over vertices.
///
/// `topo` must be built from `mesh` and `params` should be validated
/// ([`HarrisParams::validate`]); [`detect`] checks both. This function never panics: with a
/// mismatched topology, a mesh of zero area or non-finite extent, every response is NaN, and
/// out-of-range parameters are clamped (rings and points to their minimum).
pub fn harris_response(mesh: &Mesh, topo: &Topology, params: &HarrisParams) -> Vec<f64> {
    harris_response_in(mesh, topo, params, UnitArea::Own)
}

/// [`harris_response`] in the unit-area frame of `unit` (the area that counts as 1) instead of
/// the mesh's own area.
pub fn harris_response_in(
    mesh: &Mesh,
    topo: &Topology,
    params: &HarrisParams,
    unit: UnitArea,
) -> Vec<f64> {
    let n = mesh.num_vertices();
    if topo.num_vertices() != n {
        return vec![f64::NAN; n];
    }
    let unit = unit.resolved(mesh);
    let mesh = smoothed(mesh, topo, params, unit);
    let edges = response::edge_lengths(&mesh, topo, params);
    match response::Context::new(&mesh, topo, params, &edges, unit) {
        Some(ctx) => response::all_responses(&ctx),
        None => vec![f64::NAN; n],
    }
}

/// Steps 1–3 for every vertex: its local frame and fitted quadratic (unit-area units), `None`
/// where [`harris_response`] gives NaN; the response is
/// [`response_from_coefficients`]`(&fit.coefficients, params.k)`. For callers that need more of
/// the fit than the response (e.g. curvatures). Parallel over vertices; never panics (a
/// mismatched topology or a degenerate mesh gives `None` everywhere).
pub fn local_fits(mesh: &Mesh, topo: &Topology, params: &HarrisParams) -> Vec<Option<LocalFit>> {
    local_fits_in(mesh, topo, params, UnitArea::Own)
}

/// [`local_fits`] in the unit-area frame of `unit` instead of the mesh's own area.
pub fn local_fits_in(
    mesh: &Mesh,
    topo: &Topology,
    params: &HarrisParams,
    unit: UnitArea,
) -> Vec<Option<LocalFit>> {
    let n = mesh.num_vertices();
    if topo.num_vertices() != n {
        return vec![None; n];
    }
    let unit = unit.resolved(mesh);
    let mesh = smoothed(mesh, topo, params, unit);
    let edges = response::edge_lengths(&mesh, topo, params);
    match response::Context::new(&mesh, topo, params, &edges, unit) {
        Some(ctx) => response::all_fits(&ctx),
        None => vec![None; n],
    }
}

/// Steps 1–3 for a single vertex: its neighbourhood size, local frame and fitted coefficients
/// (unit-area units), or `None` where [`harris_response`] gives NaN. For inspection and tests;
/// allocates O(|V|) scratch per call.
pub fn local_fit(
    mesh: &Mesh,
    topo: &Topology,
    params: &HarrisParams,
    v: VertexId,
) -> Option<LocalFit> {
    if topo.num_vertices() != mesh.num_vertices() || v as usize >= mesh.num_vertices() {
        return None;
    }
    let unit = UnitArea::Own.resolved(mesh);
    let mesh = smoothed(mesh, topo, params, unit);
    let edges = response::edge_lengths(&mesh, topo, params);
    let ctx = response::Context::new(&mesh, topo, params, &edges, unit)?;
    let mut s = response::Scratch::new(mesh.num_vertices());
    response::local_fit_with(&ctx, v, &mut s)
}

/// Taubin λ|μ pairs that [`HarrisParams::smoothing_length`] (or, without it,
/// [`HarrisParams::smoothing_iterations`]) asks for on `mesh` in the frame of `unit`: with a
/// length ℓ, `round((ℓ / ē)⁴)` for ē the mean edge length in that frame; at most
/// [`HarrisParams::MAX_SMOOTHING_ITERATIONS`] either way.
///
/// Why the fourth power: one pair multiplies the component of graph frequency k (an
/// eigenvalue of the umbrella operator) by `(1 − λk)(1 − μk) = 1 + 0.03k − 0.265k²`
/// (`keycomp_mesh::smooth`), so n pairs damp frequencies above the pass band like
/// `exp(−0.265·n·k²)`; a spatial frequency ω has k ≈ c·(ωē)², so the damping is fixed by
/// n·ē⁴. On a canonical surface (mean edge 0.011 unit lengths) ℓ = 0.0257 is 30 pairs; on a
/// mesh of twice its resolution, 16 times as many.
pub fn smoothing_passes(
    mesh: &Mesh,
    topo: &Topology,
    smoothing_iterations: usize,
    smoothing_length: Option<f64>,
    unit: UnitArea,
) -> usize {
    let passes = match smoothing_length {
        None => smoothing_iterations,
        Some(length) => {
            let (mut sum, mut count) = (0.0, 0usize);
            for v in 0..topo.num_vertices() as VertexId {
                let p = mesh.positions[v as usize];
                for &w in topo.neighbors(v) {
                    if w > v {
                        sum += (mesh.positions[w as usize] - p).norm();
                        count += 1;
                    }
                }
            }
            let area = unit.area(mesh);
            if count == 0 || !(area > 0.0 && sum > 0.0) {
                return 0;
            }
            let edge = sum / count as f64 / area.sqrt();
            let n = (length / edge).powi(4).round();
            // `as` saturates (NaN → 0)
            n as usize
        }
    };
    passes.min(HarrisParams::MAX_SMOOTHING_ITERATIONS)
}

/// The mesh the responses are computed on: `mesh` itself, or, when smoothing is asked for
/// ([`smoothing_passes`]), a copy smoothed by that many Taubin λ|μ pairs (boundary vertices
/// included). The topology is the same either way.
fn smoothed<'m>(
    mesh: &'m Mesh,
    topo: &Topology,
    params: &HarrisParams,
    unit: UnitArea,
) -> Cow<'m, Mesh> {
    let n = smoothing_passes(
        mesh,
        topo,
        params.smoothing_iterations,
        params.smoothing_length,
        unit,
    );
    if n == 0 {
        return Cow::Borrowed(mesh);
    }
    Cow::Owned(Mesh {
        positions: keycomp_mesh::smooth::taubin_with(mesh, topo, n, false),
        faces: mesh.faces.clone(),
    })
}

/// Validates `params`, computes every response and selects the keypoints.
pub fn detect(
    mesh: &Mesh,
    topo: &Topology,
    params: &HarrisParams,
) -> Result<HarrisResult, HarrisError> {
    detect_in(mesh, topo, params, UnitArea::Own)
}

/// [`detect`] in the unit-area frame of `unit` (the area that counts as 1: responses,
/// [`LengthReference::Unit`] radii, [`Selection::PerArea`] budgets and
/// [`HarrisParams::smoothing_length`] are measured in it) instead of the mesh's own area.
pub fn detect_in(
    mesh: &Mesh,
    topo: &Topology,
    params: &HarrisParams,
    unit: UnitArea,
) -> Result<HarrisResult, HarrisError> {
    params.validate()?;
    if let UnitArea::Given(a) = unit
        && !(a.is_finite() && a > 0.0)
    {
        return Err(HarrisError::InvalidParameter {
            name: "unit_area",
            value: a.to_string(),
            reason: "must be a positive area",
        });
    }
    if topo.num_vertices() != mesh.num_vertices() {
        return Err(HarrisError::TopologyMismatch {
            mesh: mesh.num_vertices(),
            topology: topo.num_vertices(),
        });
    }
    let response = harris_response_in(mesh, topo, params, unit);
    let keypoints = select_keypoints_in(mesh, topo, &response, &params.selection, unit);
    Ok(HarrisResult {
        response,
        keypoints,
    })
}
