//! `keycomp demo`: the pipeline on a shape generated in code, so it runs anywhere with no files.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Result;
use keycomp_components::{DetectParams, detect};
use keycomp_mesh::synth;

use crate::{detect::component_colors, output};

/// Arguments of `keycomp demo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Also write the demo shape with its key-components coloured to this PLY file.
    #[arg(long, value_name = "OUT")]
    pub ply: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<ExitCode> {
    let t0 = Instant::now();
    let mesh = synth::textured_protrusion_sphere(6);
    let dirs = synth::protrusion_directions();
    let gen_ms = t0.elapsed().as_secs_f64() * 1e3;
    let params = DetectParams::default();
    let t = Instant::now();
    let det = detect(&mesh, &params)?;
    let total_ms = t.elapsed().as_secs_f64() * 1e3;

    let mut s = String::new();
    writeln!(
        s,
        "keycomp demo: a sphere with {} textured protrusions, generated in code in {gen_ms:.0} ms \
         ({} vertices, {} faces)",
        dirs.len(),
        mesh.num_vertices(),
        mesh.num_faces()
    )?;
    writeln!(
        s,
        "key-components with the paper's KC-1 preset: {} keypoints (1 % of vertices), {} in no cluster",
        det.keypoints.len(),
        det.unclustered.len()
    )?;
    let strongest: Vec<String> = det
        .keypoints
        .iter()
        .take(10)
        .map(|k| k.to_string())
        .collect();
    writeln!(
        s,
        "strongest Harris 3D keypoints (vertex ids, best first): {} …",
        strongest.join(", ")
    )?;
    writeln!(
        s,
        "{:>4}  {:>8}  {:>9}  {:>9}  {:>7}  protrusion (angle to its axis)",
        "id", "centre", "keypoints", "vertices", "area %"
    )?;
    let mut found = vec![false; dirs.len()];
    for c in &det.components {
        let u = mesh.positions[c.center as usize].coords.normalize();
        let (nearest, angle) = dirs
            .iter()
            .enumerate()
            .map(|(i, d)| (i, u.dot(d).clamp(-1.0, 1.0).acos()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((0, f64::NAN));
        found[nearest] = true;
        writeln!(
            s,
            "{:>4}  {:>8}  {:>9}  {:>9}  {:>7.2}  #{} ({:.0}°)",
            c.id,
            c.center,
            c.keypoints.len(),
            c.vertices.len(),
            c.area * 100.0,
            nearest,
            angle.to_degrees()
        )?;
    }
    writeln!(
        s,
        "{} of {} protrusions found as key-components",
        found.iter().filter(|f| **f).count(),
        dirs.len()
    )?;
    let t = det.timings;
    writeln!(
        s,
        "time: harris {:.0} ms, geodesic {:.0}, mds {:.0}, cluster {:.1}, extract {:.1}, total {total_ms:.0} ms",
        t.harris, t.geodesic, t.mds, t.cluster, t.extract
    )?;
    if let Some(out) = &args.ply {
        keycomp_mesh::write_ply_colored(&mesh, &component_colors(&mesh, &det), out)?;
        writeln!(s, "wrote {}", out.display())?;
    } else {
        writeln!(
            s,
            "(add --ply demo.ply to write the shape with its key-components coloured)"
        )?;
    }
    output::print_text(&s)?;
    Ok(ExitCode::SUCCESS)
}
