//! Prints a markdown table of fast-marching speed: single-source solve time and the K×K keypoint
//! matrix time (K = 1 % of the vertices) with 1 and 2 threads, on synthetic meshes and on the
//! shared real meshes when they can be read.
//!
//! `cargo bench -p keycomp-geodesic --bench geodesic_table`

use std::time::Instant;

use keycomp_geodesic::{GeodesicSolver, distance_matrix};
use keycomp_mesh::{Mesh, Topology, synth};
use keycomp_test_support::{bench_args, median, shared_data};

fn row(name: &str, mesh: &Mesh) -> Result<String, Box<dyn std::error::Error>> {
    let topo = Topology::new(mesh);
    let t = Instant::now();
    let solver = GeodesicSolver::new(mesh, &topo)?;
    let build_ms = t.elapsed().as_secs_f64() * 1e3;
    let n = mesh.num_vertices();
    let mut ws = solver.workspace();
    let solve_ms = median(
        (0..5)
            .map(|i| {
                let t = Instant::now();
                solver.solve((i * 7919 % n) as u32, &mut ws)?;
                Ok(t.elapsed().as_secs_f64() * 1e3)
            })
            .collect::<Result<Vec<_>, keycomp_geodesic::GeodesicError>>()?,
    );
    // K = 1 % of the vertices, spread evenly through the id range (deterministic)
    let k = (n / 100).max(2);
    let sources: Vec<u32> = (0..k).map(|i| (i * n / k) as u32).collect();
    let mut matrix_ms = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()?;
        let t = Instant::now();
        let m = pool.install(|| distance_matrix(&solver, &sources))?;
        matrix_ms.push(t.elapsed().as_secs_f64() * 1e3);
        assert_eq!(m.len(), k);
    }
    let o = solver.obtuse_stats();
    Ok(format!(
        "| {name} | {n} | {} | {} ({} split) | {build_ms:.1} | {solve_ms:.2} | {k} | {:.0} | {:.0} |",
        mesh.num_faces(),
        o.obtuse_corners,
        o.split,
        matrix_ms[0],
        matrix_ms[1]
    ))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    if bench_args("cargo bench -p keycomp-geodesic --bench geodesic_table").is_none() {
        return Ok(());
    }
    println!(
        "| mesh | vertices | faces | obtuse corners | build ms | solve ms (median of 5) | K | K×K ms, 1 thread | K×K ms, 2 threads |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    println!("{}", row("icosphere(6)", &synth::icosphere(6, 1.0))?);
    println!(
        "{}",
        row("torus 250×200", &synth::torus(2.0, 0.6, 250, 200))?
    );
    for file in [
        "models/nefertiti.obj",
        "models/armadillo.obj",
        "models/horse.ply",
        "kids/0001.null.0.off",
    ] {
        let Some(path) = shared_data(file) else {
            continue;
        };
        // reading may not be implemented yet in this build: skip rather than abort
        match std::panic::catch_unwind(|| keycomp_mesh::read_mesh(&path)) {
            Ok(Ok(loaded)) => println!("{}", row(file, &loaded.mesh)?),
            Ok(Err(e)) => eprintln!("skipping {file}: {e}"),
            Err(_) => eprintln!("skipping {file}: mesh reading is not available in this build"),
        }
    }
    Ok(())
}
