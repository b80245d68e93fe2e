//! Generates instances of every class at a vertex target and reports failures, timings and
//! the worst triangle (smallest angle, smallest relative area) of each:
//! `cargo bench -p keycomp-shapes --bench scan -- [TARGET] [INSTANCES] [RELAX_ROUNDS]` (the
//! `--bench` flag that `cargo bench` passes is ignored).
use std::time::Instant;

use keycomp_shapes::{Class, GenerateParams, check, generate};

fn main() {
    // `cargo bench` adds `--bench`
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
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
