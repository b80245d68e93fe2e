//! Oracle tests: fast marching against exact distances (great circles on a sphere, straight
//! lines in the plane), against Dijkstra on the edges, and on meshes with obtuse triangles,
//! boundaries, several pieces and unreferenced vertices.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use keycomp_geodesic::{GeodesicParams, GeodesicSolver, distance_matrix};
use keycomp_mesh::{Mesh, Point3, Topology, synth};
use keycomp_test_support::edge_path_distances;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Mean relative error of `d` against `exact` over vertices with exact distance > `min`.
fn mean_rel(d: &[f64], exact: &[f64], min: f64) -> (f64, f64) {
    let mut sum = 0.0;
    let mut max = 0.0f64;
    let mut count = 0;
    for (a, e) in d.iter().zip(exact) {
        if *e > min {
            let r = (a - e).abs() / e;
            sum += r;
            max = max.max(r);
            count += 1;
        }
    }
    assert!(count > 0);
    (sum / count as f64, max)
}

#[test]
fn sphere_great_circles() {
    let mesh = synth::icosphere(6, 1.0);
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    assert_eq!(solver.obtuse_stats().obtuse_corners, 0);
    let mut ws = solver.workspace();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let (mut fmm, mut dij, mut fmm_max) = (0.0, 0.0, 0.0f64);
    let sources: Vec<u32> = (0..5)
        .map(|_| rng.random_range(0..mesh.num_vertices() as u32))
        .collect();
    for &s in &sources {
        solver.solve(s, &mut ws).unwrap();
        let ps = mesh.positions[s as usize].coords.normalize();
        let exact: Vec<f64> = mesh
            .positions
            .iter()
            .map(|p| p.coords.normalize().dot(&ps).clamp(-1.0, 1.0).acos())
            .collect();
        assert_eq!(ws.distance(s), 0.0);
        let (m, mx) = mean_rel(ws.distances(), &exact, 0.1);
        fmm += m / sources.len() as f64;
        fmm_max = fmm_max.max(mx);
        // plain Dijkstra on the edge graph: the baseline fast marching must beat
        let dijkstra = edge_path_distances(&mesh.positions, &mesh.faces, &[s]);
        dij += mean_rel(&dijkstra, &exact, 0.1).0 / sources.len() as f64;
    }
    println!(
        "icosphere(6): mean relative error FMM {:.4} % (max {:.3} %), Dijkstra {:.3} %",
        100.0 * fmm,
        100.0 * fmm_max,
        100.0 * dij
    );
    assert!(fmm < 0.01, "FMM mean relative error {fmm}");
    assert!(fmm < dij / 4.0, "FMM {fmm} vs Dijkstra {dij}");
}

/// A flat grid whose vertices are mapped by `f`, with the straight-line oracle.
fn planar_error(mesh: &Mesh, params: GeodesicParams, sources: &[u32]) -> (f64, f64, usize) {
    let topo = Topology::new(mesh);
    let solver = GeodesicSolver::with_params(mesh, &topo, params).unwrap();
    let mut ws = solver.workspace();
    let diag = solver.diagonal();
    let mut sum = 0.0;
    let mut max = 0.0f64;
    for &s in sources {
        solver.solve(s, &mut ws).unwrap();
        let exact: Vec<f64> = mesh
            .positions
            .iter()
            .map(|p| (p - mesh.positions[s as usize]).norm())
            .collect();
        let (m, mx) = mean_rel(ws.distances(), &exact, 0.1 * diag);
        sum += m / sources.len() as f64;
        max = max.max(mx);
    }
    (sum, max, solver.obtuse_stats().obtuse_corners)
}

#[test]
fn flat_grid_gives_euclidean_distances() {
    let mesh = synth::grid(80, 80, 1.0 / 80.0);
    let (mean, max, obtuse) = planar_error(&mesh, GeodesicParams::default(), &[0, 3240, 6560]);
    println!(
        "flat grid 80×80: mean relative error {:.4} %, max {:.3} %",
        100.0 * mean,
        100.0 * max
    );
    assert_eq!(obtuse, 0);
    assert!(mean < 0.01, "{mean}");
    // along the axes and the diagonals of the alternating triangulation it is exact
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let d = solver.distance_field(0).unwrap();
    assert!((d[80] - 1.0).abs() < 1e-6, "{}", d[80]); // f32 edge lengths
}

/// A sheared grid (every cell a parallelogram with a 150° angle) and a randomly jittered grid:
/// both full of obtuse triangles. Unfolding must keep the error small and beat the fallback.
#[test]
fn obtuse_triangles_stay_accurate() {
    let shear = 1.7;
    let mut sheared = synth::grid(60, 60, 1.0 / 60.0);
    for p in &mut sheared.positions {
        p.x += shear * p.y;
    }
    let mut jittered = synth::grid(60, 60, 1.0 / 60.0);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for p in &mut jittered.positions {
        p.x += rng.random_range(-0.35..0.35) / 60.0;
        p.y += rng.random_range(-0.35..0.35) / 60.0;
    }
    let sources = [0u32, 1830, 3720];
    for (name, mesh) in [("sheared", &sheared), ("jittered", &jittered)] {
        let (with, with_max, obtuse) = planar_error(mesh, GeodesicParams::default(), &sources);
        let (without, without_max, _) = planar_error(
            mesh,
            GeodesicParams {
                max_unfold_steps: 0,
                ..GeodesicParams::default()
            },
            &sources,
        );
        println!(
            "{name} grid ({obtuse} obtuse corners): mean relative error with unfolding {:.4} % \
             (max {:.3} %), fallback only {:.4} % (max {:.3} %)",
            100.0 * with,
            100.0 * with_max,
            100.0 * without,
            100.0 * without_max
        );
        assert!(obtuse > 1000);
        assert!(with < 0.01, "{name}: {with}");
        assert!(with <= without, "{name}: {with} vs {without}");
    }
}

#[test]
fn disconnected_pieces_get_a_finite_fill() {
    let a = synth::icosphere(3, 1.0);
    let mut mesh = a.clone();
    let off = a.num_vertices() as u32;
    mesh.positions
        .extend(a.positions.iter().map(|p| p + nalgebra_offset()));
    mesh.faces
        .extend(a.faces.iter().map(|f| f.map(|v| v + off)));
    // an unreferenced vertex too
    mesh.positions.push(Point3::new(9.0, 9.0, 9.0));
    let lone = mesh.num_vertices() as u32 - 1;
    let topo = Topology::new(&mesh);
    let solver = GeodesicSolver::new(&mesh, &topo).unwrap();
    let sources = [0, 5, off, off + 7, lone];
    let m = distance_matrix(&solver, &sources).unwrap();
    assert!(m.as_slice().iter().all(|d| d.is_finite() && *d >= 0.0));
    // pairs across pieces: {0,5}×{off,off+7} = 4, and the lone vertex with the other 4
    assert_eq!(m.disconnected_pairs(), 8);
    assert!(m.is_disconnected(0, 2) && !m.is_disconnected(0, 1) && !m.is_disconnected(4, 4));
    let largest = (0..5)
        .flat_map(|i| (0..5).map(move |j| (i, j)))
        .filter(|&(i, j)| !m.is_disconnected(i, j))
        .map(|(i, j)| m.get(i, j))
        .fold(0.0, f64::max);
    assert_eq!(m.fill_value(), 2.0 * largest);
    assert_eq!(m.get(0, 2), m.fill_value());
    for i in 0..5 {
        assert_eq!(m.get(i, i), 0.0);
    }
    // the lone vertex's own field: 0 at itself, ∞ elsewhere
    let d = solver.distance_field(lone).unwrap();
    assert_eq!(d[lone as usize], 0.0);
    assert!(d[0].is_infinite());
}

fn nalgebra_offset() -> keycomp_mesh::Vector3<f64> {
    keycomp_mesh::Vector3::new(5.0, 0.0, 0.0)
}
