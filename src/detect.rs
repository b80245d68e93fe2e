//! `keycomp detect`: key-components of one mesh file (Sipiran & Bustos 2013).

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};
use keycomp::json::DetectionJson;
use keycomp::options::DetectOptions;
use keycomp_components::{DetectParams, Detection, Preset, detect};
use keycomp_mesh::{Geometry, Mesh, read_input};
use keycomp_mser::Method;
use keycomp_mser::MserParams;
use keycomp_surface::SurfaceParams;
use serde::Serialize;

use crate::keypoints::HarrisArgs;
use crate::{colors, output};

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
    /// Detect on the mesh as read (the default) or on its canonical surface (`keycomp
    /// surface`), whose vertices the output's ids then are. A point cloud is always detected on
    /// its canonical surface.
    #[arg(long, value_name = "MODE", value_parser = ["as-read", "canonical"])]
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

/// Detection options shared by the commands that detect key-components.
#[derive(Debug, Clone, clap::Args)]
pub struct DetectArgs {
    /// Preset: robust (keycomp's: KC-1's clustering on Harris responses of a smoothed copy,
    /// 2 % of the vertices as keypoints, spheres from the keypoints' spread; repeats best under
    /// noise and poses, BENCHMARKS.md section 3), or one of the paper's (Section 4.3): kc1
    /// (R 0.15, T 0.30, N 30), kc2 (N 20), kc3 (R 0.10, T 0.20, N 30). Default: robust for
    /// `detect`, `render` and `bench detect`; kc1 for `index add`, `query` and `match`.
    #[arg(long, value_parser = parse_preset)]
    pub preset: Option<Preset>,
    #[command(flatten)]
    pub harris: HarrisArgs,
    /// Intra-cluster distance R (geodesic, on the mesh scaled to unit area).
    #[arg(long = "r", value_name = "R")]
    pub r: Option<f64>,
    /// Inter-cluster distance T (geodesic, on the mesh scaled to unit area).
    #[arg(long = "t", value_name = "T")]
    pub t: Option<f64>,
    /// Fewest keypoints in a cluster, N.
    #[arg(long = "n", value_name = "N", value_parser = crate::output::at_least_one)]
    pub n: Option<usize>,
    /// Scale N down for shapes with fewer than K keypoints: N·keypoints/K, at least 5 (not in
    /// the paper: lets meshes under ~20k vertices have key-components). 0 = the paper's fixed
    /// N. Default: 0 for `detect`, 250 for `index add`, `query` and `match`.
    #[arg(long = "n-reference", value_name = "K")]
    pub n_reference: Option<usize>,
    /// Factor σ on the enclosing sphere's radius that bounds region growing [default: 1.5].
    #[arg(long, value_name = "S")]
    pub sigma: Option<f64>,
    /// Seed of SMACOF's random starts [default: 0].
    #[arg(long, value_name = "S")]
    pub seed: Option<u64>,
    #[command(flatten)]
    pub speed: SpeedArgs,
}

/// How the geodesic distances and the embedding are computed (deviations from the paper made
/// for speed, and their off switches): shared by every command that detects key-components
/// and by `bench repeatability`.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct SpeedArgs {
    /// Run the fast-marching fronts on a proxy of at most N vertices (the mesh simplified by
    /// half-edge collapse, keypoints kept as vertices) when the mesh has more; 0 = the full
    /// mesh, as in the paper. The default proxy is a deviation from the paper, made for speed
    /// (several times fewer CPU cycles on 50–60k vertices; repeatability and retrieval within
    /// noise: BENCHMARKS.md section 2) [default: 10000]
    #[arg(long, value_name = "N")]
    pub geodesic_vertices: Option<usize>,
    /// Fast marching splits obtuse corners of at least this angle, in degrees (90 = every
    /// obtuse corner, 180 = none) [default: 90].
    #[arg(long, value_name = "DEG")]
    pub split_angle: Option<f64>,
    /// Landmark fronts: only this many keypoints (spread by farthest-point sampling) run a
    /// full fast-marching front, the others a short one, and the pairs no front measured get
    /// the shortest path through a landmark; 0 = a full front from every keypoint, as in the
    /// paper. A deviation from the paper, made for speed (with the classical start below,
    /// 0.37–0.41× the time of detection on 50–60k vertices, repeatability within noise:
    /// BENCHMARKS.md section 2) [default: 100].
    #[arg(long, value_name = "L")]
    pub landmarks: Option<usize>,
    /// Where the non-landmarks' short fronts stop, in covering radii (the largest distance
    /// from a keypoint to its nearest landmark) [default: 2].
    #[arg(long, value_name = "F")]
    pub landmark_radius: Option<f64>,
    /// The proxy's simplification runs in parallel in cells of at least this many vertices
    /// (pieces of the mesh's connectivity, a power of two of them, at most 64), then once more
    /// from the seams; 0 = one pass over the whole mesh. The cells depend on the mesh only, so
    /// the result is the same on any number of threads [default: 10000].
    #[arg(long, value_name = "N")]
    pub proxy_cell_vertices: Option<usize>,
    /// SMACOF's starts (the paper's method: 4 random ones) [default: 2].
    #[arg(long, value_name = "N", value_parser = crate::output::at_least_one)]
    pub smacof_starts: Option<usize>,
    /// SMACOF's first start: `random`, or `classical` (Torgerson scaling of the distances; the
    /// other starts stay random) [default: classical].
    #[arg(long, value_name = "INIT", value_parser = parse_init)]
    pub smacof_init: Option<bool>,
}

impl SpeedArgs {
    /// These options as [`DetectOptions`] (every other option unset).
    pub fn options(&self) -> DetectOptions {
        DetectOptions {
            geodesic_vertices: self.geodesic_vertices,
            split_angle: self.split_angle,
            landmarks: self.landmarks,
            landmark_radius: self.landmark_radius,
            proxy_cell_vertices: self.proxy_cell_vertices,
            smacof_starts: self.smacof_starts,
            classical_start: self.smacof_init,
            ..DetectOptions::default()
        }
    }
}

fn parse_init(s: &str) -> Result<bool, String> {
    match s {
        "classical" => Ok(true),
        "random" => Ok(false),
        _ => Err(format!("unknown SMACOF start '{s}' (classical or random)")),
    }
}

fn parse_preset(s: &str) -> Result<Preset, String> {
    s.parse::<Preset>()
        .map_err(|_| format!("unknown preset '{s}' (robust, kc1, kc2 or kc3)"))
}

impl DetectArgs {
    /// Whether these options give the same retrieval parameters as giving none at all.
    pub fn is_default(&self) -> bool {
        #[derive(clap::Parser)]
        struct Bare {
            #[command(flatten)]
            detect: DetectArgs,
        }
        <Bare as clap::Parser>::try_parse_from(["keycomp"])
            .is_ok_and(|b| b.detect.retrieval_params() == self.retrieval_params())
    }

    /// The preset of the detection commands (`detect`, `render`, `bench detect`): the one
    /// given, else the robust preset.
    pub fn detection_preset(&self) -> Preset {
        self.preset.unwrap_or(Preset::Robust)
    }

    /// The preset of the retrieval commands: the one given, else KC-1.
    pub fn retrieval_preset(&self) -> Preset {
        self.preset.unwrap_or(Preset::Kc1)
    }

    /// The options as the library takes them, with the retrieval commands' preset.
    pub fn options(&self) -> DetectOptions {
        self.options_with(self.retrieval_preset())
    }

    /// The options as the library takes them, with `preset`.
    fn options_with(&self, preset: Preset) -> DetectOptions {
        DetectOptions {
            preset,
            fraction: self.harris.fraction,
            count: self.harris.count,
            rings: self.harris.rings,
            radius: self.harris.radius,
            r: self.r,
            t: self.t,
            n: self.n,
            n_reference: self.n_reference,
            sigma: self.sigma,
            seed: self.seed,
            ..self.speed.options()
        }
    }

    /// The parameters of the retrieval commands ([`DetectOptions::retrieval_params`]).
    pub fn retrieval_params(&self) -> DetectParams {
        self.options().retrieval_params()
    }

    /// The retrieval parameters when the options ask for other than the default ones, else
    /// `None` (an index's own parameters then apply).
    pub fn explicit(&self) -> Option<DetectParams> {
        (!self.is_default()).then(|| self.retrieval_params())
    }

    /// The parameters of the detection commands: their preset
    /// ([`DetectArgs::detection_preset`]), then each explicit option on top
    /// ([`DetectOptions::params`]).
    pub fn params(&self) -> DetectParams {
        self.options_with(self.detection_preset()).params()
    }
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
    let mut params = args.detect.params();
    let t0 = Instant::now();
    let loaded = read_input(&args.mesh)?;
    for w in &loaded.warnings {
        eprintln!("warning: {}: {w}", args.mesh.display());
    }
    // the file's geometry is kept when detection runs on its canonical surface (for --ply)
    let (mesh, input) = match loaded.geometry {
        Geometry::Mesh(m) if args.surface.as_deref() != Some("canonical") => (m, None),
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
