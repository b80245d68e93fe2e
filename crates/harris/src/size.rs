//! Reference lengths that adaptive radii and spacings are fractions of.

use keycomp_mesh::geometry::bounding_box;
use keycomp_mesh::{Mesh, Vector3};

use crate::params::LengthReference;

/// The mesh's diagonal as chosen by `reference` (for [`LengthReference::Unit`], the square root
/// of its own area), in the mesh's units. NaN for a mesh without faces (or of zero area, for the
/// moment diagonal and the unit).
pub fn reference_length(mesh: &Mesh, reference: LengthReference) -> f64 {
    match reference {
        LengthReference::BoundingBoxDiagonal => {
            if mesh.faces.is_empty() {
                f64::NAN
            } else {
                bounding_box(mesh).diagonal()
            }
        }
        LengthReference::MomentDiagonal => moment_diagonal(mesh),
        // the mesh's own unit here; a caller with another unit area passes it to `*_in`
        LengthReference::Unit => {
            let a = keycomp_mesh::geometry::total_area(mesh);
            if a > 0.0 { a.sqrt() } else { f64::NAN }
        }
    }
}

/// `√(12 · E|p − μ|²)` for p uniform over the surface (area-weighted, integrated exactly over
/// each triangle) and μ its centroid: a rotation- and translation-invariant size. For a surface
/// spread evenly over an axis-aligned box of sides a, b, c (or over a sphere) it equals the
/// bounding-box diagonal √(a² + b² + c²), which is why the √12. NaN for zero area. O(|F|).
pub fn moment_diagonal(mesh: &Mesh) -> f64 {
    // Coordinates relative to a vertex of the mesh, so far-away meshes lose no precision.
    let Some(first) = mesh.faces.first() else {
        return f64::NAN;
    };
    let o = mesh.positions[first[0] as usize];
    let mut area = 0.0;
    let mut first_moment = Vector3::zeros();
    let mut second = 0.0; // ∫ |p − o|² dA
    for f in 0..mesh.num_faces() {
        let [a, b, c] = mesh.triangle(f).map(|p| p - o);
        let af = 0.5 * (b - a).cross(&(c - a)).norm();
        let s = a + b + c;
        area += af;
        first_moment += s * (af / 3.0);
        // ∫_T |p|² dA = A/12 · (|a|² + |b|² + |c|² + |a + b + c|²)
        second +=
            af / 12.0 * (a.norm_squared() + b.norm_squared() + c.norm_squared() + s.norm_squared());
    }
    if area.is_nan() || area <= 0.0 {
        return f64::NAN;
    }
    let mu = first_moment / area;
    let var = (second / area - mu.norm_squared()).max(0.0);
    (12.0 * var).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;
    use nalgebra::Rotation3;

    #[test]
    fn moment_diagonal_matches_the_box_for_a_plate_and_a_sphere() {
        // flat plate 4 × 2: bounding-box diagonal √20
        let mut m = synth::grid(8, 4, 0.5);
        let d = moment_diagonal(&m);
        assert!((d - 20f64.sqrt()).abs() < 1e-9, "{d}");
        // invariant under rotation and translation, while the box is not
        let r = Rotation3::from_euler_angles(0.4, -0.2, 0.9);
        for p in &mut m.positions {
            *p = r * *p + Vector3::new(1e3, 2e3, -5e2);
        }
        assert!((moment_diagonal(&m) - d).abs() < 1e-9 * d);
        assert!((reference_length(&m, LengthReference::BoundingBoxDiagonal) - d).abs() > 0.1);
        // sphere of radius 2: box diagonal 4√3, approached as the tessellation refines
        let s = synth::icosphere(5, 2.0);
        let d = moment_diagonal(&s);
        assert!((d - 4.0 * 3f64.sqrt()).abs() < 1e-2, "{d}");
    }
}
