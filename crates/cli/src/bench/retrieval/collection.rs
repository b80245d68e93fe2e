//! The collection: every shape's index record (through the cache, as `keycomp index add`
//! analyses it) and the baselines' raw material (D2 histograms, FPFH points), then a fresh
//! on-disk index of the records in `OUT/index`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use keycomp::collection::Reader;
use keycomp::{Profile, Role};
use keycomp_bench::retrieval::d2::{D2Params, d2};
use keycomp_bench::retrieval::fpfh::{FpfhParams, OrientedPoints, sample_oriented};
use keycomp_describe::DIM;
use keycomp_index::{ContentHash, ShapeRecord};
use keycomp_mesh::read_mesh;
use rayon::prelude::*;

use super::cache::RecordCache;
use crate::progress::{open_writer, progress};

/// The collection analysed, in file order.
pub(super) struct Collection {
    /// Index records.
    pub(super) records: Vec<ShapeRecord<DIM>>,
    /// D2 histograms (empty without baselines).
    pub(super) hists: Vec<Vec<f64>>,
    /// Points sampled for FPFH (empty without baselines).
    pub(super) points: Vec<OrientedPoints>,
    /// Records found in the cache.
    pub(super) hits: usize,
}

/// Analyses every file of the collection (records from `cache`; with `baselines`, D2 and FPFH
/// samples too).
pub(super) fn analyse(
    files: &[PathBuf],
    params: &Profile,
    cache: &RecordCache,
    baselines: bool,
    d2_params: &D2Params,
    fpfh_params: &FpfhParams,
) -> Result<Collection> {
    let n = files.len();
    let bar = progress(n as u64, "collection");
    let analysed: Vec<Result<_>> = files
        .par_iter()
        .map(|p| {
            let r = (|| {
                let hash = ContentHash::of_file(p)?;
                let (recs, hit) = cache.records(p, hash, params, Role::Indexed)?;
                let rec = recs.into_iter().next().context("no record")?;
                if !baselines {
                    return Ok((rec, hit, None));
                }
                let mesh = read_mesh(p)?.mesh;
                let h = d2(&mesh, d2_params).with_context(|| format!("{}: D2", p.display()))?;
                let pts = sample_oriented(&mesh, fpfh_params)
                    .with_context(|| format!("{}: FPFH", p.display()))?;
                Ok((rec, hit, Some((h, pts))))
            })();
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    let mut records = Vec::with_capacity(n);
    let mut hists = Vec::with_capacity(n);
    let mut points = Vec::with_capacity(n);
    let mut hits = 0;
    for (p, r) in files.iter().zip(analysed) {
        let (rec, hit, baseline) = r.with_context(|| format!("{}: cannot analyse", p.display()))?;
        hits += usize::from(hit);
        records.push(rec);
        if let Some((h, pts)) = baseline {
            hists.push(h);
            points.push(pts);
        }
    }
    Ok(Collection {
        records,
        hists,
        points,
        hits,
    })
}

/// Writes `records` as a fresh index in `out/index` (built aside, then renamed over an earlier
/// one) and opens it; also returns each indexed path's position in `files`.
pub(super) fn fresh_index(
    out: &Path,
    params: &Profile,
    records: &[ShapeRecord<DIM>],
    files: &[PathBuf],
) -> Result<(Reader, HashMap<PathBuf, usize>)> {
    let n = files.len();
    let index_dir = out.join("index");
    keycomp::folders::replace_folder(&index_dir, |tmp| -> Result<()> {
        let mut w = open_writer(tmp, params)?;
        w.add_batch(records.to_vec())?;
        Ok(())
    })?;
    let reader = Reader::open(&index_dir)?;
    let index_of: HashMap<PathBuf, usize> = reader
        .shapes()?
        .iter()
        .filter_map(|s| {
            files
                .iter()
                .position(|f| *f == s.record.path)
                .map(|i| (s.record.path.clone(), i))
        })
        .collect();
    if index_of.len() != n {
        bail!(
            "{}: the index holds {} of the {n} shapes (two files with the same canonical path?)",
            index_dir.display(),
            index_of.len()
        );
    }

    Ok((reader, index_of))
}
