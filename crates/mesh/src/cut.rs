//! Sub-meshes: keeping a subset of faces (a fragment of a shape), with the map back to the
//! original vertex ids.

use crate::{Mesh, Point3, Vector3, VertexId};

/// The faces for which `keep(face index)` is true, with their vertices renumbered compactly in
/// increasing original id order, and for each new vertex its original id.
pub fn submesh(mesh: &Mesh, keep: impl Fn(usize) -> bool) -> (Mesh, Vec<VertexId>) {
    let mut new_id = vec![u32::MAX; mesh.num_vertices()];
    let kept: Vec<usize> = (0..mesh.num_faces()).filter(|&f| keep(f)).collect();
    for &f in &kept {
        for &v in &mesh.faces[f] {
            new_id[v as usize] = 0;
        }
    }
    let mut original = Vec::new();
    for (v, id) in new_id.iter_mut().enumerate() {
        if *id == 0 {
            *id = original.len() as u32;
            original.push(v as VertexId);
        }
    }
    let positions = original
        .iter()
        .map(|&v| mesh.positions[v as usize])
        .collect();
    let faces = kept
        .iter()
        .map(|&f| mesh.faces[f].map(|v| new_id[v as usize]))
        .collect();
    (Mesh { positions, faces }, original)
}

/// The part of `mesh` on the positive side of the plane through `point` with normal `normal`:
/// the faces whose centroid lies there (faces are kept whole, never split).
pub fn cut_by_plane(
    mesh: &Mesh,
    point: Point3<f64>,
    normal: Vector3<f64>,
) -> (Mesh, Vec<VertexId>) {
    submesh(mesh, |f| {
        let [a, b, c] = mesh.triangle(f);
        let centroid = Point3::from((a.coords + b.coords + c.coords) / 3.0);
        (centroid - point).dot(&normal) > 0.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{geometry, synth};

    #[test]
    fn half_a_sphere() {
        let m = synth::icosphere(4, 1.0);
        let (half, orig) = cut_by_plane(&m, Point3::origin(), Vector3::z());
        let a = geometry::total_area(&half) / geometry::total_area(&m);
        assert!((a - 0.5).abs() < 0.02, "{a}");
        assert_eq!(orig.len(), half.num_vertices());
        for (i, &o) in orig.iter().enumerate() {
            assert_eq!(half.positions[i], m.positions[o as usize]);
        }
        assert!(orig.windows(2).all(|w| w[0] < w[1]));
        let (_, rep) = Mesh::from_raw(half.positions.clone(), half.faces.clone()).expect("valid");
        assert_eq!(rep.unreferenced_vertices, 0);
    }
}
