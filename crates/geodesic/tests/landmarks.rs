//! Landmark fronts (`landmark_distance_matrix`) against full fronts (`distance_matrix`): the
//! same matrix when every source is a landmark, great circles on a sphere as an oracle, pieces
//! without a landmark, bad landmark lists, and thread-count independence.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use keycomp_geodesic::{
    GeodesicError, GeodesicSolver, ShortRadius, distance_matrix, landmark_distance_matrix,
};
use keycomp_mesh::{Mesh, Point3, Topology, synth};
use proptest::prelude::*;

/// Every `step`-th vertex of `mesh`.
fn every(mesh: &Mesh, step: usize) -> Vec<u32> {
    (0..mesh.num_vertices() as u32).step_by(step).collect()
}

/// Landmarks at every `step`-th position of `k` sources.
fn spread(k: usize, step: usize) -> Vec<usize> {
    (0..k).step_by(step).collect()
}

#[test]
fn every_source_a_landmark_is_the_full_matrix() {
    let mesh = synth::icosphere(3, 1.0);
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let sources = every(&mesh, 7);
    let all: Vec<usize> = (0..sources.len()).collect();
    let (m, stats) =
        landmark_distance_matrix(&solver, &sources, &all, ShortRadius::Covering(2.0)).unwrap();
    assert_eq!(m, distance_matrix(&solver, &sources).unwrap());
    assert_eq!(stats.full_fronts, sources.len());
    assert_eq!(stats.short_fronts, 0);
    assert_eq!(stats.estimated_pairs, 0);
}

#[test]
fn a_sphere_keeps_its_great_circles() {
    // unit sphere, 1 % of the vertices as sources, 1 in 5 of them landmarks
    let mesh = synth::icosphere(5, 1.0);
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let sources = every(&mesh, 97);
    let k = sources.len();
    let landmarks = spread(k, 5);
    let (m, stats) =
        landmark_distance_matrix(&solver, &sources, &landmarks, ShortRadius::Covering(2.0))
            .unwrap();
    let full = distance_matrix(&solver, &sources).unwrap();
    let great = |i: usize, j: usize| {
        let (p, q) = (
            mesh.positions[sources[i] as usize].coords.normalize(),
            mesh.positions[sources[j] as usize].coords.normalize(),
        );
        p.dot(&q).clamp(-1.0, 1.0).acos()
    };
    let (mut err_l, mut err_f, mut n) = (0.0, 0.0, 0);
    for i in 0..k {
        for j in i + 1..k {
            let g = great(i, j);
            err_l += (m.get(i, j) - g).abs() / g;
            err_f += (full.get(i, j) - g).abs() / g;
            n += 1;
            // a path through a landmark is never much shorter than the front's distance
            assert!(m.get(i, j) >= full.get(i, j) * 0.99 - 1e-9, "({i}, {j})");
        }
    }
    let (err_l, err_f) = (err_l / n as f64, err_f / n as f64);
    assert!(err_f < 0.01, "full fronts: {err_f}");
    // the estimated pairs (a fifth of them here) add at most 0.6 percentage points
    assert!(
        err_l < err_f + 0.006,
        "landmarks: {err_l} (full fronts {err_f})"
    );
    assert_eq!(stats.full_fronts, landmarks.len());
    assert_eq!(stats.short_fronts, k - landmarks.len());
    assert!(stats.estimated_pairs > 0 && stats.estimated_pairs < k * (k - 1) / 2);
    assert!(stats.covering_radius > 0.0 && stats.radius == 2.0 * stats.covering_radius);
}

#[test]
fn local_radii_estimate_more_pairs_within_the_same_bound() {
    let mesh = synth::icosphere(5, 1.0);
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let sources = every(&mesh, 97);
    let k = sources.len();
    let landmarks = spread(k, 5);
    let full = distance_matrix(&solver, &sources).unwrap();
    let (covering, cs) =
        landmark_distance_matrix(&solver, &sources, &landmarks, ShortRadius::Covering(2.0))
            .unwrap();
    let (local, ls) =
        landmark_distance_matrix(&solver, &sources, &landmarks, ShortRadius::Local(2.0)).unwrap();
    assert_eq!(ls.covering_radius, cs.covering_radius);
    assert!(ls.radius <= cs.radius, "{} > {}", ls.radius, cs.radius);
    assert!(ls.estimated_pairs >= cs.estimated_pairs);
    let mean_error = |m: &keycomp_geodesic::DistanceMatrix| {
        let (mut sum, mut n) = (0.0, 0);
        for i in 0..k {
            for j in i + 1..k {
                let f = full.get(i, j);
                // the estimate through a landmark is within 2·min(h_i, h_j) of the fronts'
                assert!(m.get(i, j) <= f + 2.0 * cs.covering_radius + 1e-9);
                sum += (m.get(i, j) - f).abs() / f;
                n += 1;
            }
        }
        sum / n as f64
    };
    // 1.1 % against 0.4 % here, where every fifth source in index order is a landmark
    let (e_cov, e_loc) = (mean_error(&covering), mean_error(&local));
    assert!(e_loc < e_cov + 0.01, "local {e_loc}, covering {e_cov}");
    // the same matrix on any number of threads
    let on_one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| {
            landmark_distance_matrix(&solver, &sources, &landmarks, ShortRadius::Local(2.0))
        })
        .unwrap();
    assert_eq!(on_one.0, local);
}

/// Two spheres far apart.
fn two_spheres() -> Mesh {
    let a = synth::icosphere(3, 1.0);
    let mut b = synth::icosphere(2, 0.5);
    for p in &mut b.positions {
        *p = Point3::new(p.x + 10.0, p.y, p.z);
    }
    let offset = a.num_vertices() as u32;
    let mut mesh = a;
    mesh.positions.extend(b.positions);
    mesh.faces.extend(
        b.faces
            .iter()
            .map(|f| [f[0] + offset, f[1] + offset, f[2] + offset]),
    );
    mesh
}

#[test]
fn a_piece_without_a_landmark_gets_full_fronts() {
    let mesh = two_spheres();
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let sources = every(&mesh, 11);
    let k = sources.len();
    let on_small: Vec<usize> = (0..k).filter(|&i| sources[i] >= 642).collect();
    assert!(on_small.len() >= 3);
    // landmarks only on the big sphere
    let landmarks: Vec<usize> = (0..k).filter(|&i| sources[i] < 642).step_by(4).collect();
    let (m, stats) =
        landmark_distance_matrix(&solver, &sources, &landmarks, ShortRadius::Covering(1.0))
            .unwrap();
    let full = distance_matrix(&solver, &sources).unwrap();
    assert_eq!(stats.full_fronts, landmarks.len() + on_small.len());
    assert_eq!(m.disconnected_pairs(), full.disconnected_pairs());
    for &i in &on_small {
        for &j in &on_small {
            assert_eq!(
                m.get(i, j),
                full.get(i, j),
                "({i}, {j}) on the small sphere"
            );
        }
        assert!(m.is_disconnected(i, 0));
    }
}

#[test]
fn bad_landmarks_are_errors() {
    let mesh = synth::icosphere(2, 1.0);
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let sources = every(&mesh, 10);
    let k = sources.len();
    for bad in [vec![0, k], vec![3, 1, 3]] {
        assert!(matches!(
            landmark_distance_matrix(&solver, &sources, &bad, ShortRadius::Covering(2.0)),
            Err(GeodesicError::BadLandmark { .. })
        ));
    }
    assert!(
        landmark_distance_matrix(&solver, &[0, 99_999], &[0], ShortRadius::Covering(2.0)).is_err()
    );
    let (m, _) = landmark_distance_matrix(&solver, &[], &[], ShortRadius::Covering(2.0)).unwrap();
    assert!(m.is_empty());
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let mesh = synth::icosphere(4, 1.0);
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let sources = every(&mesh, 23);
    let landmarks = spread(sources.len(), 6);
    let run = |t: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .unwrap()
            .install(|| {
                landmark_distance_matrix(&solver, &sources, &landmarks, ShortRadius::Covering(2.0))
                    .unwrap()
            })
    };
    assert_eq!(run(1), run(3));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// On a bumpy grid: symmetric, zero diagonal, finite, every landmark's row exact up to the
    /// symmetrisation, and no estimate below the shorter of the two fronts' distances by more
    /// than the discretisation allows.
    #[test]
    fn landmark_matrices_are_distance_matrices(step in 2usize..9, factor in 0.5f64..4.0) {
        let mut mesh = synth::grid(20, 16, 0.05);
        for (i, p) in mesh.positions.iter_mut().enumerate() {
            p.z = 0.05 * ((i % 7) as f64).sin();
        }
        let topo = Topology::new(&mesh);
        let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
        let sources = every(&mesh, 5);
        let k = sources.len();
        let landmarks = spread(k, step);
        let (m, _) = landmark_distance_matrix(&solver, &sources, &landmarks, ShortRadius::Covering(factor)).unwrap();
        let full = distance_matrix(&solver, &sources).unwrap();
        for i in 0..k {
            prop_assert_eq!(m.get(i, i), 0.0);
            for j in 0..k {
                let d = m.get(i, j);
                prop_assert!(d.is_finite() && d >= 0.0);
                prop_assert_eq!(d, m.get(j, i));
                prop_assert!(d >= full.get(i, j) * 0.98 - 1e-9, "({}, {}): {} < {}", i, j, d, full.get(i, j));
            }
        }
    }
}
