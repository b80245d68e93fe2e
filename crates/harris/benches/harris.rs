//! Criterion benches of Harris 3D (response + selection, `detect`) on a synthetic icosphere(6)
//! and, when `../shared/data/models` is present, on nefertiti.obj, horse.ply (~50k vertices)
//! and igea.ply (134k); plus the reading time of those files.
//!
//! `cargo bench -p keycomp-harris`

use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use keycomp_harris::{HarrisParams, detect};
use keycomp_mesh::{Mesh, Topology, read_mesh, synth};
use keycomp_test_support::shared_data;

const MODELS: [&str; 3] = ["nefertiti.obj", "horse.ply", "igea.ply"];

/// The synthetic mesh plus every shared model that is present and readable.
fn meshes() -> Vec<(String, Mesh)> {
    let mut out = vec![("icosphere6".to_string(), synth::icosphere(6, 1.0))];
    for name in MODELS {
        let Some(p) = shared_data(format!("models/{name}")) else {
            continue;
        };
        match read_mesh(&p) {
            Ok(m) => out.push((name.to_string(), m.mesh)),
            Err(e) => eprintln!("skipping {name}: {e}"),
        }
    }
    out
}

fn bench_detect(c: &mut Criterion) {
    let mut g = c.benchmark_group("harris_detect");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    let params = HarrisParams::default();
    for (name, mesh) in meshes() {
        let topo = Topology::new(&mesh);
        g.throughput(Throughput::Elements(mesh.num_vertices() as u64));
        g.bench_function(name, |b| b.iter(|| detect(&mesh, &topo, &params)));
    }
    g.finish();
}

fn bench_read(c: &mut Criterion) {
    let mut g = c.benchmark_group("mesh_read");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    for name in MODELS {
        let Some(p) = shared_data(format!("models/{name}")) else {
            continue;
        };
        let Ok(m) = read_mesh(&p) else {
            eprintln!("skipping reading {name}: unreadable");
            continue;
        };
        g.throughput(Throughput::Elements(m.mesh.num_vertices() as u64));
        g.bench_function(name, |b| b.iter(|| read_mesh(&p)));
    }
    g.finish();
}

criterion_group!(benches, bench_detect, bench_read);
criterion_main!(benches);
