//! Partial queries: fragments cut from the collection's shapes (a geodesic ball, a plane cut,
//! a simulated range-scan view), written to `OUT/fragments` and queried as `keycomp query`
//! queries a file; with `--repeatability`, how well each fragment's own parts repeat its
//! source's.

use std::collections::BTreeMap;
use std::fs;
use std::path::PathBuf;

use anyhow::{Context, Result};
use keycomp::Role;
use keycomp_bench::retrieval::complete_ranking;
use keycomp_describe::DIM;
use keycomp_fragment::{PartialKind, cut_fragment};
use keycomp_index::{ContentHash, ShapeRecord};
use keycomp_mesh::read_mesh;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::answer::{Setting, kc_answer};
use super::args::{Queries, stem, sub_seed};
use super::repeatability::{Repeatability, partial_repeatability};
use super::results::{MethodResult, QueryResult, method_result};
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
        let (ranking, components, error) = kc_answer(
            &rec,
            reader,
            index_of,
            match_params,
            args.verify_weight,
            params.surface.is_some(),
        )?;
        let returned = &ranking.order;
        let kc_order = complete_ranking(
            returned,
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
            key_components: MethodResult {
                source_verified: Some(ranking.verified.contains(&src)),
                ..method_result(&kc_order, returned.len(), class, classes, names, Some(src))
            },
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
