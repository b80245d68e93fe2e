//! `keycomp detect`: key-components of one mesh file (Sipiran & Bustos 2013).

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};
use keycomp::json::DetectionJson;
use keycomp_components::detect;
use keycomp_mesh::{Geometry, read_input};
use keycomp_mser::Method;
use keycomp_mser::MserParams;
use keycomp_surface::SurfaceParams;
use serde::Serialize;

use crate::args::DetectArgs;
use crate::colors::component_colors;
use crate::output;

pub const EXAMPLES: &str = "Examples:
  keycomp detect cat0.off
  keycomp detect cat0.off --preset kc3 --json > cat0.json
  keycomp detect cat0.off --method mser-kc --json > cat0-mser-kc.json
  keycomp detect horse.ply --r 0.2 --t 0.4 --n 25 --ply horse-components.ply";

/// Arguments of `keycomp detect`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Mesh file (.off, .obj, .ply, .stl, .gltf, .glb), range scan (PLY range grid) or point
    /// cloud (.xyz, .pts, .pcd, or a PLY, OFF or OBJ without faces).
    pub mesh: PathBuf,
    #[command(flatten)]
    pub detect: DetectArgs,
    /// Detect on the canonical surface (the default; `keycomp surface`), whose vertices the
    /// output's ids then are, or on the mesh as read. A point cloud is always detected on its
    /// canonical surface.
    #[arg(long, value_name = "MODE", value_parser = ["canonical", "as-read"])]
    pub surface: Option<String>,
    /// Print JSON (mesh, counts, area, preset, params, keypoints, components, timings_ms).
    #[arg(long)]
    pub json: bool,
    /// Write the mesh with each key-component in its own colour (grey elsewhere), binary PLY.
    #[arg(long, value_name = "OUT")]
    pub ply: Option<PathBuf>,
    /// Detection method: kc (key-components, the paper's method), mser (every
    /// diffusion-geometric maximally stable component, Litman et al. 2011) or mser-kc (the MSER
    /// key-components of Section 4.4: the smallest MSER components covering the HKS
    /// keypoints). The MSER methods ignore the key-component options and compute 60
    /// Laplace-Beltrami eigenpairs of the full mesh.
    #[arg(long, default_value = "kc", value_name = "METHOD")]
    pub method: Method,
}

#[derive(Serialize)]
struct TimingsJson {
    read: f64,
    /// MSER methods: normalisation and Laplace–Beltrami eigenpairs.
    #[serde(skip_serializing_if = "Option::is_none")]
    spectrum: Option<f64>,
    /// MSER methods: HKS keypoints.
    #[serde(skip_serializing_if = "Option::is_none")]
    hks: Option<f64>,
    /// MSER methods: weights, component tree and maximally stable components.
    #[serde(skip_serializing_if = "Option::is_none")]
    mser: Option<f64>,
    /// MSER methods: the covering set.
    #[serde(skip_serializing_if = "Option::is_none")]
    select: Option<f64>,
    harris: f64,
    geodesic: f64,
    mds: f64,
    cluster: f64,
    extract: f64,
    total: f64,
}

pub fn run(args: Args) -> Result<ExitCode> {
    let mut params = args.detect.params();
    let t0 = Instant::now();
    let loaded = read_input(&args.mesh)?;
    for w in &loaded.warnings {
        eprintln!("warning: {}: {w}", args.mesh.display());
    }
    // the file's geometry is kept when detection runs on its canonical surface (for --ply)
    let canonical = crate::args::canonical_choice(args.surface.as_deref())
        .unwrap_or_else(|| args.detect.canonical_by_default());
    let (mesh, input) = match loaded.geometry {
        Geometry::Mesh(m) if !canonical => (m, None),
        geometry => {
            // as in the analysis: no keypoints from fits that reach a scan's border
            params.harris.skip_boundary = true;
            let surface =
                keycomp::analysis::canonical_surface(&geometry, &SurfaceParams::default())
                    .with_context(|| format!("{}: no canonical surface", args.mesh.display()))?
                    .mesh;
            (surface, Some(geometry))
        }
    };
    let read_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mesh = &mesh;
    let mser_params = args.method.mser_output().map(|_| MserParams::default());
    let (det, mser_timings) = match (args.method.mser_output(), &mser_params) {
        (Some(out), Some(mp)) => {
            let d = keycomp_mser::detect(mesh, mp)
                .with_context(|| format!("{}: MSER detection failed", args.mesh.display()))?;
            let det = d
                .to_detection(mesh, out)
                .with_context(|| format!("{}: MSER detection failed", args.mesh.display()))?;
            (det, Some(d.timings))
        }
        _ => (
            detect(mesh, &params).with_context(|| {
                format!("{}: key-component detection failed", args.mesh.display())
            })?,
            None,
        ),
    };
    let total_ms = t0.elapsed().as_secs_f64() * 1e3;

    if let Some(out) = &args.ply {
        output::write_colours_on_input(input, mesh, &component_colors(mesh, &det), out)?;
    }
    let t = det.timings;
    if args.json {
        output::print_json(&DetectionJson {
            mser_params,
            timings_ms: Some(TimingsJson {
                read: read_ms,
                spectrum: mser_timings.map(|m| m.spectrum),
                hks: mser_timings.map(|m| m.keypoints),
                mser: mser_timings.map(|m| m.mser),
                select: mser_timings.map(|m| m.select),
                harris: t.harris,
                geodesic: t.geodesic,
                mds: t.mds,
                cluster: t.cluster,
                extract: t.extract,
                total: total_ms,
            }),
            ..DetectionJson::new(
                &args.mesh.display().to_string(),
                mesh,
                &det,
                &params,
                args.detect.detection_preset(),
                args.method.name(),
            )
        })?;
    } else {
        let mut s = String::new();
        writeln!(
            s,
            "{}: {} vertices, {} faces, area {:.6} (file units)",
            args.mesh.display(),
            mesh.num_vertices(),
            mesh.num_faces(),
            det.area
        )?;
        let cp = &params.components;
        if let Some(mp) = &mser_params {
            writeln!(
                s,
                "method {} ({} weights, t {}·area, {} eigenpairs, Δ {}): {} HKS keypoints, {} in no component",
                args.method,
                mp.weighting,
                mp.time,
                mp.eigenpairs,
                mp.stable.delta,
                det.keypoints.len(),
                det.unclustered.len()
            )?;
        } else if let keycomp_components::Grouping::Salient(sp) = cp.grouping {
            writeln!(
                s,
                "preset {} (salient peaks: t {}, prominence {}, radius {}, at most {}): {} keypoints, {} in no component",
                args.detect.detection_preset(),
                sp.time,
                sp.prominence,
                sp.radius,
                sp.max_components,
                det.keypoints.len(),
                det.unclustered.len()
            )?;
        } else {
            writeln!(
                s,
                "preset {} (R {}, T {}, N {}, σ {}, seed {}): {} keypoints, {} in no cluster",
                args.detect.detection_preset(),
                cp.cluster.r,
                cp.cluster.t,
                cp.cluster.n_min,
                cp.sigma,
                cp.smacof.seed,
                det.keypoints.len(),
                det.unclustered.len()
            )?;
        }
        if det.disconnected_pairs > 0 {
            writeln!(
                s,
                "note: {} keypoint pairs lie on different connected pieces",
                det.disconnected_pairs
            )?;
        }
        writeln!(s, "{} key-components:", det.components.len())?;
        writeln!(
            s,
            "{:>4}  {:>8}  {:>9}  {:>9}  {:>7}  {:>12}",
            "id", "centre", "keypoints", "vertices", "area %", "radius"
        )?;
        for c in &det.components {
            writeln!(
                s,
                "{:>4}  {:>8}  {:>9}  {:>9}  {:>7.2}  {:>12.5}{}",
                c.id,
                c.center,
                c.keypoints.len(),
                c.vertices.len(),
                c.area * 100.0,
                c.sphere_radius,
                if c.missed_keypoints.is_empty() {
                    String::new()
                } else {
                    format!("  ({} keypoints not reached)", c.missed_keypoints.len())
                }
            )?;
        }
        if let Some(m) = mser_timings {
            writeln!(
                s,
                "time: read {read_ms:.0} ms, spectrum {:.0}, hks {:.0}, mser {:.0}, select {:.1}, total {total_ms:.0} ms",
                m.spectrum, m.keypoints, m.mser, m.select
            )?;
        } else {
            writeln!(
                s,
                "time: read {read_ms:.0} ms, harris {:.0}, geodesic {:.0}, mds {:.0}, cluster {:.1}, extract {:.1}, total {total_ms:.0} ms",
                t.harris, t.geodesic, t.mds, t.cluster, t.extract
            )?;
        }
        if let Some(out) = &args.ply {
            writeln!(s, "wrote {}", out.display())?;
        }
        output::print_text(&s)?;
    }
    Ok(ExitCode::SUCCESS)
}
