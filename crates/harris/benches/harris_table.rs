//! Prints a markdown table of Harris 3D timings on the shared meshes (and a synthetic
//! icosphere): reading time, response + selection with 1 and 2 threads, vertices per second.
//! Median of 5 runs each.
//!
//! `cargo bench -p keycomp-harris --bench harris_table` (no arguments; run without cargo's
//! `--bench` flag, as `cargo test --all-targets` does, it measures nothing)

use std::time::Instant;

use keycomp_harris::{HarrisParams, detect};
use keycomp_mesh::{Mesh, Topology, read_mesh, synth};
use keycomp_test_support::{median, shared_data};

const RUNS: usize = 5;

/// The median wall time of `RUNS` calls of `f`, in milliseconds.
fn median_ms(mut f: impl FnMut()) -> f64 {
    median(
        (0..RUNS)
            .map(|_| {
                let s = Instant::now();
                f();
                s.elapsed().as_secs_f64() * 1e3
            })
            .collect(),
    )
}

fn harris_ms(mesh: &Mesh, threads: usize) -> Result<f64, Box<dyn std::error::Error>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let topo = Topology::new(mesh);
    let params = HarrisParams::default();
    let mut err = None;
    let ms = pool.install(|| {
        median_ms(|| {
            if let Err(e) = detect(mesh, &topo, &params) {
                err = Some(e);
            }
        })
    });
    match err {
        Some(e) => Err(e.into()),
        None => Ok(ms),
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    if keycomp_test_support::bench_args("cargo bench -p keycomp-harris --bench harris_table")
        .is_none()
    {
        return Ok(());
    }
    println!(
        "| mesh | vertices | read ms | harris ms (1 thread) | harris ms (2 threads) | vertices/s (2 threads) |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    let mut rows: Vec<(String, Mesh, Option<f64>)> = vec![(
        "icosphere(6) (synthetic)".into(),
        synth::icosphere(6, 1.0),
        None,
    )];
    for name in ["nefertiti.obj", "horse.ply", "igea.ply"] {
        let Some(p) = shared_data(format!("models/{name}")) else {
            continue;
        };
        let mut mesh = None;
        let mut err = None;
        let read = median_ms(|| match read_mesh(&p) {
            Ok(m) => mesh = Some(m.mesh),
            Err(e) => err = Some(e),
        });
        if let Some(e) = err {
            return Err(e.into());
        }
        if let Some(m) = mesh {
            rows.push((name.to_string(), m, Some(read)));
        }
    }
    for (name, mesh, read) in rows {
        let one = harris_ms(&mesh, 1)?;
        let two = harris_ms(&mesh, 2)?;
        let n = mesh.num_vertices();
        println!(
            "| {name} | {n} | {} | {one:.1} | {two:.1} | {:.2} M |",
            read.map_or("–".to_string(), |r| format!("{r:.1}")),
            n as f64 / (two / 1e3) / 1e6
        );
    }
    Ok(())
}
