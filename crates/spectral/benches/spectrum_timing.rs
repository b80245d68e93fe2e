//! Prints how long the Laplace–Beltrami spectrum takes on a ~10k and a ~50k vertex mesh:
//! vertices, eigenpairs, factorisation, Lanczos and total time, restarts, worst residual.
//!
//! ```text
//! cargo bench -p keycomp-spectral --bench spectrum_timing -- [COUNT ...]
//! ```
//!
//! Real meshes are read from `../shared/data` (relative to the workspace root) and skipped
//! with a message when absent.

use keycomp_mesh::{Mesh, read_mesh, synth};
use keycomp_spectral::{Spectrum, SpectrumParams};
use keycomp_test_support::{bench_args, shared_data};

fn main() {
    let Some(args) = bench_args("cargo bench -p keycomp-spectral --bench spectrum_timing") else {
        return;
    };
    let counts: Vec<usize> = args.iter().skip(1).filter_map(|a| a.parse().ok()).collect();
    let counts = if counts.is_empty() {
        vec![100, 200]
    } else {
        counts
    };
    let mut meshes: Vec<(String, Mesh)> = vec![("icosphere(5)".into(), synth::icosphere(5, 1.0))];
    for rel in ["tosca/cat0.off", "models/nefertiti.obj"] {
        let Some(path) = shared_data(rel) else {
            continue;
        };
        match read_mesh(&path) {
            Ok(loaded) => meshes.push((rel.to_string(), loaded.mesh)),
            Err(e) => eprintln!("skipping {rel}: {e}"),
        }
    }
    println!(
        "{:<22} {:>8} {:>6} {:>9} {:>10} {:>10} {:>9} {:>9} {:>9} {:>8} {:>10}",
        "mesh",
        "vertices",
        "pairs",
        "assemb ms",
        "factor ms",
        "lanczos ms",
        "solve ms",
        "ortho ms",
        "total ms",
        "restarts",
        "max resid"
    );
    for (name, mesh) in &meshes {
        for &count in &counts {
            let params = SpectrumParams {
                count,
                ..Default::default()
            };
            match Spectrum::compute(mesh, &params) {
                Ok(s) => {
                    let st = s.stats();
                    let worst = s.residuals().iter().copied().fold(0.0, f64::max);
                    println!(
                        "{:<22} {:>8} {:>6} {:>9.1} {:>10.1} {:>10.1} {:>9.1} {:>9.1} {:>9.1} {:>8} {:>10.1e}",
                        name,
                        mesh.num_vertices(),
                        s.len(),
                        st.assembly.as_secs_f64() * 1e3,
                        st.factorization.as_secs_f64() * 1e3,
                        st.iteration.as_secs_f64() * 1e3,
                        st.solve.as_secs_f64() * 1e3,
                        st.orthogonalization.as_secs_f64() * 1e3,
                        st.total.as_secs_f64() * 1e3,
                        st.restarts,
                        worst
                    );
                }
                Err(e) => println!("{name:<22} {count:>6} pairs: error: {e}"),
            }
        }
    }
}
