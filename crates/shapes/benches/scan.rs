//! Generates instances of every class at a vertex target and reports failures, timings and
//! the worst triangle (smallest angle, smallest relative area) of each:
//! `cargo bench -p keycomp-shapes --bench scan -- [TARGET] [INSTANCES] [RELAX_ROUNDS]` (run
//! without cargo's `--bench` flag, as `cargo test --all-targets` does, it measures nothing).
use std::time::Instant;

use keycomp_shapes::{Class, GenerateParams, check, generate};

fn main() {
    let Some(args) = keycomp_test_support::bench_args(
        "cargo bench -p keycomp-shapes --bench scan -- [TARGET] [INSTANCES] [RELAX_ROUNDS]",
    ) else {
        return;
    };
    let args = &args[1..];
    let target = args.first().and_then(|s| s.parse().ok()).unwrap_or(20_000);
    let n = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(6);
    let rounds = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(4);
    let params = GenerateParams {
        target_vertices: target,
        relax_rounds: rounds,
        ..GenerateParams::default()
    };
    for class in Class::ALL {
        for i in 0..n {
            let t = Instant::now();
            match generate(class, i, &params) {
                Ok(s) => {
                    let r = check::check_closed_manifold(&s.mesh);
                    println!(
                        "{:<14} {:>6} vertices {:>6.0} ms  {:?}",
                        s.name,
                        s.mesh.num_vertices(),
                        t.elapsed().as_secs_f64() * 1e3,
                        r.map(|r| (r.min_angle_deg, r.min_relative_area))
                    );
                }
                Err(e) => println!("{class}-{i:02}: FAILED {e}"),
            }
        }
    }
}
