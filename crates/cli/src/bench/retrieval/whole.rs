//! Whole-shape queries: every shape of the collection queried as `keycomp query` would analyse
//! it (a shape with a boundary is described as a fragment, `DescribeParams::for_query`; a
//! closed one's index record is its query record) and left out of its own ranking.

use anyhow::Result;
use keycomp::Role;
use keycomp_bench::retrieval::complete_ranking;
use keycomp_describe::DIM;
use keycomp_index::ShapeRecord;
use rayon::prelude::*;

use super::answer::{Setting, kc_ranking};
use super::args::sub_seed;
use super::results::{QueryResult, method_result};

/// The results of the whole-shape queries, in collection order; `records` are the
/// collection's index records.
pub(super) fn queries(s: &Setting<'_>, records: &[ShapeRecord<DIM>]) -> Result<Vec<QueryResult>> {
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
    let as_queries: Vec<Option<Vec<ShapeRecord<DIM>>>> = (0..n)
        .into_par_iter()
        .map(|i| -> Result<Option<Vec<ShapeRecord<DIM>>>> {
            let as_query = params
                .describe
                .for_query_with_boundary(records[i].boundary_vertices > 0);
            if as_query == [params.describe.clone()] {
                return Ok(None);
            }
            let hash = records[i].content_hash;
            Ok(Some(cache.records(&files[i], hash, params, Role::Query)?.0))
        })
        .collect::<Result<_>>()?;
    (0..n)
        .map(|i| -> Result<QueryResult> {
            let returned = kc_ranking(
                reader,
                as_queries[i]
                    .as_deref()
                    .unwrap_or(std::slice::from_ref(&records[i])),
                index_of,
                match_params,
                args.verify_weight,
                params.surface.is_some(),
            )?
            .order;
            let kc_order = complete_ranking(
                &returned,
                n,
                Some(i),
                sub_seed(args.seed, "whole", i as u64),
            );
            let nret = returned.iter().filter(|&&j| j != i).count();
            let by_baseline = baselines
                .iter()
                .map(|b| {
                    let order = b.ranking(&b.collection[i], Some(i));
                    let m = method_result(&order, n - 1, &classes[i], classes, names, None);
                    (b.key, m)
                })
                .collect();
            Ok(QueryResult {
                query: names[i].clone(),
                class: classes[i].clone(),
                source: None,
                target_fraction: None,
                fraction: None,
                cut: None,
                components: records[i].components.len(),
                error: None,
                key_components: method_result(&kc_order, nret, &classes[i], classes, names, None),
                baselines: by_baseline,
                random: method_result(
                    &complete_ranking(&[], n, Some(i), sub_seed(args.seed, "random", i as u64)),
                    0,
                    &classes[i],
                    classes,
                    names,
                    None,
                ),
            })
        })
        .collect::<Result<_>>()
}
