//! Time of SMACOF (pipeline step 4) on real keypoint matrices and on great-circle matrices.
//!
//! For each mesh file: unit-area normalisation, Harris keypoints and the keypoint distance
//! matrix exactly as `detect` does under `--preset` (default robust; its geodesic options
//! included), then SMACOF with that preset's parameters (`--relaxation W` overriding its
//! over-relaxation, e.g. 1 for the plain Guttman transform), `--runs` times (default 5). Without a mesh: great-circle distances
//! between K random points of the unit sphere, K = 500, 1000 and 1400, one classical start.
//! Printed per matrix: K, the winning start's transforms, the final stress, the median
//! milliseconds of the whole call and per transform. Threads: the global rayon pool
//! (`RAYON_NUM_THREADS=1` for one thread).
//!
//! ```text
//! cargo bench -p keycomp-components --bench smacof -- [--runs 5] [--preset robust|kc1] \
//!     [--relaxation W] [MESH...]
//! ```
//!
//! MESH paths are relative to the workspace root. When `cargo bench` did not run it, it prints
//! its usage and measures nothing.

use std::time::Instant;

use keycomp_components::{Preset, SmacofParams, keypoint_distances, smacof};
use keycomp_mesh::{Topology, geometry, read_mesh};
use keycomp_test_support::{bench_args, great_circle_matrix, median, workspace_path};

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// Runs SMACOF `runs` times on the matrix and prints one table row.
fn measure(name: &str, d: &[f64], k: usize, params: &SmacofParams, runs: usize) -> Res<()> {
    let mut times = Vec::with_capacity(runs);
    let mut last = None;
    for _ in 0..runs {
        let t = Instant::now();
        let e = smacof(d, k, params)?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
        last = Some(e);
    }
    let e = last.ok_or("--runs must be at least 1")?;
    let ms = median(times);
    println!(
        "| {name} | {k} | {} | {:.6e} | {ms:.1} | {:.3} |",
        e.iterations,
        e.stress,
        ms / (e.iterations + 1) as f64
    );
    Ok(())
}

fn main() -> Res<()> {
    let Some(args) = bench_args(
        "cargo bench -p keycomp-components --bench smacof -- [--runs 5] [--preset robust|kc1] \
         [--relaxation W] [MESH...]",
    ) else {
        return Ok(());
    };
    let mut args = args.into_iter().skip(1);
    let mut runs = 5;
    let mut preset = Preset::Robust;
    let mut files = Vec::new();
    let mut relaxation = None;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--relaxation" => relaxation = Some(args.next().ok_or("--relaxation W")?.parse()?),
            "--runs" => runs = args.next().ok_or("--runs N")?.parse()?,
            "--preset" => {
                preset = match args.next().ok_or("--preset NAME")?.as_str() {
                    "robust" => Preset::Robust,
                    "kc1" => Preset::Kc1,
                    other => return Err(format!("unknown preset {other}").into()),
                }
            }
            _ => files.push(a),
        }
    }
    println!(
        "SMACOF, {} threads, median of {runs} runs{}\n",
        rayon::current_num_threads(),
        relaxation.map_or(String::new(), |w| format!(", relaxation {w}"))
    );
    println!("| matrix | K | transforms | stress | ms | ms per transform |");
    println!("|---|---:|---:|---:|---:|---:|");
    if files.is_empty() {
        let params = SmacofParams {
            starts: 1,
            relaxation: relaxation.unwrap_or(1.0),
            ..SmacofParams::default()
        };
        for k in [500, 1000, 1400] {
            measure(
                &format!("sphere {k}"),
                &great_circle_matrix(k, 1),
                k,
                &params,
                runs,
            )?;
        }
        return Ok(());
    }
    let mut params = preset.component_params().smacof;
    if let Some(w) = relaxation {
        params.relaxation = w;
    }
    for f in files {
        let mesh = read_mesh(&workspace_path(&f))?.mesh;
        let (norm, _) = geometry::normalize_unit_area(&mesh);
        let topo = Topology::new(&norm);
        let harris = keycomp_harris::detect(&norm, &topo, &preset.harris_params())?;
        let (dist, _, _) =
            keypoint_distances(&norm, &topo, &harris.keypoints, &preset.geodesic_options())?;
        let k = harris.keypoints.len();
        let name = std::path::Path::new(&f)
            .file_name()
            .map_or(f.clone(), |n| n.to_string_lossy().into_owned());
        measure(&name, dist.as_slice(), k, &params, runs)?;
    }
    Ok(())
}
