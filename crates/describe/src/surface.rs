//! The surface a shape is described on: the mesh scaled to the length unit, smoothed, with
//! its Harris fits recomputed there (response, principal curvatures as shape index and
//! curvedness), area-weighted vertex normals and barycentric vertex areas, and its geodesic
//! solver.
//!
//! Smoothing is Taubin's λ|μ filter (G. Taubin, "A signal processing approach to fair surface
//! design", SIGGRAPH 1995, `keycomp_mesh::smooth`), the Harris fit that of Harris 3D
//! (I. Sipiran and B. Bustos, "Harris 3D: a robust extension of the Harris operator for
//! interest point detection on 3D meshes", The Visual Computer 27(11), 2011,
//! `keycomp_harris`), the shape index and curvedness those of J. J. Koenderink and A. J. van
//! Doorn, "Surface shape and curvature scales", Image and Vision Computing 10(8), 1992. Why
//! the surface is smoothed first: crate documentation, *Smoothing*.
//!
//! Cost: the smoothing passes over the whole mesh and one Harris fit per vertex.

use keycomp_components::Detection;
use keycomp_geodesic::GeodesicSolver;
use keycomp_harris::LocalFit;
use keycomp_mesh::{Mesh, Topology, Vector3, geometry, smooth};

use crate::error::DescribeError;
use crate::params::{DescribeParams, Units};

/// Per-vertex quantities of the smoothed, rescaled surface.
pub(crate) struct Surface {
    pub(crate) mesh: Mesh,
    pub(crate) response: Vec<f64>,
    /// Koenderink's shape index in [−1, 1], NaN without a fit.
    pub(crate) shape_index: Vec<f64>,
    /// Curvedness √((κ1² + κ2²)/2) in inverse length units, NaN without a fit.
    pub(crate) curvedness: Vec<f64>,
    pub(crate) areas: Vec<f64>,
    pub(crate) normals: Vec<Vector3<f64>>,
    pub(crate) total_keypoints: f64,
    pub(crate) vertices: f64,
    /// Entry 31 holds the part's size in the length unit instead of its keypoint density.
    pub(crate) file_units: bool,
    /// Vertices without a Harris response (fits reaching the boundary, `skip_boundary`) are
    /// left out of the response histogram instead of counted in its lowest bin.
    pub(crate) skip_unfitted: bool,
}

/// The surface `params` describe `mesh` on (scaled to the length unit, smoothed, with its
/// Harris fits), which vertices lie on its boundary, and its geodesic solver. When the scale
/// is free the unit is the detection's ([`Detection::scale`]: the shape's own unit area, or the
/// area of the shape a fragment stands for when it was detected in its source's unit,
/// `keycomp_components::detect_in`).
pub(crate) fn prepare(
    mesh: &Mesh,
    det: &Detection,
    params: &DescribeParams,
) -> Result<(Surface, Vec<bool>, GeodesicSolver), DescribeError> {
    let n = mesh.num_vertices();
    let scale = match params.units {
        Units::ScaleFree if det.scale.is_finite() && det.scale > 0.0 => det.scale,
        Units::ScaleFree => 1.0,
        Units::File { length } => 1.0 / length,
    };
    let mut norm = Mesh {
        positions: mesh.positions.iter().map(|p| p * scale).collect(),
        faces: mesh.faces.clone(),
    };
    let topo = Topology::new(&norm);
    let passes = keycomp_harris::smoothing_passes(
        &norm,
        &topo,
        params.smoothing_iterations,
        params.smoothing_length,
        keycomp_harris::UnitArea::Given(1.0),
    );
    norm.positions = smooth::taubin(&norm, &topo, passes);
    let normals = geometry::vertex_normals(&norm);
    // Harris parameters in the unit's lengths are fitted in the unit's frame (a fragment in
    // its source's unit gets its source's neighbourhoods); otherwise in the smoothed surface's
    // own unit-area frame, as detection does
    let unit = match params.harris.length_reference {
        keycomp_harris::LengthReference::Unit => keycomp_harris::UnitArea::Given(1.0),
        _ => keycomp_harris::UnitArea::Own,
    };
    let fits = keycomp_harris::local_fits_in(&norm, &topo, &params.harris, unit);
    // Fits are in units of the smoothed mesh scaled to unit area (or already in the unit's
    // frame); curvatures scale back.
    let norm_area = geometry::total_area(&norm);
    let to_len = if unit == keycomp_harris::UnitArea::Given(1.0) {
        1.0
    } else if norm_area > 0.0 {
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
