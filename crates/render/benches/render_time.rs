//! Times the renderer on real and synthetic meshes and optionally writes the pictures.
//!
//! ```text
//! cargo bench -p keycomp-render --bench render_time [-- OUT_DIR]
//! ```
//!
//! OUT_DIR, when given, is relative to the workspace root. Meshes:
//! `../shared/data/models/nefertiti.obj` (skipped with a message when absent; found relative to
//! the workspace root, or in the folder `KEYCOMP_DATA` names, itself relative to the root) and
//! `synth::textured_protrusion_sphere(6)`. Each is coloured by height and rendered at 512 px
//! with 2×2 supersampling; the table shows the median of several runs. Run without cargo's
//! `--bench` flag, as `cargo test --all-targets` does, it measures nothing.

use std::path::{Path, PathBuf};
use std::time::Instant;

use keycomp_mesh::{Mesh, read_mesh, synth};
use keycomp_render::{RenderParams, UpAxis, render};
use keycomp_test_support::{SHARED_DATA, median, workspace_path};

/// Blue → teal → yellow ramp for the example's height colouring.
fn ramp(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 3] = [
        [50.0, 60.0, 150.0],
        [40.0, 160.0, 140.0],
        [250.0, 220.0, 50.0],
    ];
    let x = t.clamp(0.0, 1.0) * 2.0;
    let i = (x as usize).min(1);
    let f = x - i as f64;
    [0, 1, 2].map(|k| (STOPS[i][k] + f * (STOPS[i + 1][k] - STOPS[i][k])) as u8)
}

fn by_height(mesh: &Mesh, axis: usize) -> Vec<[u8; 3]> {
    let h: Vec<f64> = mesh.positions.iter().map(|p| p[axis]).collect();
    let lo = h.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = h.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    h.iter()
        .map(|v| ramp((v - lo) / (hi - lo).max(1e-12)))
        .collect()
}

fn data_dir() -> PathBuf {
    // `cargo bench` runs in crates/render
    std::env::var_os("KEYCOMP_DATA").map_or_else(|| workspace_path(SHARED_DATA), workspace_path)
}

fn time(name: &str, mesh: &Mesh, colors: &[[u8; 3]], params: &RenderParams, out: Option<&Path>) {
    // Warm up (thread pool, page faults), then take the median of 7 runs.
    let image = match render(mesh, colors, params) {
        Ok(image) => image,
        Err(e) => {
            eprintln!("{name}: {e}");
            return;
        }
    };
    let ms: Vec<f64> = (0..7)
        .map(|_| {
            let t = Instant::now();
            let _ = render(mesh, colors, params);
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    let min_ms = ms.iter().copied().fold(f64::INFINITY, f64::min);
    let t = Instant::now();
    let png = image.to_png_bytes().map(|b| b.len()).unwrap_or(0);
    let png_ms = t.elapsed().as_secs_f64() * 1e3;
    println!(
        "{name:<34} {:>8} {:>8} {:>6} {:>9.1} {:>9.1} {:>9.1} {:>8}",
        mesh.num_vertices(),
        mesh.num_faces(),
        params.size,
        min_ms,
        median(ms),
        png_ms,
        png / 1024
    );
    if let Some(dir) = out {
        let path = dir.join(format!("{name}.png"));
        if let Err(e) = image.write_png(&path) {
            eprintln!("{e}");
        }
    }
}

fn main() {
    let Some(args) = keycomp_test_support::bench_args(
        "cargo bench -p keycomp-render --bench render_time [-- OUT_DIR]",
    ) else {
        return;
    };
    let out = args.get(1).map(workspace_path);
    println!(
        "rayon threads: {}; 2x2 supersampling, smooth shading, outline on",
        rayon::current_num_threads()
    );
    println!(
        "{:<34} {:>8} {:>8} {:>6} {:>9} {:>9} {:>9} {:>8}",
        "mesh", "vertices", "faces", "px", "min ms", "median ms", "png ms", "png KiB"
    );
    let params = RenderParams::default();

    let sphere = synth::textured_protrusion_sphere(6);
    let colors = by_height(&sphere, 1);
    time(
        "textured_protrusion_sphere_6",
        &sphere,
        &colors,
        &params,
        out.as_deref(),
    );
    let flat = RenderParams {
        shading: keycomp_render::Shading::Flat,
        outline: None,
        ..params
    };
    time(
        "textured_protrusion_sphere_6_flat",
        &sphere,
        &colors,
        &flat,
        out.as_deref(),
    );

    let path = data_dir().join("models/nefertiti.obj");
    match read_mesh(&path) {
        Ok(loaded) => {
            let mesh = loaded.mesh;
            let colors = by_height(&mesh, 2);
            let params = RenderParams {
                up: UpAxis::Z,
                ..params
            };
            time("nefertiti", &mesh, &colors, &params, out.as_deref());
            let big = RenderParams {
                size: 1024,
                ..params
            };
            time("nefertiti_1024", &mesh, &colors, &big, out.as_deref());
        }
        Err(e) => println!("nefertiti: skipped ({e})"),
    }
}
