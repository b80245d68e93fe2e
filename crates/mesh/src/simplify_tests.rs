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
    check_cells(mesh, target, protected, 1)
}

/// [`check`] of [`simplify_in_cells`].
fn check_cells(mesh: &Mesh, target: usize, protected: &[VertexId], cells: usize) -> Simplified {
    let s = simplify_in_cells(mesh, &Topology::new(mesh), target, protected, cells);
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
    #![proptest_config(ProptestConfig::with_cases(48))]
    // in one pass (cells = 1) or in cells
    #[test]
    fn any_protected_set_survives_and_the_shape_stays_manifold(
        seed in any::<u64>(), keep in 0.05f64..0.9, every in 2usize..60, cells in 1usize..10
    ) {
        let mesh = synth::protrusion_sphere(3, 0.8, 0.25);
        let n = mesh.num_vertices();
        let offset = (seed % every as u64) as usize;
        let protected: Vec<VertexId> =
            (offset..n).step_by(every).map(|v| v as VertexId).collect();
        let target = ((keep * n as f64) as usize).max(4);
        let s = check_cells(&mesh, target, &protected, cells);
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

#[test]
fn one_cell_is_the_sequential_simplification() {
    let mesh = synth::textured_protrusion_sphere(4);
    assert_eq!(
        simplify_in_cells(&mesh, &Topology::new(&mesh), 700, &[3, 50], 1),
        simplify(&mesh, 700, &[3, 50])
    );
}

/// The cell of every vertex of `mesh` (all referenced) split into `cells`.
fn cells_of(mesh: &Mesh, cells: u32) -> Vec<u32> {
    let n = mesh.num_vertices();
    let topo = Topology::new(mesh);
    let mut cell = vec![cell_tag(0); n];
    let (mut seen, mut stamp) = (vec![0; n], 0);
    let ids = (0..n as VertexId).collect();
    bisect(&topo, ids, cells, 0, &mut cell, &mut seen, &mut stamp);
    cell
}

/// The bisection gives every cell its share of the vertices, and the cells of a long strip
/// are pieces along it.
#[test]
fn the_bisection_balances_the_cells() {
    let mesh = synth::icosphere(4, 1.0);
    let n = mesh.num_vertices();
    for cells in [2u32, 3, 4, 8] {
        let cell = cells_of(&mesh, cells);
        let mut count = vec![0usize; cells as usize];
        for &c in &cell {
            count[c as usize] += 1;
        }
        let share = n / cells as usize;
        assert!(
            count.iter().all(|&k| k.abs_diff(share) <= cells as usize),
            "{cells} cells: {count:?}"
        );
    }
    // two cells of a 60 × 6 strip: its two ends, meeting across about its width
    let mesh = synth::height_field(60, 6, 0.1, |_, _| 0.0);
    let cell = cells_of(&mesh, 2);
    let range = |c: u32| {
        mesh.positions
            .iter()
            .zip(&cell)
            .filter(|(_, k)| **k == c)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (p, _)| {
                (lo.min(p.x), hi.max(p.x))
            })
    };
    let (a, b) = (range(0), range(1));
    let overlap = a.1.min(b.1) - a.0.max(b.0);
    let length = a.1.max(b.1) - a.0.min(b.0);
    assert!(overlap < 0.15 * length, "{a:?} {b:?}");
}

/// The cells come from the connectivity: stretching and bending the mesh leaves them alone.
#[test]
fn the_cells_do_not_depend_on_the_embedding() {
    let mesh = synth::textured_protrusion_sphere(4);
    let mut bent = mesh.clone();
    for p in &mut bent.positions {
        *p = Point3::new(3.0 * p.x + p.y * p.y, p.y, p.z - 0.5 * p.x * p.x);
    }
    for cells in [2, 4, 8] {
        assert_eq!(cells_of(&mesh, cells), cells_of(&bent, cells));
    }
}

#[test]
fn cells_reach_the_target_and_keep_a_closed_manifold_sphere() {
    let mesh = synth::icosphere(5, 1.0);
    let n = mesh.num_vertices();
    for cells in [2, 4, 8] {
        for target in [n / 2, n / 8] {
            let s = check_cells(&mesh, target, &[], cells);
            assert_eq!(s.mesh.num_vertices(), target, "{cells} cells");
            let (b, _, more) = edge_kinds(&s.mesh);
            assert_eq!((b, more), (0, 0));
            assert_eq!(euler(&s.mesh), 2);
            // the seams are decimated too: no survivor is much closer to its nearest
            // survivor than the typical spacing (the input's spacing is ~sqrt(target / n) of it)
            let spacing = (4.0 * std::f64::consts::PI / target as f64).sqrt();
            let topo = Topology::new(&s.mesh);
            let mut short = 0;
            for v in 0..s.mesh.num_vertices() as VertexId {
                let p = s.mesh.positions[v as usize];
                let nearest = topo
                    .neighbors(v)
                    .iter()
                    .map(|&w| (s.mesh.positions[w as usize] - p).norm())
                    .fold(f64::INFINITY, f64::min);
                if nearest < 0.25 * spacing {
                    short += 1;
                }
            }
            assert!(
                short * 100 < target,
                "{cells} cells, {target}: {short} crowded"
            );
        }
    }
}

#[test]
fn cells_keep_a_disc_a_disc() {
    let mesh = synth::height_field(60, 60, 0.1, |x, y| 0.3 * (x * 2.0).sin() * y.cos());
    for cells in [2, 4, 16] {
        let s = check_cells(&mesh, mesh.num_vertices() / 4, &[], cells);
        let (b, _, more) = edge_kinds(&s.mesh);
        assert_eq!(more, 0);
        assert!(b > 0);
        assert_eq!(euler(&s.mesh), 1);
    }
}

/// The cells are a function of the mesh: one thread and three give the same proxy.
#[test]
fn cells_do_not_depend_on_the_number_of_threads() {
    let mesh = synth::textured_protrusion_sphere(5);
    let protected = [3, 50, 700, 5000];
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| simplify_in_cells(&mesh, &Topology::new(&mesh), 2000, &protected, 4))
    };
    let one = run(1);
    assert_eq!(one, run(3));
    assert_eq!(one.mesh.num_vertices(), 2000);
    assert_ne!(one, simplify(&mesh, 2000, &protected));
}
