//! Arguments shared by several commands (detection, Harris 3D, units, surface, weights) and
//! the value parsers of clap options.

use anyhow::{Result, bail};
use keycomp::collection::Units;
use keycomp::options::DetectOptions;
use keycomp_components::{DetectParams, Preset};
use keycomp_harris::HarrisParams;

/// Detection options shared by the commands that detect key-components.
#[derive(Debug, Clone, clap::Args)]
pub struct DetectArgs {
    /// Preset: robust (the default; keycomp's: Harris responses of a copy smoothed over 0.0257
    /// unit lengths in neighbourhoods of 0.02 unit lengths, 400 keypoints per unit area, and
    /// components as the salient peaks of the diffused response, geodesic discs of 0.15 unit
    /// lengths: every length per unit of the source's; BENCHMARKS.md, *Repeatability*), or one
    /// of the paper's (Section 4.3), whose keypoints are 1 % of the vertices and which analyse
    /// the mesh as read unless --surface canonical: kc1 (R 0.15, T 0.30, N 30), kc2 (N 20),
    /// kc3 (R 0.10, T 0.20, N 30).
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
    #[arg(long = "n", value_name = "N", value_parser = crate::args::at_least_one)]
    pub n: Option<usize>,
    /// Scale N down for shapes with fewer than K keypoints: N·keypoints/K, at least 5 (not in
    /// the paper: lets meshes under ~20k vertices have key-components). 0 = the paper's fixed
    /// N. Default: 0, except with the paper's presets in `index add`, `query` and `match`
    /// (250), whose keypoints are a fraction of the vertices.
    #[arg(long = "n-reference", value_name = "K")]
    pub n_reference: Option<usize>,
    /// Factor σ on the enclosing sphere's radius that bounds region growing [default: 1.5].
    #[arg(long, value_name = "S")]
    pub sigma: Option<f64>,
    /// Seed of SMACOF's random starts [default: 0].
    #[arg(long, value_name = "S")]
    pub seed: Option<u64>,
    /// How keypoints become key-components: salient (the robust preset's: prominent peaks of
    /// the diffused Harris response, a geodesic disc around each) or adaptive (the paper's:
    /// SMACOF, Algorithm 1, sphere-bounded growing) [default: the preset's].
    #[arg(long, value_name = "MODE", value_parser = parse_grouping)]
    pub grouping: Option<bool>,
    /// Salient grouping: diffusion time of the response, in unit areas [default: 0.02].
    #[arg(long, value_name = "T")]
    pub saliency_time: Option<f64>,
    /// Salient grouping: share of its height by which a peak's saddle must lie below it
    /// [default: 0.4].
    #[arg(long, value_name = "P")]
    pub prominence: Option<f64>,
    /// Salient grouping: geodesic radius of a component around its peak, in unit lengths
    /// [default: 0.15].
    #[arg(long, value_name = "R")]
    pub component_radius: Option<f64>,
    /// Salient grouping: the most components, highest peaks first [default: 12].
    #[arg(long, value_name = "K", value_parser = crate::args::at_least_one)]
    pub max_components: Option<usize>,
    #[command(flatten)]
    pub speed: SpeedArgs,
}

fn parse_grouping(s: &str) -> Result<bool, String> {
    match s {
        "salient" => Ok(true),
        "adaptive" => Ok(false),
        _ => Err(format!("unknown grouping '{s}' (salient or adaptive)")),
    }
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
    /// from a keypoint to its nearest landmark; under the robust preset, in the keypoint's own
    /// distance to its nearest landmark, at least the 90th percentile of those) [default: 2].
    #[arg(long, value_name = "F")]
    pub landmark_radius: Option<f64>,
    /// The proxy's simplification runs in parallel in cells of at least this many vertices
    /// (pieces of the mesh's connectivity, a power of two of them, at most 64), then once more
    /// from the seams; 0 = one pass over the whole mesh. The cells depend on the mesh only, so
    /// the result is the same on any number of threads [default: 10000].
    #[arg(long, value_name = "N")]
    pub proxy_cell_vertices: Option<usize>,
    /// SMACOF's starts (the paper's method: 4 random ones) [default: 2].
    #[arg(long, value_name = "N", value_parser = crate::args::at_least_one)]
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
    /// given, else the default ([`keycomp::options::DEFAULT_PRESET`]).
    pub fn detection_preset(&self) -> Preset {
        self.preset.unwrap_or(keycomp::options::DEFAULT_PRESET)
    }

    /// Whether the surface analysed, when `--surface` is not given, is the canonical one
    /// ([`DetectOptions::canonical_by_default`] of the detection commands' preset).
    pub fn canonical_by_default(&self) -> bool {
        self.options_with(self.detection_preset())
            .canonical_by_default()
    }

    /// The preset of the retrieval commands: the one given, else the default.
    pub fn retrieval_preset(&self) -> Preset {
        self.preset.unwrap_or(keycomp::options::DEFAULT_PRESET)
    }

    /// The options as the library takes them, with the retrieval commands' preset.
    pub fn options(&self) -> DetectOptions {
        self.options_with(self.retrieval_preset())
    }

    /// The options as the library takes them, with `preset`.
    fn options_with(&self, preset: Preset) -> DetectOptions {
        DetectOptions {
            preset,
            density: self.harris.density,
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
            salient: self.grouping,
            saliency_time: self.saliency_time,
            prominence: self.prominence,
            component_radius: self.component_radius,
            max_components: self.max_components,
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

/// Harris 3D options shared by the commands that detect keypoints.
#[derive(Debug, Clone, clap::Args)]
pub struct HarrisArgs {
    /// Keep this many keypoints per unit area (of the source the input stands for), best
    /// first [default: 400 with the robust preset].
    #[arg(long, value_name = "K", group = "select")]
    pub density: Option<f64>,
    /// Keep this fraction of the vertices as keypoints, best first [default: 0.01 with the
    /// paper's presets].
    #[arg(long, value_name = "F", group = "select")]
    pub fraction: Option<f64>,
    /// Keep this many keypoints, best first.
    #[arg(long, value_name = "N", group = "select", value_parser = crate::args::at_least_one)]
    pub count: Option<usize>,
    /// Neighbourhood: this many whole rings around each vertex.
    #[arg(long, value_name = "K", group = "nbhd")]
    pub rings: Option<usize>,
    /// Neighbourhood: adaptive rings reaching this length, in unit lengths with the robust
    /// preset [default: 0.02], as a fraction of the moment diagonal (the bounding-box diagonal
    /// of an evenly spread surface) with the paper's [default: 0.01].
    #[arg(long, value_name = "D", group = "nbhd")]
    pub radius: Option<f64>,
}

impl HarrisArgs {
    /// The Harris parameters these options select, starting from `base`.
    pub fn params(&self, base: HarrisParams) -> HarrisParams {
        keycomp::options::DetectOptions {
            density: self.density,
            fraction: self.fraction,
            count: self.count,
            rings: self.rings,
            radius: self.radius,
            ..Default::default()
        }
        .harris(base)
    }
}

/// The length unit options of the commands that describe shapes (`index add`, `match`).
#[derive(Debug, Clone, clap::Args)]
pub struct UnitsArgs {
    /// Length unit of the description: scale-free (every mesh scaled to unit area on its own,
    /// the default) or file (the files' own units, for a collection and queries in the same
    /// real units, e.g. CAD in mm or calibrated scans: a fragment keeps its source's scale).
    /// Recorded in the index's profile; queries use the index's.
    #[arg(long, value_name = "MODE", value_parser = ["scale-free", "file"])]
    pub units: Option<String>,
    /// With --units file: the length unit, in file units [default: the square root of the
    /// median surface area of the shapes added (`index add` into a new index) or of the second
    /// shape (`match`)].
    #[arg(long, value_name = "L", requires = "units")]
    pub unit_length: Option<f64>,
}

impl UnitsArgs {
    /// The units asked for (`None`: none given).
    pub fn units(&self) -> Result<Option<Units>> {
        Ok(match (self.units.as_deref(), self.unit_length) {
            (None, None) => None,
            (Some("file"), length) => Some(Units::File { length }),
            (_, Some(_)) => bail!("--unit-length needs --units file"),
            (_, None) => Some(Units::ScaleFree),
        })
    }
}

/// What the commands that describe shapes (`index add`, `match`) analyse.
#[derive(Debug, Clone, clap::Args)]
pub struct SurfaceArgs {
    /// The surface analysed: canonical (the default: every input remade as one connected
    /// surface sampled at one density per unit of the area of the shape it stands for, the
    /// same whatever its tessellation: CAD soups, scans, point clouds, meshes at any
    /// resolution) or as-read (the mesh as the file gives it; point clouds still get their
    /// canonical surface). Recorded in the index's profile; queries use the index's.
    #[arg(long, value_name = "MODE", value_parser = ["canonical", "as-read"])]
    pub surface: Option<String>,
}

impl SurfaceArgs {
    /// `Some(true)`: canonical asked for; `Some(false)`: as read; `None`: not given.
    pub fn canonical(&self) -> Option<bool> {
        canonical_choice(self.surface.as_deref())
    }
}

/// A `--surface` value read: `Some(true)` canonical, `Some(false)` as read, `None` not given.
pub fn canonical_choice(surface: Option<&str>) -> Option<bool> {
    surface.map(|s| s == "canonical")
}

/// Parses a count that must be at least 1 (clap `value_parser` of `-k`, `--runs`, …).
pub fn at_least_one(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!("'{s}': expected a whole number of at least 1")),
    }
}

/// Parses a weight in [0, 1] (a clap value parser).
pub fn unit_weight(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(w) if (0.0..=1.0).contains(&w) => Ok(w),
        _ => Err(format!("'{s}': expected a number between 0 and 1")),
    }
}

/// A weight between 0 and 1, or `auto` (`None`): the value of `--verify`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutoWeight(pub Option<f64>);

/// Parses `auto` or a weight between 0 and 1 (clap's value parser of `--verify`).
pub fn auto_or_unit_weight(s: &str) -> Result<AutoWeight, String> {
    if s.trim().eq_ignore_ascii_case("auto") {
        Ok(AutoWeight(None))
    } else {
        unit_weight(s)
            .map(|w| AutoWeight(Some(w)))
            .map_err(|_| format!("'{s}': expected 'auto' or a number between 0 and 1"))
    }
}
