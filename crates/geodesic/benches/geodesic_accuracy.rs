//! Prints the mean relative error of fast marching against great circles on `icosphere(6)` with
//! its vertices jittered by ±0, 0.2, 0.4, 0.8 mean edge lengths and projected back to the
//! sphere, without splitting obtuse corners and splitting those above each given angle.
//!
//! `cargo bench -p keycomp-geodesic --bench geodesic_accuracy -- [angle...]`

use keycomp_geodesic::{GeodesicParams, GeodesicSolver};
use keycomp_mesh::{Mesh, Topology, synth};
use keycomp_test_support::bench_args;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn jittered(level: u32, amount: f64, seed: u64) -> Mesh {
    let mut mesh = synth::icosphere(level, 1.0);
    let mut sum = 0.0;
    let mut c = 0;
    for f in &mesh.faces {
        for i in 0..3 {
            sum += (mesh.positions[f[i] as usize] - mesh.positions[f[(i + 1) % 3] as usize]).norm();
            c += 1;
        }
    }
    let edge = sum / c as f64;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    if amount == 0.0 {
        return mesh;
    }
    for p in &mut mesh.positions {
        let j = keycomp_mesh::Vector3::new(
            rng.random_range(-amount..amount),
            rng.random_range(-amount..amount),
            rng.random_range(-amount..amount),
        ) * edge;
        *p = keycomp_mesh::Point3::from((p.coords + j).normalize());
    }
    mesh
}

fn error(mesh: &Mesh, angle: f64, steps: usize) -> (f64, usize, usize) {
    let topo = Topology::new(mesh);
    let solver = GeodesicSolver::with_params(
        mesh,
        &topo,
        GeodesicParams {
            max_unfold_steps: steps,
            min_split_angle_degrees: angle,
            ..GeodesicParams::default()
        },
    )
    .expect("solver");
    let mut ws = solver.workspace();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut total = 0.0;
    let m = 6;
    for _ in 0..m {
        let s = rng.random_range(0..mesh.num_vertices() as u32);
        solver.solve(s, &mut ws).expect("solve");
        let ps = mesh.positions[s as usize].coords;
        let mut sum = 0.0;
        let mut c = 0;
        for (v, p) in mesh.positions.iter().enumerate() {
            let e = p.coords.dot(&ps).clamp(-1.0, 1.0).acos();
            if e > 0.1 {
                sum += (ws.distance(v as u32) - e).abs() / e;
                c += 1;
            }
        }
        total += sum / c as f64 / m as f64;
    }
    let o = solver.obtuse_stats();
    (total, o.obtuse_corners, o.split)
}

fn main() {
    let Some(args) = bench_args("cargo bench -p keycomp-geodesic --bench geodesic_accuracy") else {
        return;
    };
    let angles: Vec<f64> = args
        .iter()
        .skip(1)
        .map(|a| a.parse().expect("angle"))
        .collect();
    let angles = if angles.is_empty() {
        vec![90.0, 100.0, 110.0, 120.0]
    } else {
        angles
    };
    for amount in [0.0, 0.2, 0.4, 0.8] {
        let mesh = jittered(6, amount, 5);
        let mut line = format!("jitter ±{amount} edge:");
        let (e0, obt, _) = error(&mesh, 90.0, 0);
        line += &format!(" obtuse {obt}, no split {:.3} %;", 100.0 * e0);
        for &a in &angles {
            let (e, _, split) = error(&mesh, a, 8);
            line += &format!(" ≥{a}°: {:.3} % ({split} split);", 100.0 * e);
        }
        println!("{line}");
    }
}
