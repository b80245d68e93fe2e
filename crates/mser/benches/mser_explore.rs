//! Prints the maximally stable components and MSER key-components of a mesh file (or of a
//! synthetic protrusion sphere) with chosen parameters, to tune and inspect the method.
//!
//! ```text
//! cargo bench -p keycomp-mser --bench mser_explore -- \
//!     [MESH|synth] [edge|vertex] [time] [delta] [min_diversity] [max_variation]
//! ```
//!
//! MESH is relative to the workspace root. Run without cargo's `--bench` flag, as
//! `cargo test --all-targets` does, it measures nothing.

use keycomp_mesh::{read_mesh, synth};
use keycomp_mser::{MserParams, StableParams, detect};
use keycomp_test_support::workspace_path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(args) = keycomp_test_support::bench_args(
        "cargo bench -p keycomp-mser --bench mser_explore -- [MESH|synth] [edge|vertex] [time] [delta] [min_diversity] [max_variation]",
    ) else {
        return Ok(());
    };
    let args = &args[1..];
    let mesh = match args.first().map(String::as_str) {
        None | Some("synth") => synth::protrusion_sphere(5, 0.8, 0.25),
        // `cargo bench` runs in crates/mser
        Some(path) => read_mesh(&workspace_path(path))?.mesh,
    };
    let d = MserParams::default();
    let params = MserParams {
        weighting: args.get(1).map_or(Ok(d.weighting), |s| s.parse())?,
        time: args.get(2).map_or(Ok(d.time), |s| s.parse())?,
        stable: StableParams {
            delta: args.get(3).map_or(Ok(d.stable.delta), |s| s.parse())?,
            min_diversity: args
                .get(4)
                .map_or(Ok(d.stable.min_diversity), |s| s.parse())?,
            max_variation: args
                .get(5)
                .map_or(Ok(d.stable.max_variation), |s| s.parse())?,
            ..d.stable
        },
        ..d
    };
    let det = detect(&mesh, &params)?;
    println!(
        "{} vertices; {} keypoints; {} components; {} key-components; {} uncovered; {:?}",
        mesh.num_vertices(),
        det.keypoints.len(),
        det.components.len(),
        det.key_components.len(),
        det.uncovered.len(),
        det.timings
    );
    for (i, s) in det.stable.iter().enumerate() {
        let kps = det
            .keypoints
            .iter()
            .filter(|k| det.components[i].binary_search(k).is_ok())
            .count();
        println!(
            "{i:3} level {:.3} area {:.4} var {:.3} keypoints {kps}{}",
            s.level,
            s.area,
            s.variation,
            if det.key_components.contains(&i) {
                "  KC"
            } else {
                ""
            }
        );
    }
    Ok(())
}
