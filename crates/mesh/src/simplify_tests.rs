//! Tests of [`super`]: counts, exact positions, protected vertices, topology kept.

use super::*;
use crate::{Topology, synth};
use proptest::prelude::*;

/// (boundary, interior, non-manifold) edge counts.
fn edge_kinds(m: &Mesh) -> (usize, usize, usize) {
    let t = Topology::new(m);
    let mut c = (0, 0, 0);
    for v in 0..m.num_vertices() as u32 {
        for (&w, &k) in t.neighbors(v).iter().zip(t.edge_face_counts(v)) {
            if v < w {
                match k {
                    1 => c.0 += 1,
                    2 => c.1 += 1,
                    _ => c.2 += 1,
                }
            }
        }
    }
    c
}

fn euler(m: &Mesh) -> i64 {
    let (a, b, c) = edge_kinds(m);
    m.num_vertices() as i64 - (a + b + c) as i64 + m.num_faces() as i64
}

/// Checks what every simplification must satisfy and returns it.
fn check(mesh: &Mesh, target: usize, protected: &[VertexId]) -> Simplified {
    let s = simplify(mesh, target, protected);
    assert!(s.original.windows(2).all(|w| w[0] < w[1]));
    assert_eq!(s.original.len(), s.mesh.num_vertices());
    for (i, &o) in s.original.iter().enumerate() {
        assert_eq!(s.mesh.positions[i], mesh.positions[o as usize]);
        assert_eq!(s.proxy_vertex(o), Some(i as VertexId));
    }
    // every vertex is referenced, every face valid and non-degenerate
    let mut used = vec![false; s.mesh.num_vertices()];
    for f in &s.mesh.faces {
        assert!(f[0] != f[1] && f[1] != f[2] && f[0] != f[2]);
        for &v in f {
            used[v as usize] = true;
        }
    }
    assert!(used.iter().all(|u| *u));
    let (_, repairs) = Mesh::from_raw(s.mesh.positions.clone(), s.mesh.faces.clone()).unwrap();
    assert_eq!(repairs.dropped_faces(), 0);
    let referenced = |v: VertexId| mesh.faces.iter().any(|f| f.contains(&v));
    for &p in protected {
        if (p as usize) < mesh.num_vertices() && referenced(p) {
            assert!(s.proxy_vertex(p).is_some(), "protected vertex {p} removed");
        }
    }
    s
}

#[test]
fn a_sphere_reaches_the_target_and_stays_a_closed_manifold_sphere() {
    let mesh = synth::icosphere(4, 1.0);
    let n = mesh.num_vertices();
    for target in [n * 4 / 5, n / 2, n / 4, n / 10] {
        let s = check(&mesh, target, &[]);
        assert_eq!(s.mesh.num_vertices(), target);
        assert_eq!(edge_kinds(&s.mesh).0, 0);
        assert_eq!(edge_kinds(&s.mesh).2, 0);
        assert_eq!(euler(&s.mesh), 2);
        // survivors stay on the sphere, and the density stays roughly uniform: every original
        // vertex is within a few proxy edge lengths of a survivor
        let edge =
            (4.0 * std::f64::consts::PI / s.mesh.num_faces() as f64 * 4.0 / 3f64.sqrt()).sqrt();
        for p in &mesh.positions {
            let nearest = s
                .mesh
                .positions
                .iter()
                .map(|q| (p - q).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < 2.0 * edge, "{nearest} vs edge {edge}");
        }
    }
}

#[test]
fn a_disc_keeps_its_boundary_and_topology() {
    let mesh = synth::height_field(40, 40, 0.1, |x, y| 0.3 * (x * 2.0).sin() * y.cos());
    let (b0, _, _) = edge_kinds(&mesh);
    let s = check(&mesh, mesh.num_vertices() / 3, &[]);
    let (b, _, more) = edge_kinds(&s.mesh);
    assert_eq!(more, 0);
    assert!(b > 0 && b <= b0);
    assert_eq!(euler(&s.mesh), 1);
}

#[test]
fn protected_vertices_survive_and_stop_the_decimation_when_they_are_all_that_is_left() {
    let mesh = synth::protrusion_sphere(4, 0.8, 0.25);
    let n = mesh.num_vertices() as VertexId;
    let protected: Vec<VertexId> = (0..n).step_by(7).collect();
    let s = check(&mesh, 10, &protected);
    // far below the target is impossible: at least the protected vertices remain
    assert!(s.mesh.num_vertices() >= protected.len());
    assert!(s.mesh.num_vertices() < n as usize / 2);
    assert_eq!(euler(&s.mesh), 2);
    // everything protected: nothing can go
    let all: Vec<VertexId> = (0..n).collect();
    let s = check(&mesh, 10, &all);
    assert_eq!(s.mesh, mesh);
    // ids that are not vertices are ignored
    check(&mesh, 100, &[n, n + 5, VertexId::MAX]);
}

#[test]
fn a_target_at_or_above_the_vertex_count_changes_nothing() {
    let mesh = synth::torus(1.0, 0.3, 24, 12);
    for target in [mesh.num_vertices(), mesh.num_vertices() + 10] {
        let s = check(&mesh, target, &[]);
        assert_eq!(s.mesh, mesh);
        assert_eq!(decimate(&mesh, target, &[]), mesh.faces);
    }
}

#[test]
fn unreferenced_vertices_are_dropped_and_not_counted() {
    let mut mesh = synth::icosphere(3, 1.0);
    let n = mesh.num_vertices();
    mesh.positions.push(Point3::new(5.0, 5.0, 5.0));
    let s = check(&mesh, n / 2, &[n as VertexId]);
    assert_eq!(s.mesh.num_vertices(), n / 2);
    assert_eq!(s.proxy_vertex(n as VertexId), None);
}

#[test]
fn simplification_is_deterministic() {
    let mesh = synth::textured_protrusion_sphere(4);
    let a = simplify(&mesh, 500, &[3, 50, 700]);
    let b = simplify(&mesh, 500, &[3, 50, 700]);
    assert_eq!(a, b);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn any_protected_set_survives_and_the_shape_stays_manifold(
        seed in any::<u64>(), keep in 0.05f64..0.9, every in 2usize..60
    ) {
        let mesh = synth::protrusion_sphere(3, 0.8, 0.25);
        let n = mesh.num_vertices();
        let offset = (seed % every as u64) as usize;
        let protected: Vec<VertexId> =
            (offset..n).step_by(every).map(|v| v as VertexId).collect();
        let target = ((keep * n as f64) as usize).max(4);
        let s = check(&mesh, target, &protected);
        prop_assert!(s.mesh.num_vertices() >= target.min(n));
        let (b, _, more) = edge_kinds(&s.mesh);
        prop_assert_eq!((b, more), (0, 0));
        prop_assert_eq!(euler(&s.mesh), 2);
    }
}

/// Vertices of huge valence (the apices of a double cone of 3000 sides) are the end of no
/// collapse, so every collapse's work stays bounded, while their neighbours still collapse
/// among themselves: the cone decimates to the target, apices kept, closed and manifold.
#[test]
fn vertices_of_huge_valence_stay_and_their_neighbours_collapse() {
    let mesh = synth::bicone(3000);
    let s = check(&mesh, 100, &[]);
    assert_eq!(s.mesh.num_vertices(), 100);
    assert!(s.proxy_vertex(3000).is_some() && s.proxy_vertex(3001).is_some());
    assert_eq!(euler(&s.mesh), 2);
}
