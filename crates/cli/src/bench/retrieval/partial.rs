//! Partial queries: fragments cut from the collection's shapes (a geodesic ball, a plane cut,
//! a simulated range-scan view), written to `OUT/fragments` and queried as `keycomp query`
//! queries a file; with `--repeatability`, how well each fragment's own parts repeat its
//! source's.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use keycomp::{Profile, Role, analyse};
use keycomp_bench::retrieval::complete_ranking;
use keycomp_describe::DIM;
use keycomp_fragment::{PartialKind, cut_fragment};
use keycomp_index::{ContentHash, ShapeRecord};
use keycomp_mesh::read_mesh;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use super::answer::{Setting, kc_answer};
use super::results::{QueryResult, method_result};
use super::{Queries, stem, sub_seed};
use crate::progress::progress;

/// The partial queries' results by kind, and each fragment's repeatability (with
/// `--repeatability`) with its kind and kept area.
pub(super) type Partial = (
    BTreeMap<PartialKind, Vec<QueryResult>>,
    Vec<(&'static str, f64, Repeatability)>,
);

/// Cuts `args.queries` fragments of each of `kinds` (one per shape by default) and queries
/// them; the fragments of an earlier run are removed first.
pub(super) fn queries(s: &Setting<'_>, kinds: &[PartialKind]) -> Result<Partial> {
    let Setting {
        args,
        cache,
        params,
        reader,
        index_of,
        match_params,
        baselines,
        classes,
        names,
        files,
    } = *s;
    let n = files.len();
    let per_kind = match &args.queries {
        Some(Queries::PerKind(k)) => *k,
        _ => n,
    };
    let mut sources: Vec<usize> = (0..n).collect();
    sources.shuffle(&mut ChaCha8Rng::seed_from_u64(sub_seed(
        args.seed, "sources", 0,
    )));
    let frag_dir = args.out.join("fragments");
    // fragments of an earlier run (perhaps with other options) would be mistaken for this one's
    if frag_dir.exists() {
        fs::remove_dir_all(&frag_dir)
            .with_context(|| format!("{}: cannot clear", frag_dir.display()))?;
    }
    if !kinds.is_empty() && per_kind > 0 {
        fs::create_dir_all(&frag_dir)
            .with_context(|| format!("{}: cannot create", frag_dir.display()))?;
    }
    let jobs: Vec<(PartialKind, usize)> = kinds
        .iter()
        .flat_map(|&k| (0..per_kind).map(move |q| (k, q)))
        .collect();
    let bar = progress(jobs.len() as u64, "partial queries");
    let mut repeatability: Vec<(&'static str, f64, Repeatability)> = Vec::new();
    type Fragment = (
        usize,
        f64,
        f64,
        String,
        Result<Vec<ShapeRecord<DIM>>>,
        Vec<Vec<f64>>,
        PathBuf,
        Option<Repeatability>,
    );
    let fragments: Vec<Result<Fragment>> = jobs
        .par_iter()
        .map(|&(kind, q)| {
            let r = (|| -> Result<Fragment> {
                let src = sources[q % n];
                let mut rng = ChaCha8Rng::seed_from_u64(sub_seed(args.seed, kind.name(), q as u64));
                let target = rng.random_range(args.area.0..=args.area.1);
                let mesh = read_mesh(&files[src])?.mesh;
                let frag = cut_fragment(&mesh, kind, target, &mut rng).with_context(|| {
                    format!("{}: cannot cut a {kind} fragment", files[src].display())
                })?;
                let path = frag_dir.join(format!("{kind}-{q:03}-{}.off", names[src]));
                keycomp_mesh::write_off(&frag.mesh, &path)?;
                let descriptors = baselines
                    .iter()
                    .map(|b| {
                        (b.describe)(&frag.mesh)
                            .with_context(|| format!("{}: {}", path.display(), b.label))
                    })
                    .collect::<Result<_>>()?;
                // detection may legitimately fail on a fragment: the query then has no
                // key-components (its ranking is random), which is reported
                let rec = ContentHash::of_file(&path)
                    .map_err(anyhow::Error::from)
                    .and_then(|hash| {
                        cache
                            .records(&path, hash, params, Role::Query)
                            .map(|(r, _)| r)
                    });
                let rep = if args.repeatability {
                    Some(partial_repeatability(
                        &files[src],
                        &path,
                        &frag.original,
                        params,
                    )?)
                } else {
                    None
                };
                Ok((
                    src,
                    target,
                    frag.fraction,
                    frag.detail,
                    rec,
                    descriptors,
                    path,
                    rep,
                ))
            })();
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    let mut by_kind: BTreeMap<PartialKind, Vec<QueryResult>> = BTreeMap::new();
    for ((kind, q), f) in jobs.iter().zip(fragments) {
        let (src, target, fraction, detail, rec, descriptors, path, rep) = f?;
        if let Some(r) = rep {
            repeatability.push((kind.name(), fraction, r));
        }
        let (returned, components, error) = kc_answer(
            &rec,
            reader,
            index_of,
            match_params,
            args.verify_weight,
            params.surface.is_some(),
        )?;
        let kc_order = complete_ranking(
            &returned,
            n,
            None,
            sub_seed(args.seed, &format!("{kind}-tail"), *q as u64),
        );
        let class: &str = &classes[src];
        let by_baseline = baselines
            .iter()
            .zip(&descriptors)
            .map(|(b, d)| {
                let order = b.ranking(d, None);
                let m = method_result(&order, n, class, classes, names, Some(src));
                (b.key, m)
            })
            .collect();
        by_kind.entry(*kind).or_default().push(QueryResult {
            query: stem(&path),
            class: class.to_string(),
            source: Some(names[src].clone()),
            target_fraction: Some(target),
            fraction: Some(fraction),
            cut: Some(detail),
            components,
            error,
            key_components: method_result(
                &kc_order,
                returned.len(),
                class,
                classes,
                names,
                Some(src),
            ),
            baselines: by_baseline,
            random: method_result(
                &complete_ranking(
                    &[],
                    n,
                    None,
                    sub_seed(args.seed, &format!("{kind}-random"), *q as u64),
                ),
                0,
                class,
                classes,
                names,
                Some(src),
            ),
        });
    }
    Ok((by_kind, repeatability))
}

/// One row of the partial-repeatability table: the parts of every fragment of one kind and
/// kept-area bin pooled (see [`Repeatability`]).
#[derive(Debug, Serialize)]
pub(super) struct RepeatabilityRow {
    pub(super) kind: &'static str,
    pub(super) area: (f64, f64),
    pub(super) fragments: usize,
    pub(super) kc_parts: usize,
    pub(super) kc_overlap: f64,
    pub(super) patch_parts: usize,
    pub(super) patch_overlap: f64,
}

pub(super) fn repeatability_rows(
    all: &[(&'static str, f64, Repeatability)],
    range: (f64, f64),
) -> Vec<RepeatabilityRow> {
    let mut rows = Vec::new();
    let kinds: Vec<&'static str> = {
        let mut k: Vec<_> = all.iter().map(|r| r.0).collect();
        k.dedup();
        k
    };
    let step = (range.1 - range.0) / 3.0;
    for kind in kinds {
        for b in 0..3 {
            let lo = range.0 + step * b as f64;
            let hi = if b == 2 { f64::INFINITY } else { lo + step };
            let lo = if b == 0 { f64::NEG_INFINITY } else { lo };
            let sel: Vec<&Repeatability> = all
                .iter()
                .filter(|r| r.0 == kind && r.1 >= lo && r.1 < hi)
                .map(|r| &r.2)
                .collect();
            if sel.is_empty() {
                continue;
            }
            let kc_parts: usize = sel.iter().map(|r| r.kc_parts).sum();
            let patch_parts: usize = sel.iter().map(|r| r.patch_parts).sum();
            let pooled = |f: &dyn Fn(&Repeatability) -> f64, n: usize| {
                if n > 0 {
                    sel.iter().map(|r| f(r)).sum::<f64>() / n as f64
                } else {
                    0.0
                }
            };
            rows.push(RepeatabilityRow {
                kind,
                area: (range.0 + step * b as f64, range.0 + step * (b + 1) as f64),
                fragments: sel.len(),
                kc_parts,
                kc_overlap: pooled(&|r| r.kc_overlap * r.kc_parts as f64, kc_parts),
                patch_parts,
                patch_overlap: pooled(&|r| r.patch_overlap * r.patch_parts as f64, patch_parts),
            });
        }
    }
    rows
}

/// Partial repeatability of one fragment: for key-components (level 0) and for patches (levels
/// 1 to L, the whole surface left out), the source's parts with at least half of their area inside the fragment, and the
/// mean over them of the best overlap (area IoU on the fragment, as in the repeatability
/// benchmark) between the part restricted to the fragment and a part the fragment's own
/// analysis finds (of the same kind: key-component or patch, any level).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub(super) struct Repeatability {
    pub(super) kc_overlap: f64,
    pub(super) kc_parts: usize,
    pub(super) patch_overlap: f64,
    pub(super) patch_parts: usize,
}

pub(super) fn partial_repeatability(
    source: &Path,
    fragment: &Path,
    original: &[u32],
    profile: &Profile,
) -> Result<Repeatability> {
    let s = analyse(source, profile)?;
    let f = keycomp::analyse_as(fragment, profile, Role::Query)?;
    let src_areas = keycomp_mesh::geometry::vertex_areas(&s.mesh);
    let frag_areas = keycomp_mesh::geometry::vertex_areas(&f.mesh);
    let mut to_frag = vec![u32::MAX; s.mesh.num_vertices()];
    for (i, &o) in original.iter().enumerate() {
        if let Some(t) = to_frag.get_mut(o as usize) {
            *t = i as u32;
        }
    }
    // key-components are level 0, patches levels 1..=L; the whole surface (L + 1) is neither
    let whole = profile.describe.levels.len() + 1;
    let in_group = move |c: &&keycomp_describe::ComponentDescription, patches: bool| {
        (c.level as usize) < whole && (c.level > 0) == patches
    };
    let group = |patches: bool| -> (f64, usize) {
        let mine: Vec<&[u32]> = f
            .description
            .components
            .iter()
            .filter(|c| in_group(c, patches))
            .map(|c| c.vertices.as_slice())
            .collect();
        let (mut sum, mut count) = (0.0, 0);
        for c in s
            .description
            .components
            .iter()
            .filter(|c| in_group(c, patches))
        {
            let total: f64 = c.vertices.iter().map(|&v| src_areas[v as usize]).sum();
            let inside: Vec<u32> = c
                .vertices
                .iter()
                .map(|&v| to_frag[v as usize])
                .filter(|&t| t != u32::MAX)
                .collect();
            let kept: f64 = c
                .vertices
                .iter()
                .filter(|&&v| to_frag[v as usize] != u32::MAX)
                .map(|&v| src_areas[v as usize])
                .sum();
            if total <= 0.0 || kept < 0.5 * total {
                continue;
            }
            let best = mine
                .iter()
                .map(|m| keycomp_bench::overlap(&frag_areas, &inside, m))
                .fold(0.0, f64::max);
            sum += best;
            count += 1;
        }
        (if count > 0 { sum / count as f64 } else { 0.0 }, count)
    };
    let (kc_overlap, kc_parts) = group(false);
    let (patch_overlap, patch_parts) = group(true);
    Ok(Repeatability {
        kc_overlap,
        kc_parts,
        patch_overlap,
        patch_parts,
    })
}
