//! The baselines key-components are measured against: a descriptor per mesh and a distance
//! (D2, Osada et al. 2002; FPFH bags of words, Rusu et al. 2009), fitted on the collection
//! before any query.

use std::path::PathBuf;

use anyhow::{Context, Result};
use keycomp_bench::retrieval::d2::{D2Params, d2, l1};
use keycomp_bench::retrieval::fpfh::{
    BagOfWords, FpfhParams, FpfhScale, OrientedPoints, cosine_distance, features_of,
};
use keycomp_bench::retrieval::rank_by_distance;
use keycomp_mesh::Mesh;
use rayon::prelude::*;

/// How a [`Baseline`] describes a mesh.
pub(super) type Describe = Box<dyn Fn(&Mesh) -> Result<Vec<f64>> + Send + Sync>;

/// A baseline method: one descriptor per mesh and a distance between two descriptors (smaller
/// is more alike). Key-components are not one: they go through the product's index and ranking.
pub(super) struct Baseline {
    /// Row label in the tables and curve label in the PR plots.
    pub(super) label: &'static str,
    /// Key in `results.json`.
    pub(super) key: &'static str,
    /// Descriptors of the collection's shapes, in collection order.
    pub(super) collection: Vec<Vec<f64>>,
    /// The descriptor of another mesh (a fragment).
    pub(super) describe: Describe,
    /// The distance between two descriptors.
    pub(super) distance: fn(&[f64], &[f64]) -> f64,
}

impl Baseline {
    /// The collection from nearest to farthest from `query` (ties by index), without `exclude`.
    pub(super) fn ranking(&self, query: &[f64], exclude: Option<usize>) -> Vec<usize> {
        let d: Vec<f64> = self
            .collection
            .iter()
            .map(|c| (self.distance)(query, c))
            .collect();
        rank_by_distance(&d, exclude)
    }
}

/// The FPFH bag-of-words baseline at one radius rule: a codebook and idf fitted on the
/// collection's points (sampled once, `points[i]` for shape `i`), the collection's tf-idf
/// vectors, and the description of other meshes with the same model.
pub(super) fn fpfh_baseline(
    label: &'static str,
    key: &'static str,
    points: &[OrientedPoints],
    files: &[PathBuf],
    params: &FpfhParams,
    scale: FpfhScale,
) -> Result<Baseline> {
    let features: Vec<_> = points
        .par_iter()
        .zip(files)
        .map(|(p, f)| {
            features_of(p, params, scale).with_context(|| format!("{}: {label}", f.display()))
        })
        .collect::<Result<_>>()?;
    let (model, collection) = BagOfWords::fit(&features, params, scale)
        .with_context(|| format!("{label}: cannot fit the codebook"))?;
    Ok(Baseline {
        label,
        key,
        collection,
        describe: Box::new(move |m: &Mesh| Ok(model.describe(m)?)),
        distance: cosine_distance,
    })
}

/// Each FPFH baseline's row label, key in `results.json` and radius rule.
pub(super) type FpfhScales = [(&'static str, &'static str, FpfhScale); 2];

/// The baselines fitted on the collection (none with `--no-baselines`): D2 on `hists`, and
/// FPFH bags of words at both radius rules on `points` (dropped once fitted); also each FPFH
/// baseline's (label, key, radius rule).
pub(super) fn fit(
    no_baselines: bool,
    files: &[PathBuf],
    hists: Vec<Vec<f64>>,
    points: Vec<OrientedPoints>,
    d2_params: D2Params,
    fpfh_params: &FpfhParams,
) -> Result<(Vec<Baseline>, FpfhScales)> {
    let areas: Vec<f64> = points.iter().map(|p| p.area).collect();
    let fpfh_scales = [
        ("FPFH BoW", "fpfh_bow", FpfhScale::ScaleFree),
        (
            "FPFH BoW units",
            "fpfh_bow_units",
            FpfhScale::file_units(&areas),
        ),
    ];
    let mut baselines = Vec::new();
    if !no_baselines {
        baselines.push(Baseline {
            label: "D2",
            key: "d2",
            collection: hists,
            describe: Box::new(move |m: &Mesh| Ok(d2(m, &d2_params)?)),
            distance: l1,
        });
    }
    for (label, key, scale) in fpfh_scales.into_iter().filter(|_| !no_baselines) {
        baselines.push(fpfh_baseline(
            label,
            key,
            &points,
            files,
            fpfh_params,
            scale,
        )?);
    }
    drop(points);
    Ok((baselines, fpfh_scales))
}
