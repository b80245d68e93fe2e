//! `keycomp detect`: key-components of one mesh file (Sipiran & Bustos 2013).

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};
use keycomp_components::{DetectParams, Detection, Preset, detect};
use keycomp_harris::HarrisParams;
use keycomp_mesh::{Mesh, read_mesh};
use serde::Serialize;

use crate::keypoints::HarrisArgs;
use crate::{colors, output};

pub const EXAMPLES: &str = "Examples:
  keycomp detect cat0.off
  keycomp detect cat0.off --preset kc3 --json > cat0.json
  keycomp detect horse.ply --r 0.2 --t 0.4 --n 25 --ply horse-components.ply";

/// Arguments of `keycomp detect`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Mesh file (.off, .obj, .ply, .stl).
    pub mesh: PathBuf,
    #[command(flatten)]
    pub detect: DetectArgs,
    /// Print JSON (mesh, counts, area, preset, params, keypoints, components, timings_ms).
    #[arg(long)]
    pub json: bool,
    /// Write the mesh with each key-component in its own colour (grey elsewhere), binary PLY.
    #[arg(long, value_name = "OUT")]
    pub ply: Option<PathBuf>,
}

/// Detection options shared by the commands that detect key-components.
#[derive(Debug, Clone, clap::Args)]
pub struct DetectArgs {
    /// Preset of Section 4.3: kc1 (R 0.15, T 0.30, N 30), kc2 (N 20), kc3 (R 0.10, T 0.20, N 30).
    #[arg(long, default_value = "kc1", value_parser = parse_preset)]
    pub preset: Preset,
    #[command(flatten)]
    pub harris: HarrisArgs,
    /// Intra-cluster distance R (geodesic, on the mesh scaled to unit area).
    #[arg(long = "r", value_name = "R")]
    pub r: Option<f64>,
    /// Inter-cluster distance T (geodesic, on the mesh scaled to unit area).
    #[arg(long = "t", value_name = "T")]
    pub t: Option<f64>,
    /// Fewest keypoints in a cluster, N.
    #[arg(long = "n", value_name = "N")]
    pub n: Option<usize>,
    /// Factor σ on the enclosing sphere's radius that bounds region growing [default: 1.5].
    #[arg(long, value_name = "S")]
    pub sigma: Option<f64>,
    /// Seed of SMACOF's random starts [default: 0].
    #[arg(long, value_name = "S")]
    pub seed: Option<u64>,
}

fn parse_preset(s: &str) -> Result<Preset, String> {
    s.parse::<Preset>()
        .map_err(|_| format!("unknown preset '{s}' (kc1, kc2 or kc3)"))
}

impl DetectArgs {
    /// The parameters: the preset, then each explicit option on top.
    pub fn params(&self) -> DetectParams {
        let mut p = DetectParams {
            harris: self.harris.params(HarrisParams::default()),
            components: self.preset.component_params(),
        };
        let c = &mut p.components;
        if let Some(r) = self.r {
            c.cluster.r = r;
        }
        if let Some(t) = self.t {
            c.cluster.t = t;
        }
        if let Some(n) = self.n {
            c.cluster.n_min = n;
        }
        if let Some(s) = self.sigma {
            c.sigma = s;
        }
        if let Some(seed) = self.seed {
            c.smacof.seed = seed;
        }
        p
    }
}

#[derive(Serialize)]
struct SphereJson {
    center: [f64; 3],
    radius: f64,
}

#[derive(Serialize)]
struct ComponentJson<'a> {
    id: usize,
    center: u32,
    sphere: SphereJson,
    keypoints: &'a [u32],
    vertices: &'a [u32],
    faces: &'a [u32],
    area: f64,
}

#[derive(Serialize)]
struct TimingsJson {
    read: f64,
    harris: f64,
    geodesic: f64,
    mds: f64,
    cluster: f64,
    extract: f64,
    total: f64,
}

#[derive(Serialize)]
struct Report<'a> {
    mesh: String,
    vertices: usize,
    faces: usize,
    area: f64,
    preset: String,
    params: &'a DetectParams,
    keypoints: &'a [u32],
    components: Vec<ComponentJson<'a>>,
    timings_ms: TimingsJson,
}

/// Colours each key-component distinctly, grey elsewhere (later components paint over earlier
/// ones where they overlap).
pub fn component_colors(mesh: &Mesh, det: &Detection) -> Vec<[u8; 3]> {
    let mut cols = vec![colors::GREY; mesh.num_vertices()];
    for c in &det.components {
        let col = colors::distinct(c.id);
        for &v in &c.vertices {
            cols[v as usize] = col;
        }
    }
    cols
}

pub fn run(args: Args) -> Result<ExitCode> {
    let params = args.detect.params();
    let t0 = Instant::now();
    let loaded = read_mesh(&args.mesh)?;
    let read_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mesh = &loaded.mesh;
    let det = detect(mesh, &params)
        .with_context(|| format!("{}: key-component detection failed", args.mesh.display()))?;
    let total_ms = t0.elapsed().as_secs_f64() * 1e3;

    if let Some(out) = &args.ply {
        keycomp_mesh::write_ply_colored(mesh, &component_colors(mesh, &det), out)?;
    }
    let t = det.timings;
    if args.json {
        output::print_json(&Report {
            mesh: args.mesh.display().to_string(),
            vertices: mesh.num_vertices(),
            faces: mesh.num_faces(),
            area: det.area,
            preset: args.detect.preset.to_string(),
            params: &params,
            keypoints: &det.keypoints,
            components: det
                .components
                .iter()
                .map(|c| ComponentJson {
                    id: c.id,
                    center: c.center,
                    sphere: SphereJson {
                        center: c.sphere_center,
                        radius: c.sphere_radius,
                    },
                    keypoints: &c.keypoints,
                    vertices: &c.vertices,
                    faces: &c.faces,
                    area: c.area,
                })
                .collect(),
            timings_ms: TimingsJson {
                read: read_ms,
                harris: t.harris,
                geodesic: t.geodesic,
                mds: t.mds,
                cluster: t.cluster,
                extract: t.extract,
                total: total_ms,
            },
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
        writeln!(
            s,
            "preset {} (R {}, T {}, N {}, σ {}, seed {}): {} keypoints, {} in no cluster",
            args.detect.preset,
            cp.cluster.r,
            cp.cluster.t,
            cp.cluster.n_min,
            cp.sigma,
            cp.smacof.seed,
            det.keypoints.len(),
            det.unclustered.len()
        )?;
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
        writeln!(
            s,
            "time: read {read_ms:.0} ms, harris {:.0}, geodesic {:.0}, mds {:.0}, cluster {:.1}, extract {:.1}, total {total_ms:.0} ms",
            t.harris, t.geodesic, t.mds, t.cluster, t.extract
        )?;
        if let Some(out) = &args.ply {
            writeln!(s, "wrote {}", out.display())?;
        }
        output::print_text(&s)?;
    }
    Ok(ExitCode::SUCCESS)
}
