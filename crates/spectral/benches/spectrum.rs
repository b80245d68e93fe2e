//! Criterion benchmark of the spectrum: assembly + factorisation + Lanczos on an icosphere.
#![allow(missing_docs)]

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use keycomp_mesh::synth;
use keycomp_spectral::{Spectrum, SpectrumParams};

fn spectrum(c: &mut Criterion) {
    let mut g = c.benchmark_group("spectrum");
    g.sample_size(10);
    for (sub, count) in [(4u32, 100usize), (5, 100)] {
        let mesh = synth::icosphere(sub, 1.0);
        g.throughput(Throughput::Elements(mesh.num_vertices() as u64));
        let params = SpectrumParams {
            count,
            ..Default::default()
        };
        g.bench_function(format!("icosphere{sub}_k{count}"), |b| {
            b.iter(|| Spectrum::compute(&mesh, &params).expect("converges"))
        });
    }
    g.finish();
}

criterion_group!(benches, spectrum);
criterion_main!(benches);
