//! A query's key-component answer: its records ranked as `keycomp query` ranks them, over the
//! run's fresh index, and the [`Setting`] every query set is measured in.

use std::collections::HashMap;
use std::path::PathBuf;

use anyhow::Result;
use keycomp::Profile;
use keycomp::collection::Reader;
use keycomp_describe::DIM;
use keycomp_index::ShapeRecord;
use keycomp_retrieval::{MatchParams, rank_hypotheses};

use super::args::Args;
use super::baselines::Baseline;
use super::cache::RecordCache;
use crate::output;

/// What the queries are measured against: the run's options, its cache, the collection's
/// index and the baselines.
#[derive(Clone, Copy)]
pub(super) struct Setting<'a> {
    pub(super) args: &'a Args,
    pub(super) cache: &'a RecordCache,
    pub(super) params: &'a Profile,
    pub(super) reader: &'a Reader,
    pub(super) index_of: &'a HashMap<PathBuf, usize>,
    pub(super) match_params: &'a MatchParams,
    pub(super) baselines: &'a [Baseline],
    pub(super) classes: &'a [String],
    pub(super) names: &'a [String],
    pub(super) files: &'a [PathBuf],
}

/// A query's key-component ranking: collection indices, best first, and those among them
/// that geometric verification measured (the shortlist: candidate recall is whether the
/// source is among them).
#[derive(Debug, Clone, Default)]
pub(super) struct KcRanking {
    pub(super) order: Vec<usize>,
    pub(super) verified: Vec<usize>,
}

/// Key-component ranking of the collection for one query, its records one per scale
/// hypothesis.
pub(super) fn kc_ranking(
    reader: &Reader,
    records: &[ShapeRecord<DIM>],
    index_of: &HashMap<PathBuf, usize>,
    match_params: &MatchParams,
    verify: Option<f64>,
    canonical: bool,
) -> Result<KcRanking> {
    let Some(record) = records.first() else {
        return Ok(KcRanking::default());
    };
    let match_params = &MatchParams {
        verify_weight: keycomp_retrieval::verify_weight_for(
            record.boundary_vertices as usize,
            match_params.file_units || canonical,
            verify,
        ),
        verify_search: keycomp_retrieval::verify_search_for(canonical),
        ..*match_params
    };
    if record.components.is_empty() {
        return Ok(KcRanking::default());
    }
    let parts: Vec<_> = records
        .iter()
        .map(|r| {
            (
                r.components
                    .iter()
                    .map(|c| c.descriptor)
                    .collect::<Vec<_>>(),
                keycomp_retrieval::record_areas(r, match_params),
                keycomp_retrieval::record_centres(r, match_params),
            )
        })
        .collect();
    let views: Vec<_> = records
        .iter()
        .zip(&parts)
        .map(
            |(r, (descs, areas, centres))| keycomp_retrieval::ShapeView {
                descriptors: descs,
                layout: &r.layout,
                areas,
                centres,
                sample: keycomp_retrieval::record_sample(r, match_params),
            },
        )
        .collect();
    let ranked = rank_hypotheses(reader, &views, index_of.len(), match_params)?;
    let at = |r: &keycomp_retrieval::Ranked| index_of.get(&r.path).copied();
    Ok(KcRanking {
        order: ranked.iter().filter_map(at).collect(),
        verified: ranked
            .iter()
            .filter(|r| r.result.verified.is_some())
            .filter_map(at)
            .collect(),
    })
}

/// A query's key-component answer: the shapes ranked ([`kc_ranking`]), its component count
/// and, when it could not be analysed (detection may fail on a fragment or a scan), why; its
/// ranking is then empty (random).
pub(super) fn kc_answer(
    rec: &Result<Vec<ShapeRecord<DIM>>>,
    reader: &Reader,
    index_of: &HashMap<PathBuf, usize>,
    match_params: &MatchParams,
    verify: Option<f64>,
    canonical: bool,
) -> Result<(KcRanking, usize, Option<String>)> {
    Ok(match rec {
        Ok(r) => (
            kc_ranking(reader, r, index_of, match_params, verify, canonical)?,
            r.first().map_or(0, |r| r.components.len()),
            None,
        ),
        Err(e) => (KcRanking::default(), 0, Some(output::error_chain(e))),
    })
}
