//! Criterion benches of fast marching: one full front, and a K×K keypoint matrix (K = 1 % of the
//! vertices), on `icosphere(6)` (40,962 vertices) and, when it can be read, the shared
//! `nefertiti.obj` (about 50k vertices).
//!
//! `cargo bench -p keycomp-geodesic`

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use keycomp_geodesic::{GeodesicSolver, distance_matrix};
use keycomp_mesh::{Mesh, Topology, synth};
use keycomp_test_support::shared_data;

fn meshes() -> Vec<(String, Mesh)> {
    let mut out = vec![("icosphere6".to_string(), synth::icosphere(6, 1.0))];
    if let Some(path) = shared_data("models/nefertiti.obj") {
        // reading may not be implemented in every build: skip rather than abort
        match std::panic::catch_unwind(|| keycomp_mesh::read_mesh(&path)) {
            Ok(Ok(loaded)) => out.push(("nefertiti".to_string(), loaded.mesh)),
            Ok(Err(e)) => eprintln!("skipping nefertiti: {e}"),
            Err(_) => eprintln!("skipping nefertiti: mesh reading is not available"),
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    for (name, mesh) in meshes() {
        let topo = Topology::new(&mesh);
        let Ok(solver) = GeodesicSolver::new(&mesh, &topo) else {
            eprintln!("skipping {name}: solver could not be built");
            continue;
        };
        let n = mesh.num_vertices();
        let mut group = c.benchmark_group(format!("geodesic/{name}"));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(2));

        group.throughput(Throughput::Elements(n as u64));
        let mut ws = solver.workspace();
        let mut source = 0u32;
        group.bench_function("single_source", |b| {
            b.iter(|| {
                source = (source + 7919) % n as u32;
                solver.solve(black_box(source), &mut ws).ok();
                black_box(ws.distance(0))
            })
        });

        let k = (n / 100).max(2);
        let sources: Vec<u32> = (0..k).map(|i| (i * n / k) as u32).collect();
        group.throughput(Throughput::Elements((k * k) as u64));
        group.bench_function(format!("matrix_{k}x{k}"), |b| {
            b.iter(|| distance_matrix(&solver, black_box(&sources)).map(|m| m.len()))
        });
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
