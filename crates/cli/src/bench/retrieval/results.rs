//! What a run measures: each query's ranking scored per method ([`MethodResult`]), the
//! summaries of a query set ([`QuerySet`]), and everything `results.json` holds ([`Results`]).

use std::collections::BTreeMap;

use keycomp_bench::retrieval::d2::D2Params;
use keycomp_bench::retrieval::fpfh::{FpfhParams, FpfhScale};
use keycomp_bench::retrieval::metrics::{QueryScores, Summary, score, summarize};
use keycomp_components::DetectParams;
use keycomp_describe::DescribeParams;
use keycomp_retrieval::MatchParams;
use serde::Serialize;

use super::repeatability::RepeatabilityRow;

/// A query's ranking scored for one method.
#[derive(Debug, Serialize)]
pub(super) struct MethodResult {
    /// Shapes the method returned before the random tail (every shape for a baseline).
    pub(super) returned: usize,
    /// 1-based rank of the source shape (partial queries).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) source_rank: Option<usize>,
    /// Whether the source shape is ranked ahead of every shape of another class (partial
    /// queries): with a score per shape, the source scores higher than any of them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) source_ahead: Option<bool>,
    /// Whether geometric verification measured the source shape (key-components' partial
    /// queries with verification on: the source reached the shortlist).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) source_verified: Option<bool>,
    /// The first five results (file stems).
    pub(super) top: Vec<String>,
    pub(super) nn: Option<f64>,
    pub(super) ft: Option<f64>,
    pub(super) st: Option<f64>,
    pub(super) e: Option<f64>,
    pub(super) dcg: Option<f64>,
    pub(super) ap: Option<f64>,
    #[serde(skip)]
    pub(super) scores: Option<QueryScores>,
}

#[derive(Debug, Serialize)]
pub(super) struct QueryResult {
    pub(super) query: String,
    pub(super) class: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) source: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) target_fraction: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) fraction: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) cut: Option<String>,
    /// Key-components of the query.
    pub(super) components: usize,
    /// Why the query has no key-component record (detection failed), if so.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) error: Option<String>,
    pub(super) key_components: MethodResult,
    /// One result per baseline, by [`super::baselines::Baseline::key`] (`d2`, `fpfh_bow`, `fpfh_bow_units`).
    #[serde(flatten)]
    pub(super) baselines: BTreeMap<&'static str, MethodResult>,
    /// A seeded random ranking, the chance level of every measure (summarised only).
    #[serde(skip)]
    pub(super) random: MethodResult,
}

impl QueryResult {
    /// The result of one method: key-components for `None`, else the baseline with that key.
    pub(super) fn method(&self, key: Option<&str>) -> &MethodResult {
        key.map_or(&self.key_components, |k| &self.baselines[k])
    }
}

#[derive(Debug, Serialize)]
pub(super) struct MethodSummary {
    #[serde(flatten)]
    pub(super) summary: Summary,
    /// Queries for which the method returned no shape (all ranks random; every query for the
    /// random ranking).
    pub(super) empty: usize,
    /// Mean 1-based rank of the source shape (partial queries).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) mean_source_rank: Option<f64>,
    /// Partial queries whose source shape is ranked first.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) source_first: Option<usize>,
    /// Partial queries whose source shape is among the first three.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) source_top3: Option<usize>,
    /// Partial queries whose source shape is ranked ahead of every shape of another class.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) source_ahead: Option<usize>,
    /// Partial queries whose source shape geometric verification measured (candidate recall;
    /// key-components only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) source_verified: Option<usize>,
}

#[derive(Debug, Serialize)]
pub(super) struct QuerySet {
    pub(super) name: String,
    pub(super) queries: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) mean_fraction: Option<f64>,
    pub(super) key_components: MethodSummary,
    /// One summary per baseline, by [`super::baselines::Baseline::key`].
    #[serde(flatten)]
    pub(super) baselines: BTreeMap<&'static str, MethodSummary>,
    /// A seeded random ranking of the same queries: the chance level.
    pub(super) random: MethodSummary,
    /// Every method on the queries key-components answer (return at least one shape for).
    pub(super) answered: Answered,
    pub(super) results: Vec<QueryResult>,
}

#[derive(Debug, Serialize)]
pub(super) struct Answered {
    pub(super) key_components: MethodSummary,
    #[serde(flatten)]
    pub(super) baselines: BTreeMap<&'static str, MethodSummary>,
}

#[derive(Debug, Serialize)]
pub(super) struct Results {
    pub(super) collection: String,
    pub(super) shapes: usize,
    pub(super) classes: BTreeMap<String, usize>,
    pub(super) seed: u64,
    pub(super) fraction_range: (f64, f64),
    pub(super) detect_params: DetectParams,
    pub(super) describe_params: DescribeParams,
    pub(super) match_params: MatchParams,
    /// Geometric verification's weight as given (`--verify-weight`); `None`: automatic, by
    /// whether the query has a boundary (`keycomp_retrieval::verify_weight_for`).
    pub(super) verify_weight: Option<f64>,
    pub(super) d2_params: D2Params,
    pub(super) fpfh_params: FpfhParams,
    /// The radius rule of each FPFH baseline (for "FPFH BoW units", the collection's median
    /// surface area in file units squared).
    pub(super) fpfh_scales: BTreeMap<&'static str, FpfhScale>,
    /// Collection shapes without key-components (never returned by key-component queries).
    pub(super) shapes_without_components: Vec<String>,
    pub(super) components_per_shape: f64,
    pub(super) query_sets: Vec<QuerySet>,
    /// Partial repeatability per query kind and third of the kept-area range (with
    /// `--repeatability`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub(super) partial_repeatability: Vec<RepeatabilityRow>,
}

/// Scores one ranking (`order` of collection indices) for a query of `class`.
pub(super) fn method_result(
    order: &[usize],
    returned: usize,
    class: &str,
    classes: &[String],
    names: &[String],
    source: Option<usize>,
) -> MethodResult {
    let rel: Vec<bool> = order.iter().map(|&j| classes[j] == class).collect();
    let scores = score(&rel);
    MethodResult {
        returned,
        source_rank: source.and_then(|s| order.iter().position(|&j| j == s).map(|p| p + 1)),
        source_ahead: source.map(|s| {
            let at = order.iter().position(|&j| j == s).unwrap_or(usize::MAX);
            let other = order
                .iter()
                .position(|&j| classes[j] != class)
                .unwrap_or(usize::MAX);
            at < other
        }),
        source_verified: None,
        top: order.iter().take(5).map(|&j| names[j].clone()).collect(),
        nn: scores.as_ref().map(|s| s.nn),
        ft: scores.as_ref().map(|s| s.ft),
        st: scores.as_ref().map(|s| s.st),
        e: scores.as_ref().map(|s| s.e),
        dcg: scores.as_ref().map(|s| s.dcg),
        ap: scores.as_ref().map(|s| s.ap),
        scores,
    }
}

pub(super) fn summarize_method(
    results: &[&QueryResult],
    pick: impl Fn(&QueryResult) -> &MethodResult,
) -> MethodSummary {
    let scores: Vec<Option<QueryScores>> = results.iter().map(|r| pick(r).scores.clone()).collect();
    let classes: Vec<&str> = results.iter().map(|r| r.class.as_str()).collect();
    let ranks: Vec<usize> = results.iter().filter_map(|r| pick(r).source_rank).collect();
    MethodSummary {
        summary: summarize(&scores, &classes),
        empty: results.iter().filter(|r| pick(r).returned == 0).count(),
        mean_source_rank: (!ranks.is_empty())
            .then(|| ranks.iter().sum::<usize>() as f64 / ranks.len() as f64),
        source_first: (!ranks.is_empty()).then(|| ranks.iter().filter(|&&r| r == 1).count()),
        source_top3: (!ranks.is_empty()).then(|| ranks.iter().filter(|&&r| r <= 3).count()),
        source_ahead: (!ranks.is_empty()).then(|| {
            results
                .iter()
                .filter(|r| pick(r).source_ahead == Some(true))
                .count()
        }),
        source_verified: results
            .iter()
            .any(|r| pick(r).source_verified.is_some())
            .then(|| {
                results
                    .iter()
                    .filter(|r| pick(r).source_verified == Some(true))
                    .count()
            }),
    }
}

/// The summaries of one query set; `methods` are the baselines' (label, key) pairs.
pub(super) fn query_set(
    name: &str,
    results: Vec<QueryResult>,
    methods: &[(&str, &'static str)],
) -> QuerySet {
    let fr: Vec<f64> = results.iter().filter_map(|r| r.fraction).collect();
    let all: Vec<&QueryResult> = results.iter().collect();
    let answered: Vec<&QueryResult> = results
        .iter()
        .filter(|r| r.key_components.returned > 0)
        .collect();
    let per_baseline = |rs: &[&QueryResult]| -> BTreeMap<&'static str, MethodSummary> {
        methods
            .iter()
            .map(|&(_, key)| (key, summarize_method(rs, |r| &r.baselines[key])))
            .collect()
    };
    QuerySet {
        name: name.to_string(),
        queries: results.len(),
        mean_fraction: (!fr.is_empty()).then(|| fr.iter().sum::<f64>() / fr.len() as f64),
        key_components: summarize_method(&all, |r| &r.key_components),
        baselines: per_baseline(&all),
        random: summarize_method(&all, |r| &r.random),
        answered: Answered {
            key_components: summarize_method(&answered, |r| &r.key_components),
            baselines: per_baseline(&answered),
        },
        results,
    }
}
