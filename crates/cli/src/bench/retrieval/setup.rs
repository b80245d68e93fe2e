//! A run's settings from its arguments: the query kinds, the collection's files and classes,
//! the external queries' ground truth, and the parameters of key-components (exactly what
//! `keycomp index add` uses with the same options) and of the baselines.

use std::path::PathBuf;

use anyhow::{Result, bail};
use keycomp::Profile;
use keycomp::collection::{areas_of, unit_from_areas};
use keycomp_bench::retrieval::d2::D2Params;
use keycomp_bench::retrieval::fpfh::FpfhParams;
use keycomp_bench::retrieval::labels::{
    DEFAULT_CLASS_REGEX, Truth, classes_from_csv, classes_from_names, truth_from_csv,
};
use keycomp_describe::{DescribeParams, Units};
use keycomp_fragment::PartialKind;
use keycomp_retrieval::MatchParams;

use super::args::{Args, Queries, detect_args, list_meshes, stem, sub_seed};
use crate::args::DetectArgs;

/// What a run measures and with which parameters.
pub(super) struct Setup {
    /// The partial query kinds, sorted.
    pub(super) kinds: Vec<PartialKind>,
    /// The collection's files, sorted by path.
    pub(super) files: Vec<PathBuf>,
    /// Each file's class.
    pub(super) classes: Vec<String>,
    /// Each file's stem.
    pub(super) names: Vec<String>,
    /// The external queries and their sources (`--queries DIR --truth CSV`).
    pub(super) external: Option<Vec<Truth>>,
    /// Detection options as `index add` parses them.
    pub(super) detect: DetectArgs,
    /// Detection, description and surface of key-components.
    pub(super) params: Profile,
    /// The matching's parameters.
    pub(super) match_params: MatchParams,
    /// The D2 baseline's.
    pub(super) d2_params: D2Params,
    /// The FPFH baselines'.
    pub(super) fpfh_params: FpfhParams,
}

impl Setup {
    /// The settings `args` ask for, checked.
    pub(super) fn new(args: &Args) -> Result<Setup> {
        let kinds: Vec<PartialKind> = if args.partial.is_empty() {
            PartialKind::ALL.to_vec()
        } else if args.partial.iter().any(|k| k == "none") {
            if args.partial.len() > 1 {
                bail!("--partial none cannot be combined with other kinds");
            }
            Vec::new()
        } else {
            let mut k: Vec<PartialKind> = args
                .partial
                .iter()
                .map(|s| s.parse::<PartialKind>().map_err(anyhow::Error::msg))
                .collect::<Result<_>>()?;
            k.sort();
            k.dedup();
            k
        };
        if args.d2_pairs == 0 {
            bail!("--d2-pairs must be at least 1");
        }
        let files = list_meshes(&args.collection, "--collection")?;
        if files.len() < 2 {
            bail!(
                "{}: found {} mesh, scan or point-cloud file(s) (.off, .obj, .ply, .stl, .gltf, .glb, .xyz, .pts, .pcd); retrieval needs at least 2",
                args.collection.display(),
                files.len()
            );
        }
        let classes = match (&args.labels, &args.class_from_name) {
            (Some(csv), _) => classes_from_csv(&files, &args.collection, csv)?,
            (None, Some(re)) => classes_from_names(&files, re)?,
            (None, None) => classes_from_names(&files, DEFAULT_CLASS_REGEX)?,
        };
        let external = match (&args.queries, &args.truth) {
            (Some(Queries::Folder(dir)), Some(csv)) => {
                let queries = list_meshes(dir, "--queries")?;
                Some(truth_from_csv(
                    &queries,
                    dir,
                    &files,
                    &args.collection,
                    csv,
                )?)
            }
            (Some(Queries::Folder(dir)), None) => bail!(
                "--queries {}: external queries need --truth CSV (lines query,source[,class])",
                dir.display()
            ),
            (_, Some(_)) => bail!("--truth goes with --queries DIR (a folder of query files)"),
            _ => None,
        };
        let names: Vec<String> = files.iter().map(|f| stem(f)).collect();
        let detect = detect_args(args.detect.as_deref())?;
        // exactly what `keycomp index add` uses with these options
        let mut describe = DescribeParams::default();
        if args.units == "file" {
            describe.units = Units::File {
                length: unit_from_areas(areas_of(&files))?,
            };
        }
        if let Some(l) = &args.levels {
            describe.levels = if l.trim() == "none" {
                Vec::new()
            } else {
                l.split(',')
                    .map(|x| x.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| {
                        anyhow::anyhow!(
                            "--levels: expected radii like 0.1,0.2 or 'none', got '{l}'"
                        )
                    })?
            };
        }
        if let Some(p) = args.patches {
            describe.patches_per_level = p;
        }
        describe.whole = !args.no_whole;
        if let Some(r) = &args.layout_reach {
            describe.layout_reach = if r.trim() == "none" {
                None
            } else {
                match r.trim().parse::<f64>() {
                    Ok(x) if x.is_finite() && x > 0.0 => Some(x),
                    _ => bail!("--layout-reach: expected a positive length or 'none', got '{r}'"),
                }
            };
        }
        if let Some(n) = args.describe_vertices {
            describe.proxy_vertices = n;
        }
        describe.complete_only = args.complete_only;
        let mut match_params = MatchParams {
            idf: args.idf,
            file_units: matches!(describe.units, keycomp_describe::Units::File { .. }),
            ..MatchParams::default()
        };
        if let Some(t) = args.area_tolerance {
            match_params.area_tolerance = t;
        }
        if let Some(t) = args.layout_tolerance {
            match_params.layout_tolerance = t;
        }
        if let Some(d) = args.max_distance {
            match_params.max_distance = d;
        }
        if let Some(w) = args.pose_weight {
            match_params.pose_weight = w;
        }
        if let Some(t) = args.pose_tolerance {
            if !(t.is_finite() && t >= 1.0) {
                bail!("--pose-tolerance: expected a factor ≥ 1, got {t}");
            }
            match_params.pose_tolerance = t;
        }
        if let Some(d) = args.verify_tolerance {
            if !(d.is_finite() && d > 0.0) {
                bail!("--verify-tolerance: expected a positive distance, got {d}");
            }
            match_params.verify_tolerance = d;
        }
        if !(match_params.layout_tolerance.is_finite() && match_params.layout_tolerance >= 1.0) {
            bail!(
                "--layout-tolerance: expected a factor ≥ 1, got {}",
                match_params.layout_tolerance
            );
        }
        if !(match_params.max_distance.is_finite() && match_params.max_distance > 0.0) {
            bail!(
                "--max-distance: expected a positive distance, got {}",
                match_params.max_distance
            );
        }
        if !(match_params.area_tolerance.is_finite() && match_params.area_tolerance >= 0.0) {
            bail!(
                "--area-tolerance: expected a factor ≥ 1, or 0 for no check, got {}",
                match_params.area_tolerance
            );
        }
        let surface = keycomp_surface::SurfaceParams {
            vertices: args
                .surface_vertices
                .unwrap_or(keycomp_surface::SurfaceParams::default().vertices),
            ..keycomp_surface::SurfaceParams::default()
        };
        surface.validate()?;
        let params = Profile::with(&detect.retrieval_params(), describe)
            .with_surface((args.surface == "canonical").then_some(surface));
        let d2_params = D2Params {
            pairs: args.d2_pairs,
            seed: sub_seed(args.seed, "d2", 0),
            ..D2Params::default()
        };
        let fpfh_params = FpfhParams {
            seed: sub_seed(args.seed, "fpfh", 0),
            ..FpfhParams::default()
        };
        Ok(Setup {
            kinds,
            files,
            classes,
            names,
            external,
            detect,
            params,
            match_params,
            d2_params,
            fpfh_params,
        })
    }
}
