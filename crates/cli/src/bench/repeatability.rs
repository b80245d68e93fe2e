//! `keycomp bench repeatability`: the paper's repeatability experiment (Sipiran & Bustos 2013,
//! Section 4) on generated transformations and real poses; see `keycomp_bench::experiment`.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use keycomp::options::DetectOptions;
use keycomp_bench::Kind;
use keycomp_bench::cache::EmbeddingCache;
use keycomp_bench::experiment::{
    Budget, Config, ISOMETRY, ISOMETRY_REMESHED, PresetSpec, Progress, RETESSELLATION, Report,
    RunStats, discover, run,
};
use keycomp_bench::svg::{Curve, repeatability_svg};
use keycomp_components::{Preset, SmacofParams, SphereRule};
use keycomp_harris::{HarrisParams, Selection};
use keycomp_mser::Method;
use keycomp_mser::MserParams;
use serde::Serialize;

use crate::args::HarrisArgs;
use crate::output;

pub const EXAMPLES: &str = "Examples:
  keycomp bench repeatability                       # ../shared/data, the robust preset, everything
  keycomp bench repeatability --preset all          # the paper's KC-1..3 (Tables 1-3)
  keycomp bench repeatability --preset kc1 --kinds noise,sampling --strengths 1,5
  keycomp bench repeatability --tessellation-independent --out bench-out/repeatability-ti
  keycomp bench repeatability --surface canonical --out bench-out/repeatability-canonical
  keycomp bench repeatability --method mser,mser-kc --out bench-out/repeatability-mser
  keycomp bench repeatability --data my-null-shapes/ --count 200 --json > results.json

Writes OUT/results.json (tables, curves, every component's best overlap), OUT/tables.md,
OUT/repeatability-<preset>.svg (Figs. 7-9) and OUT/run.json (timings, cache use); prints the
tables (ours / the paper's). Stage-1 detections are cached in OUT/cache by content, so a re-run
with the same parameters takes seconds.";

/// Arguments of `keycomp bench repeatability`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Null shapes: a folder laid out like ../shared/data (TOSCA pose 0, KIDS null.0 and FAUST
    /// tr_reg_000 are null shapes, the other poses are their isometry transformations), or any folder whose mesh
    /// files are all null shapes (no isometry) [default: ../shared/data].
    #[arg(long, value_name = "DIR")]
    pub data: Option<PathBuf>,
    /// Presets to evaluate: robust (keycomp's default detection: salient peaks of smoothed
    /// Harris responses, read beside the paper's KC-1),
    /// kc1, kc2, kc3, or all (the paper's three; their keypoints differ from robust's, so
    /// robust runs on its own).
    #[arg(long, default_value = "robust", value_parser = parse_presets)]
    pub preset: PresetChoice,
    /// Methods, comma-separated: kc (key-components, one table per --preset), mser (every
    /// diffusion-geometric maximally stable component, the paper's Table 5), mser-kc (MSER
    /// key-components, Table 6). The MSER methods compute 60 Laplace-Beltrami eigenpairs of
    /// each full mesh and share one cached detection.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "kc",
        value_name = "METHODS"
    )]
    pub method: Vec<Method>,
    #[command(flatten)]
    pub harris: HarrisArgs,
    /// Tessellation-independent keypoint budget for the paper's presets: the null shape and
    /// every shape made from it get the preset's fraction (1 %) of the null shape's vertex
    /// count (a fixed count per unit of normalised area) instead of that fraction of their
    /// own (the robust preset's budget is per unit area already). Implies `--surface as-read`.
    #[arg(long, conflicts_with_all = ["fraction", "count", "density"])]
    pub tessellation_independent: bool,
    /// The surface key-components are detected on: canonical (the default: each shape remade
    /// as every command analyses it, about 10,000 vertices per whole shape whatever its
    /// tessellation, the components carried back to the shape's vertices to be measured;
    /// Harris skips fits touching a border, as in canonical profiles) or as-read (each shape
    /// as generated, the paper's experiment). [default: canonical for the robust preset,
    /// as-read for the paper's presets.] MSER methods always run on the shapes as generated.
    #[arg(long, value_name = "MODE", value_parser = ["canonical", "as-read"])]
    pub surface: Option<String>,
    /// Override R of every preset (marks it with *).
    #[arg(long = "r", value_name = "R")]
    pub r: Option<f64>,
    /// Override T of every preset.
    #[arg(long = "t", value_name = "T")]
    pub t: Option<f64>,
    /// Override N of every preset.
    #[arg(long = "n", value_name = "N")]
    pub n: Option<usize>,
    /// Override σ of every preset.
    #[arg(long, value_name = "S")]
    pub sigma: Option<f64>,
    /// Override the sphere that σ scales: `enclosing` (the smallest sphere containing the
    /// cluster's keypoints, the paper's) or `spread:F` (centred at their mean, F times their
    /// RMS distance from it; the robust preset's is spread:1.2).
    #[arg(long, value_name = "RULE", value_parser = parse_sphere)]
    pub sphere: Option<SphereRule>,
    /// Override the smoothing of the copy Harris 3D runs on by this many Taubin λ|μ pairs (the
    /// robust preset's: a length, 0.0257 unit lengths, 30 pairs on a canonical surface; the
    /// paper's 0), at most 1000.
    #[arg(long, value_name = "N")]
    pub smoothing: Option<usize>,
    /// Transformations, comma-separated: isometry, holes, microholes, noise, shotnoise, scale,
    /// localscale, topology, sampling, and with --remeshed retessellation and
    /// isometry-remeshed [default: all].
    #[arg(long, value_delimiter = ',', value_parser = parse_kind, value_name = "KINDS")]
    pub kinds: Vec<KindChoice>,
    /// Strengths, comma-separated, each 1..5 [default: 1,2,3,4,5].
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u8).range(1..=5), value_name = "S")]
    pub strengths: Vec<u8>,
    /// Independent re-tessellations of the null shapes and poses, as written by
    /// `scripts/retessellate.py` (MeshLab's isotropic remeshing at five densities): adds the
    /// rows retessellation (each null shape remeshed, strength = density, finest first) and
    /// isometry-remeshed (each real pose remeshed at the middle density).
    #[arg(long, value_name = "DIR")]
    pub remeshed: Option<PathBuf>,
    /// Seed of the generated transformations.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Seed of SMACOF's random starts.
    #[arg(long, default_value_t = 0, value_name = "S")]
    pub smacof_seed: u64,
    #[command(flatten)]
    pub speed: crate::args::SpeedArgs,
    /// Output folder.
    #[arg(long, default_value = "bench-out/repeatability", value_name = "DIR")]
    pub out: PathBuf,
    /// Cache folder for detections [default: OUT/cache].
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
    /// Do not read or write the detection cache.
    #[arg(long, conflicts_with = "cache")]
    pub no_cache: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// One shape at a time (each detection still uses every thread) instead of several shapes
    /// in parallel.
    #[arg(long)]
    pub sequential: bool,
    /// Print results.json on stdout instead of the tables.
    #[arg(long)]
    pub json: bool,
}

/// The presets chosen with `--preset`.
#[derive(Debug, Clone)]
pub struct PresetChoice(Vec<Preset>);

fn parse_presets(s: &str) -> Result<PresetChoice, String> {
    if s.eq_ignore_ascii_case("all") {
        return Ok(PresetChoice(Preset::ALL.to_vec()));
    }
    s.parse::<Preset>()
        .map(|p| PresetChoice(vec![p]))
        .map_err(|_| format!("unknown preset '{s}' (robust, kc1, kc2, kc3 or all)"))
}

fn parse_sphere(s: &str) -> Result<SphereRule, String> {
    let bad = || {
        format!("unknown sphere rule '{s}' (enclosing, or spread:F with F > 0, e.g. spread:1.2)")
    };
    if s.eq_ignore_ascii_case("enclosing") {
        return Ok(SphereRule::Enclosing);
    }
    let factor: f64 = s
        .strip_prefix("spread:")
        .and_then(|f| f.parse().ok())
        .ok_or_else(bad)?;
    let rule = SphereRule::Spread { factor };
    rule.validate().map_err(|_| bad())?;
    Ok(rule)
}

/// A transformation chosen with `--kinds`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum KindChoice {
    /// Real poses.
    Isometry,
    /// The null shapes re-tessellated (`--remeshed`).
    Retessellation,
    /// The real poses re-tessellated (`--remeshed`).
    IsometryRemeshed,
    /// A generated kind.
    Generated(Kind),
}

fn parse_kind(s: &str) -> Result<KindChoice, String> {
    if s.trim().eq_ignore_ascii_case(ISOMETRY) {
        return Ok(KindChoice::Isometry);
    }
    if s.trim().eq_ignore_ascii_case(RETESSELLATION) {
        return Ok(KindChoice::Retessellation);
    }
    if s.trim().eq_ignore_ascii_case(ISOMETRY_REMESHED) {
        return Ok(KindChoice::IsometryRemeshed);
    }
    s.parse::<Kind>().map(KindChoice::Generated).map_err(|_| {
        format!(
            "unknown transformation '{s}': use isometry, holes, microholes, noise, shotnoise, \
                 scale, localscale, topology, sampling, retessellation or isometry-remeshed"
        )
    })
}

impl Args {
    fn config(&self, cache: Option<EmbeddingCache>) -> Config {
        let modified = self.r.is_some()
            || self.t.is_some()
            || self.n.is_some()
            || self.sigma.is_some()
            || self.sphere.is_some()
            || self.smoothing.is_some();
        let mut methods = self.method.clone();
        methods.dedup();
        let kc = methods.contains(&Method::Kc);
        let mut presets: Vec<PresetSpec> = self
            .preset
            .0
            .iter()
            .filter(|_| kc)
            .map(|p| {
                let c = p.component_params();
                let mut cluster = c.cluster;
                if let Some(r) = self.r {
                    cluster.r = r;
                }
                if let Some(t) = self.t {
                    cluster.t = t;
                }
                if let Some(n) = self.n {
                    cluster.n_min = n;
                }
                PresetSpec {
                    name: format!("{p}{}", if modified { "*" } else { "" }),
                    method: Method::Kc,
                    cluster,
                    sigma: self.sigma.unwrap_or(c.sigma),
                    sphere: self.sphere.unwrap_or(c.sphere),
                    grouping: c.grouping,
                    // the robust preset is read beside the paper's KC-1, the default it replaces
                    paper_name: if p.is_paper() { *p } else { Preset::Kc1 }.to_string(),
                }
            })
            .collect();
        for m in [Method::Mser, Method::MserKc] {
            if methods.contains(&m) {
                presets.extend(PresetSpec::mser(m));
            }
        }
        // The presets of one run share their keypoints (stage 1); `--preset` takes either
        // robust or paper presets, never both.
        let lead = self.preset.0.first().copied().filter(|_| kc);
        let base = lead.map_or_else(HarrisParams::default, Preset::harris_params);
        let mut harris = self.harris.params(base);
        if let Some(n) = self.smoothing {
            harris.smoothing_length = None;
            harris.smoothing_iterations = n;
        }
        // a budget calibrated on the null shape's vertices is a measure of the shapes as read
        let canonical = crate::args::canonical_choice(self.surface.as_deref())
            .unwrap_or_else(|| !lead.is_some_and(Preset::is_paper));
        let surface = (canonical && !self.tessellation_independent)
            .then(keycomp_surface::SurfaceParams::default);
        if surface.is_some() {
            harris.skip_boundary = true;
        }
        let base_smacof = lead.map_or_else(SmacofParams::default, |p| p.component_params().smacof);
        let budget = if self.tessellation_independent {
            Budget::NullCalibrated(match base.selection {
                Selection::Fraction(f) => f,
                _ => 0.01,
            })
        } else {
            Budget::PerShape(harris.selection)
        };
        let remeshed = self.remeshed.is_some();
        let (retessellation, remeshed_isometry) = if self.kinds.is_empty() {
            (remeshed, remeshed)
        } else {
            (
                self.kinds.contains(&KindChoice::Retessellation),
                self.kinds.contains(&KindChoice::IsometryRemeshed),
            )
        };
        let (kinds, isometry) = if self.kinds.is_empty() {
            (Kind::ALL.to_vec(), true)
        } else {
            let mut kinds = Vec::new();
            for k in &self.kinds {
                if let KindChoice::Generated(k) = k
                    && !kinds.contains(k)
                {
                    kinds.push(*k);
                }
            }
            (kinds, self.kinds.contains(&KindChoice::Isometry))
        };
        let mut strengths = if self.strengths.is_empty() {
            vec![1, 2, 3, 4, 5]
        } else {
            self.strengths.clone()
        };
        strengths.sort_unstable();
        strengths.dedup();
        Config {
            presets,
            harris,
            budget,
            smacof: DetectOptions {
                seed: Some(self.smacof_seed),
                ..self.speed.options()
            }
            .smacof(base_smacof),
            geodesic: DetectOptions {
                preset: lead.unwrap_or_default(),
                ..self.speed.options()
            }
            .geodesic(),
            mser: MserParams::default(),
            kinds,
            isometry,
            strengths,
            seed: self.seed,
            cache,
            parallel_shapes: !self.sequential,
            surface,
            remeshed: self.remeshed.clone(),
            retessellation,
            remeshed_isometry,
        }
    }
}

/// `KC-1` → `kc1`, `KC-1*` → `kc1-modified`.
fn file_tag(preset: &str) -> String {
    let base: String = preset
        .trim_end_matches('*')
        .chars()
        .filter(|c| c.is_ascii_alphanumeric())
        .collect::<String>()
        .to_ascii_lowercase();
    if preset.ends_with('*') {
        format!("{base}-modified")
    } else {
        base
    }
}

#[derive(Serialize)]
struct RunJson<'a> {
    data: String,
    out: String,
    cache: Option<String>,
    threads: usize,
    parallel_shapes: bool,
    stats: &'a RunStats,
}

fn progress_bar() -> ProgressBar {
    let target = if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    };
    let bar = ProgressBar::with_draw_target(Some(0), target);
    if let Ok(style) =
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} shapes  {msg}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.enable_steady_tick(Duration::from_millis(250));
    bar
}

pub fn run_cmd(args: Args) -> Result<ExitCode> {
    let data = args
        .data
        .clone()
        .unwrap_or_else(|| PathBuf::from("../shared/data"));
    let nulls = discover(&data)?;
    let cache_dir = if args.no_cache {
        None
    } else {
        Some(args.cache.clone().unwrap_or_else(|| args.out.join("cache")))
    };
    let config = args.config(cache_dir.clone().map(EmbeddingCache::new));
    if (config.retessellation || config.remeshed_isometry) && config.remeshed.is_none() {
        anyhow::bail!(
            "the rows retessellation and isometry-remeshed need --remeshed DIR, a folder of \
             re-tessellations made by scripts/retessellate.py"
        );
    }
    if let Some(dir) = &config.remeshed
        && !dir.is_dir()
    {
        anyhow::bail!(
            "{}: no such folder (scripts/retessellate.py --out {} makes it)",
            dir.display(),
            dir.display()
        );
    }
    config
        .harris
        .validate()
        .context("invalid keypoint options")?;
    config
        .geodesic
        .validate()
        .context("invalid geodesic options")?;
    for p in &config.presets {
        p.cluster
            .validate()
            .with_context(|| format!("invalid clustering options for {}", p.name))?;
    }
    output::create_output_folder(&args.out)?;

    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        builder = builder.num_threads(n);
    }
    let pool = builder.build().context("cannot start the thread pool")?;
    let threads = pool.current_num_threads();

    let bar = progress_bar();
    let on_progress = |p: Progress<'_>| {
        bar.set_length(p.total as u64);
        bar.set_position(p.done as u64);
        bar.set_message(p.shape.to_owned());
    };
    let result = pool.install(|| run(&config, &nulls, &on_progress));
    bar.finish_and_clear();
    let (report, stats) = result?;

    write_outputs(&args, &data, cache_dir.as_deref(), threads, &report, &stats)?;
    let evaluated = report.shapes.iter().filter(|s| s.kind != "null").count();
    eprintln!(
        "{} shapes ({} computed, {} from the cache{}) in {:.1} s on {threads} threads; wrote {}",
        report.shapes.len(),
        stats.computed,
        stats.cache_hits,
        if stats.corrupt_entries > 0 {
            format!(", {} corrupt entries replaced", stats.corrupt_entries)
        } else {
            String::new()
        },
        stats.seconds,
        args.out.display()
    );
    for e in &stats.cache_write_errors {
        eprintln!("warning: could not cache a detection: {e}");
    }
    if args.json {
        output::print_json(&report)?;
    } else {
        output::print_text(&report.markdown())?;
    }
    Ok(if evaluated == 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

fn write_outputs(
    args: &Args,
    data: &Path,
    cache: Option<&Path>,
    threads: usize,
    report: &Report,
    stats: &RunStats,
) -> Result<()> {
    let out = &args.out;
    let json = serde_json::to_vec_pretty(report).context("cannot serialise the results")?;
    output::write_bytes(&out.join("results.json"), &json)?;
    output::write_bytes(&out.join("tables.md"), report.markdown().as_bytes())?;
    for pr in &report.presets {
        let curves: Vec<Curve> = pr
            .curves
            .iter()
            .map(|c| Curve {
                label: format!("{} ({})", c.label, c.components),
                values: c.values.clone(),
            })
            .collect();
        let title = match pr.preset.method {
            Method::Kc => format!(
                "{}: repeatability vs overlap (R {}, T {}, N {})",
                pr.preset.name, pr.preset.cluster.r, pr.preset.cluster.t, pr.preset.cluster.n_min
            ),
            Method::Mser | Method::MserKc => {
                format!("{}: repeatability vs overlap", pr.preset.name)
            }
        };
        let svg = repeatability_svg(&title, &report.thresholds, &curves);
        output::write_bytes(
            &out.join(format!("repeatability-{}.svg", file_tag(&pr.preset.name))),
            svg.as_bytes(),
        )?;
    }
    let run = RunJson {
        data: data.display().to_string(),
        out: out.display().to_string(),
        cache: cache.map(|c| c.display().to_string()),
        threads,
        parallel_shapes: !args.sequential,
        stats,
    };
    let json = serde_json::to_vec_pretty(&run).context("cannot serialise the run statistics")?;
    output::write_bytes(&out.join("run.json"), &json)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_tags() {
        assert_eq!(file_tag("KC-1"), "kc1");
        assert_eq!(file_tag("KC-3*"), "kc3-modified");
    }
}
