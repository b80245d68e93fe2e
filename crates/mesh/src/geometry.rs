//! Geometric quantities of a mesh: face areas, per-vertex (barycentric) areas and normals,
//! total area, bounding box, and normalisation to unit surface area.
//!
//! Sipiran & Bustos (2013), Section 4.1, normalise every mesh to surface area 1 so that the
//! clustering thresholds R and T and the growth factor σ have fixed meaning; [`normalize_unit_area`]
//! does the same and returns the scale so results can be reported in the file's own units.

use crate::{Mesh, Point3};

/// Area of each face, in file units squared.
pub fn face_areas(mesh: &Mesh) -> Vec<f64> {
    (0..mesh.num_faces())
        .map(|f| {
            let [a, b, c] = mesh.triangle(f);
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .collect()
}

/// Unit normal of each vertex: the sum of its faces' normals weighted by their areas,
/// normalised (the faces' winding sets the side); zero for a vertex no face with an area uses.
pub fn vertex_normals(mesh: &Mesh) -> Vec<crate::Vector3<f64>> {
    let mut n = vec![crate::Vector3::zeros(); mesh.num_vertices()];
    for (f, tri) in mesh.faces.iter().enumerate() {
        let [a, b, c] = mesh.triangle(f);
        let face = (b - a).cross(&(c - a)); // length = 2·area: area weighting
        for &v in tri {
            n[v as usize] += face;
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

/// Barycentric area of each vertex: a third of the area of every face around it. The values sum
/// to the total area; an unreferenced vertex gets 0.
pub fn vertex_areas(mesh: &Mesh) -> Vec<f64> {
    let mut areas = vec![0.0; mesh.num_vertices()];
    for (f, a) in mesh.faces.iter().zip(face_areas(mesh)) {
        for &v in f {
            areas[v as usize] += a / 3.0;
        }
    }
    areas
}

/// Total surface area.
pub fn total_area(mesh: &Mesh) -> f64 {
    face_areas(mesh).iter().sum()
}

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundingBox {
    /// Smallest coordinates.
    pub min: Point3<f64>,
    /// Largest coordinates.
    pub max: Point3<f64>,
}

impl BoundingBox {
    /// Length of the box's diagonal.
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).norm()
    }
}

/// Bounding box of the vertices that faces refer to (unreferenced vertices are ignored, so a
/// stray point far away does not change neighbourhood sizes). Computed from the vertices
/// themselves, never including the origin unless a vertex is there.
pub fn bounding_box(mesh: &Mesh) -> BoundingBox {
    bounding_box_of(
        mesh.faces
            .iter()
            .flatten()
            .map(|&v| mesh.positions[v as usize]),
    )
}

/// Bounding box of `points` (min at +∞ and max at −∞ when there are none).
pub fn bounding_box_of(points: impl IntoIterator<Item = Point3<f64>>) -> BoundingBox {
    let mut min = Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
    let mut max = Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
    for p in points {
        min = min.inf(&p);
        max = max.sup(&p);
    }
    BoundingBox { min, max }
}

/// Returns a copy of `mesh` scaled about the origin to total area 1, and the factor `s` applied
/// (new = s · old, s = 1/√area). Divide normalised lengths by `s` (areas by `s²`) to get file
/// units back.
pub fn normalize_unit_area(mesh: &Mesh) -> (Mesh, f64) {
    let area = total_area(mesh);
    let s = if area > 0.0 { 1.0 / area.sqrt() } else { 1.0 };
    let positions = mesh.positions.iter().map(|p| p * s).collect();
    (
        Mesh {
            positions,
            faces: mesh.faces.clone(),
        },
        s,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth;

    #[test]
    fn unit_square_areas() {
        let m = synth::grid(1, 1, 1.0);
        assert_eq!(m.num_faces(), 2);
        assert!((total_area(&m) - 1.0).abs() < 1e-15);
        let va = vertex_areas(&m);
        assert!((va.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        let bb = bounding_box(&m);
        assert!((bb.diagonal() - 2f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn normalisation_gives_unit_area_and_keeps_the_scale() {
        let m = synth::icosphere(3, 7.5);
        let a = total_area(&m);
        let (n, s) = normalize_unit_area(&m);
        assert!((total_area(&n) - 1.0).abs() < 1e-12);
        assert!((s - 1.0 / a.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn bounding_box_does_not_include_the_origin() {
        let mut m = synth::grid(2, 2, 1.0);
        for p in &mut m.positions {
            p.x += 10.0;
            p.y += 10.0;
            p.z += 10.0;
        }
        let bb = bounding_box(&m);
        // the grid spans [-1, 1]² at z = 0 before the shift
        assert_eq!(bb.min, Point3::new(9.0, 9.0, 10.0));
        assert_eq!(bb.max, Point3::new(11.0, 11.0, 10.0));
        assert!((bb.diagonal() - 8f64.sqrt()).abs() < 1e-12);
    }
}
