//! External queries (`--queries DIR --truth CSV`): files from elsewhere (real range scans,
//! point clouds, meshes at another resolution), each named with its source shape.

use anyhow::{Context, Result};
use keycomp::Role;
use keycomp_bench::retrieval::complete_ranking;
use keycomp_bench::retrieval::labels::Truth;
use keycomp_index::ContentHash;
use rayon::prelude::*;

use super::answer::{Setting, kc_answer};
use super::args::sub_seed;
use super::results::{MethodResult, QueryResult, method_result};
use crate::progress::progress;

/// The results of the external queries, in the order of `truth`.
pub(super) fn queries(s: &Setting<'_>, truth: &[Truth]) -> Result<Vec<QueryResult>> {
    let bar = progress(truth.len() as u64, "external queries");
    let results: Vec<QueryResult> = truth
        .par_iter()
        .enumerate()
        .map(|(q, t)| {
            let r = external_query(t, q, s);
            bar.inc(1);
            r
        })
        .collect::<Result<_>>()?;
    bar.finish_and_clear();
    Ok(results)
}

/// One external query (the `q`-th line of --truth) ranked by key-components as `keycomp query`
/// ranks the file (a point cloud on its canonical surface, whatever the index's profile) and
/// by each baseline. The baselines need triangles: they describe the file's mesh (a range grid
/// triangulated), or a point cloud's canonical surface.
pub(super) fn external_query(t: &Truth, q: usize, s: &Setting<'_>) -> Result<QueryResult> {
    let n = s.names.len();
    let input = keycomp_mesh::read_input(&t.query)?;
    let points = matches!(input.geometry, keycomp_mesh::Geometry::Points(_));
    let descriptors: Vec<Vec<f64>> = if s.baselines.is_empty() {
        Vec::new()
    } else {
        let mesh = match input.geometry {
            keycomp_mesh::Geometry::Mesh(m) => m,
            g => {
                keycomp::analysis::canonical_surface(&g, &s.params.surface.unwrap_or_default())
                    .with_context(|| format!("{}: canonical surface", t.query.display()))?
                    .mesh
            }
        };
        s.baselines
            .iter()
            .map(|b| {
                (b.describe)(&mesh).with_context(|| format!("{}: {}", t.query.display(), b.label))
            })
            .collect::<Result<_>>()?
    };
    // detection may fail on a query: it then has no key-components (random ranking), reported
    let rec = ContentHash::of_file(&t.query)
        .map_err(anyhow::Error::from)
        .and_then(|hash| {
            s.cache
                .records(&t.query, hash, s.params, Role::Query)
                .map(|(r, _)| r)
        });
    let (ranking, components, error) = kc_answer(
        &rec,
        s.reader,
        s.index_of,
        s.match_params,
        s.args.verify_weight,
        s.params.surface.is_some() || points,
    )?;
    let src = t.source;
    let class = t.class.as_ref().unwrap_or(&s.classes[src]);
    let seed = s.args.seed;
    let result = |order: &[usize], returned: usize| {
        method_result(order, returned, class, s.classes, s.names, Some(src))
    };
    let by_baseline = s
        .baselines
        .iter()
        .zip(&descriptors)
        .map(|(b, d)| (b.key, result(&b.ranking(d, None), n)))
        .collect();
    Ok(QueryResult {
        query: t.query.display().to_string(),
        class: class.clone(),
        source: Some(s.names[src].clone()),
        target_fraction: None,
        fraction: None,
        cut: None,
        components,
        error,
        key_components: MethodResult {
            source_verified: Some(ranking.verified.contains(&src)),
            ..result(
                &complete_ranking(
                    &ranking.order,
                    n,
                    None,
                    sub_seed(seed, "external-tail", q as u64),
                ),
                ranking.order.len(),
            )
        },
        baselines: by_baseline,
        random: result(
            &complete_ranking(&[], n, None, sub_seed(seed, "external-random", q as u64)),
            0,
        ),
    })
}
