//! Invariants of fast marching on random meshes (proptest): distances are ≥ 0, 0 at the source,
//! never above Dijkstra on the edges, symmetric and satisfying the triangle inequality up to 3 %
//! of the largest distance plus half the longest edge (the scheme is first-order accurate); early termination and the matrix agree with full fronts; the bucket queues agree
//! with the heap.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use keycomp_geodesic::{GeodesicParams, GeodesicSolver, QueueKind, distance_matrix};
use keycomp_mesh::{Mesh, Point3, Topology, synth};
use keycomp_test_support::edge_path_distances;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A bumpy, irregular closed surface: an icosphere with random radial noise and tangential
/// jitter (so triangles of all shapes, obtuse ones included).
fn random_blob(seed: u64, subdivisions: u32) -> Mesh {
    let mut m = synth::icosphere(subdivisions, 1.0);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let h = 1.0 / (subdivisions as f64 + 1.0).exp2();
    for p in &mut m.positions {
        let r = 1.0 + rng.random_range(-0.15..0.15);
        let j = Point3::new(
            rng.random_range(-0.3..0.3) * h,
            rng.random_range(-0.3..0.3) * h,
            rng.random_range(-0.3..0.3) * h,
        );
        *p = Point3::from((p.coords + j.coords) * r);
    }
    m
}

/// A random open height field (boundaries).
fn random_terrain(seed: u64) -> Mesh {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (a, b, c) = (
        rng.random_range(0.5..3.0),
        rng.random_range(0.5..3.0),
        rng.random_range(0.0..0.3),
    );
    let mut m = synth::height_field(24, 18, 0.1, |x, y| c * (a * x).sin() * (b * y).cos());
    for p in &mut m.positions {
        p.x += rng.random_range(-0.03..0.03);
        p.y += rng.random_range(-0.03..0.03);
    }
    m
}

fn check_mesh(mesh: &Mesh, picks: &[usize]) -> Result<(), TestCaseError> {
    let topo = Topology::new(mesh);
    let solver = GeodesicSolver::new(mesh, &topo).unwrap();
    let n = mesh.num_vertices();
    let ids: Vec<u32> = picks.iter().map(|&i| (i % n) as u32).collect();
    let fields: Vec<Vec<f64>> = ids
        .iter()
        .map(|&s| solver.distance_field(s).unwrap())
        .collect();
    let scale = fields[0].iter().cloned().fold(0.0, f64::max);
    // fast marching is first-order accurate: on a coarse, jittered open surface the fronts
    // from a and from b can disagree by a fraction of an edge beyond the relative slack
    // (seed 936200 of the terrains: 0.057 on a distance of 0.6, 3.0 % of the scale, with
    // edges up to 0.2 long)
    let longest_edge = mesh
        .faces
        .iter()
        .flat_map(|f| (0..3).map(move |k| (f[k], f[(k + 1) % 3])))
        .map(|(u, v)| (mesh.positions[u as usize] - mesh.positions[v as usize]).norm())
        .fold(0.0, f64::max);
    let slack = 0.03 * scale + 0.5 * longest_edge;
    for (f, &s) in fields.iter().zip(&ids) {
        prop_assert_eq!(f[s as usize], 0.0);
        prop_assert!(f.iter().all(|d| *d >= 0.0 && d.is_finite()));
        let dij = edge_path_distances(&mesh.positions, &mesh.faces, &[s]);
        for (a, b) in f.iter().zip(&dij) {
            // never above the edge-graph distance (f32 edge lengths: 1e-6 relative slack)
            prop_assert!(*a <= b * (1.0 + 1e-6) + 1e-12, "{a} > dijkstra {b}");
        }
    }
    for i in 0..ids.len() {
        for j in 0..ids.len() {
            let (a, b) = (fields[i][ids[j] as usize], fields[j][ids[i] as usize]);
            prop_assert!(
                (a - b).abs() <= slack,
                "asymmetry {a} vs {b} (scale {scale}, longest edge {longest_edge})"
            );
            for k in 0..ids.len() {
                let via = fields[i][ids[j] as usize] + fields[j][ids[k] as usize];
                prop_assert!(fields[i][ids[k] as usize] <= via + slack);
            }
        }
    }
    // the matrix: symmetric, zero diagonal, averages the two fronts
    let m = distance_matrix(&solver, &ids).unwrap();
    prop_assert_eq!(m.disconnected_pairs(), 0);
    for i in 0..ids.len() {
        prop_assert_eq!(m.get(i, i), 0.0);
        for j in 0..ids.len() {
            prop_assert_eq!(m.get(i, j), m.get(j, i));
            if ids[i] != ids[j] {
                let avg = 0.5 * (fields[i][ids[j] as usize] + fields[j][ids[i] as usize]);
                prop_assert!((m.get(i, j) - avg).abs() <= 1e-12 * scale.max(1.0));
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn invariants_on_random_blobs(seed in 0u64..1_000_000, picks in proptest::collection::vec(0usize..100_000, 2..6)) {
        check_mesh(&random_blob(seed, 3), &picks)?;
    }

    #[test]
    fn invariants_on_random_terrains(seed in 0u64..1_000_000, picks in proptest::collection::vec(0usize..100_000, 2..6)) {
        check_mesh(&random_terrain(seed), &picks)?;
    }
}

#[test]
fn early_termination_gives_the_same_target_distances() {
    let mesh = random_blob(11, 4);
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let targets = [17u32, 400, 1234, 2000];
    let full = solver.distance_field(5).unwrap();
    let mut ws = solver.workspace();
    solver.solve_until(5, &targets, &mut ws).unwrap();
    for &t in &targets {
        assert_eq!(ws.distance(t), full[t as usize]);
    }
    // it stopped early: some vertex is unreached, and every reached one is exact
    assert!(ws.distances().iter().any(|d| d.is_infinite()));
    for (a, b) in ws.distances().iter().zip(&full) {
        assert!(a.is_infinite() || a == b);
    }
    // the workspace is clean for the next, full front
    solver.solve(5, &mut ws).unwrap();
    assert_eq!(ws.distances(), &full[..]);
}

#[test]
fn a_front_within_a_radius_is_exact_inside_and_unreached_outside() {
    let mesh = random_blob(12, 4);
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let full = solver.distance_field(7).unwrap();
    let far = full.iter().copied().fold(0.0, f64::max);
    let mut ws = solver.workspace();
    for radius in [0.0, 0.3, 1.0, 0.5 * far] {
        let complete = solver.solve_within(7, radius, &mut ws).unwrap();
        assert!(!complete, "radius {radius} is inside the piece");
        for (a, b) in ws.distances().iter().zip(&full) {
            if *b <= radius {
                assert_eq!(a, b);
            } else {
                assert!(a.is_infinite(), "{a} beyond {radius}");
            }
        }
        // fewer vertices touched than a full front would
        assert!(ws.reached().len() < full.len());
    }
    // a radius beyond the farthest vertex, +∞ and NaN run the whole piece
    for radius in [2.0 * far, f64::INFINITY, f64::NAN] {
        assert!(solver.solve_within(7, radius, &mut ws).unwrap());
        assert_eq!(ws.distances(), &full[..]);
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let mesh = random_blob(5, 3);
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let ids: Vec<u32> = (0..40).map(|i| i * 13).collect();
    let run = |t: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| distance_matrix(&solver, &ids).unwrap())
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn out_of_range_ids_are_errors_not_panics() {
    let mesh = synth::icosphere(1, 1.0);
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    assert!(solver.distance_field(10_000).is_err());
    assert!(distance_matrix(&solver, &[0, 99_999]).is_err());
    let mut ws = solver.workspace();
    assert!(solver.solve_until(0, &[1, 10_000], &mut ws).is_err());
    let other = Topology::new(&synth::icosphere(2, 1.0));
    assert!(GeodesicSolver::new(&mesh, &other).is_err());
    let bad = Mesh {
        positions: mesh.positions.clone(),
        faces: vec![[0, 1, 500]],
    };
    assert!(
        GeodesicSolver::new(
            &bad,
            &Topology::new(&Mesh {
                positions: mesh.positions.clone(),
                faces: vec![]
            })
        )
        .is_err()
    );
}

#[test]
fn non_manifold_fan_and_empty_matrix() {
    // three triangles sharing edge 0–1 (non-manifold), plus an obtuse one
    let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
    let mesh = Mesh {
        positions: vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(0.5, 1.0, 0.0),
            p(0.5, -1.0, 0.0),
            p(0.5, 0.0, 1.0),
            p(0.5, 0.1, 0.0),
        ],
        faces: vec![[0, 1, 2], [1, 0, 3], [0, 1, 4], [0, 5, 1]],
    };
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let d = solver.distance_field(2).unwrap();
    assert!(d.iter().all(|x| x.is_finite() && *x >= 0.0));
    assert!((d[4] - (d[0].min(d[1]) + 0.5f64.hypot(1.0)).min(d[0] + 1.5f64.sqrt())).abs() < 1.0);
    let m = distance_matrix(&solver, &[]).unwrap();
    assert!(m.is_empty());
}

/// Distance fields from `sources` with the given queue (full fronts, then a K×K matrix).
fn fields(mesh: &Mesh, queue: QueueKind, sources: &[u32]) -> (Vec<Vec<f64>>, Vec<f64>) {
    let topo = Topology::new(mesh);
    let params = GeodesicParams {
        queue,
        ..GeodesicParams::default()
    };
    let solver = GeodesicSolver::with_params(mesh, &topo, params).unwrap();
    let mut ws = solver.workspace();
    let full = sources
        .iter()
        .map(|&s| {
            solver.solve(s, &mut ws).unwrap();
            ws.distances().to_vec()
        })
        .collect();
    (full, distance_matrix(&solver, sources).unwrap().into_vec())
}

fn meshes_for_queues() -> Vec<Mesh> {
    let mut sheared = synth::grid(30, 30, 1.0 / 30.0);
    for p in &mut sheared.positions {
        p.x += 1.7 * p.y;
    }
    vec![
        synth::icosphere(4, 1.0), // many exact ties
        sheared,                  // obtuse corners split, ties
        random_blob(3, 4),
        random_terrain(8), // boundaries
    ]
}

#[test]
fn exact_bucket_queue_gives_the_heap_distances() {
    for mesh in meshes_for_queues() {
        let sources: Vec<u32> = (0..6)
            .map(|i| i * 97 % mesh.num_vertices() as u32)
            .collect();
        let heap = fields(&mesh, QueueKind::Heap, &sources);
        let buckets = fields(&mesh, QueueKind::Buckets, &sources);
        assert_eq!(heap, buckets);
    }
}

#[test]
fn untidy_bucket_queue_stays_close_to_the_heap() {
    for mesh in meshes_for_queues() {
        let sources: Vec<u32> = (0..6)
            .map(|i| i * 97 % mesh.num_vertices() as u32)
            .collect();
        let (heap, _) = fields(&mesh, QueueKind::Heap, &sources);
        let (untidy, _) = fields(&mesh, QueueKind::Untidy { width: 0.1 }, &sources);
        let (mut sum, mut count, mut max) = (0.0, 0, 0.0f64);
        for (a, b) in heap.iter().flatten().zip(untidy.iter().flatten()) {
            assert_eq!(a.is_finite(), b.is_finite());
            if *a > 0.0 && a.is_finite() {
                let r = (a - b).abs() / a;
                sum += r;
                max = max.max(r);
                count += 1;
            }
        }
        let mean = sum / count as f64;
        assert!(mean < 1e-3 && max < 0.05, "mean {mean}, max {max}");
    }
}
