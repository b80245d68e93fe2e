//! Steps 6–7 of matching (crate documentation, *Steps*) after the checks: geometric
//! verification of the whole alignment ([`crate::verify`]), which keeps assigned pairs the
//! alignment brings together, then the score: the kept similarities weighted by their query
//! parts (and their pose factors) over the query's total weight, times the verification
//! factor. Also the two upper bounds of the score that ranking prunes candidates with
//! ([`score_bound`] from the distances alone, [`pairs_score`] of the assignment).
//!
//! Cost: O(k) for k kept pairs, plus verification's few milliseconds when it runs.

use serde::{Deserialize, Serialize};

use crate::assign::{ComponentMatch, part_weight, similarity, total_weight};
use crate::checks::{self, Assigned};
use crate::params::{MatchParams, unit_weight};
use crate::verify;
use crate::view::ShapeView;

/// The result of [`match_shapes`](crate::match_shapes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeMatch {
    /// Kept matches, ordered by query component.
    pub matches: Vec<ComponentMatch>,
    /// Score in [0, 1] (see the module documentation).
    pub score: f64,
    /// Estimated target/query length ratio, when three or more matches allowed an estimate.
    pub scale: Option<f64>,
    /// Matches dropped by the consistency check.
    pub rejected: usize,
    /// The pose check's agreement: of the pairs of kept matches it compared, the fraction
    /// whose straight-line distances agree; `None` when it compared none (off, no centres,
    /// or fewer than three matches).
    pub pose: Option<f64>,
    /// Geometric verification's fitness (see [`verify`]): the share of the query's surface
    /// sample on the target's surface once aligned, 0 when no alignment was found; `None`
    /// when it did not run (off, or a shape without sample or centres).
    #[serde(default)]
    pub verified: Option<f64>,
    /// The alignment verification found, from the query's frame (its parts' positions and
    /// sample) to the target's; `None` when it did not run or found none.
    #[serde(default)]
    pub alignment: Option<verify::Alignment>,
    /// Other distinct alignments verification's screening passed, best screened first:
    /// refinement on the full surfaces may tell them apart.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub alternatives: Vec<verify::Alignment>,
}

impl ShapeMatch {
    /// No match: no pair, score 0 (a shape without parts, or a candidate left unmatched).
    pub fn none() -> Self {
        ShapeMatch {
            matches: Vec::new(),
            score: 0.0,
            scale: None,
            rejected: 0,
            pose: None,
            verified: None,
            alignment: None,
            alternatives: Vec::new(),
        }
    }
}

/// Whether geometric verification runs for this pair of shapes: its weight is above 0 and
/// both give their parts' centres and a surface sample (shapes of older indexes have neither).
pub(crate) fn can_verify(query: &ShapeView, target: &ShapeView, params: &MatchParams) -> bool {
    unit_weight(params.verify_weight) > 0.0
        && !query.sample.is_empty()
        && !target.sample.is_empty()
        && !query.centres.is_empty()
        && !target.centres.is_empty()
}

/// The score of the pairs `matches` of a query of `mq` parts: their weighted similarities, match
/// `i` scaled by `pose[i]` (1 beyond `pose`), over the query's total weight (step 7 of *Steps*).
/// With every assigned pair ([`crate::assign::pair`]) and no factor, it bounds the score of the
/// whole match from above: the checks only drop pairs, and the pose check and verification only
/// scale the score down.
pub(crate) fn pairs_score(
    mq: usize,
    matches: &[ComponentMatch],
    pose: &[f64],
    params: &MatchParams,
    weights: &[f64],
) -> f64 {
    let total = total_weight(mq, weights);
    if total > 0.0 {
        matches
            .iter()
            .enumerate()
            .map(|(i, m)| {
                similarity(m.distance, params)
                    * part_weight(weights, m.query)
                    * pose.get(i).copied().unwrap_or(1.0)
            })
            .sum::<f64>()
            / total
    } else {
        0.0
    }
}

/// An upper bound of [`match_weighted`](crate::match_weighted)'s score from its distance matrix
/// `d`: the smaller of two sums, every query part counted with its best weighted similarity to any
/// target part, and every target part with its best weighted similarity to any query part (a
/// one-to-one assignment gives each part at most that, and the layout check only drops pairs).
pub(crate) fn score_bound(
    mq: usize,
    mt: usize,
    d: &[f32],
    params: &MatchParams,
    weights: &[f64],
) -> f64 {
    let weight_of = |i: usize| part_weight(weights, i);
    let total = total_weight(mq, weights);
    if total <= 0.0 || mt == 0 {
        return 0.0;
    }
    let sim = |dd: f32| similarity(dd, params);
    let rows: f64 = (0..mq)
        .map(|i| {
            let best = d[i * mt..(i + 1) * mt]
                .iter()
                .copied()
                .fold(f32::INFINITY, f32::min);
            sim(best) * weight_of(i)
        })
        .sum();
    let mut cols = vec![0f64; mt];
    for i in 0..mq {
        let w = weight_of(i);
        for (c, &dd) in cols.iter_mut().zip(&d[i * mt..(i + 1) * mt]) {
            *c = c.max(sim(dd) * w);
        }
    }
    rows.min(cols.iter().sum::<f64>()) / total
}

/// Steps 5–7 of matching (verification, the pose check, the score) after the assignment and
/// the layout and size checks ([`Assigned`]); `d` is the distance matrix
/// ([`crate::assign::distances`]).
pub(crate) fn finish(
    query: ShapeView,
    target: ShapeView,
    d: &[f32],
    params: &MatchParams,
    weights: &[f64],
    assigned: Assigned,
) -> ShapeMatch {
    let Assigned {
        mut matches,
        mut alive,
        mut rejected,
        scale,
    } = assigned;
    let mq = query.descriptors.len();
    let k0 = matches.len();
    // geometric verification: the query aligned onto the target by its parts' centres and
    // refined on their surfaces; assigned pairs that land together under that alignment are
    // kept too, whatever the layout check said. It runs only when both shapes have centres
    // and a sample (shapes of older indexes have neither and keep their score).
    let verifying = can_verify(&query, &target, params);
    let verified = if verifying {
        align(query, target, d, params)
    } else {
        None
    };
    if let Some(v) = &verified {
        rejected -= keep_aligned(query, target, &matches, &mut alive, v);
    }
    if alive.len() < k0 {
        let keep: Vec<ComponentMatch> = alive.iter().map(|&a| matches[a]).collect();
        matches = keep;
    }
    let (pose, agreement) = checks::pose(query, target, &matches, scale, params);
    let score = pairs_score(mq, &matches, &pose, params, weights);
    // a verification that found no alignment counts as fitness 0
    let fitness = verifying.then(|| verified.as_ref().map_or(0.0, |v| v.fitness));
    let score = score * verification_factor(fitness, params);
    ShapeMatch {
        verified: fitness,
        alignment: verified.as_ref().map(|v| v.alignment()),
        alternatives: verified.map(|v| v.alternatives()).unwrap_or_default(),
        pose: agreement,
        matches,
        score,
        scale,
        rejected,
    }
}

/// The alignments of `query` onto `target` as verification finds them (steps 1–3 of
/// [`verify`]; the best first, then its [`ShapeMatch::alternatives`]) and the best one's
/// fitness, whatever the verification weight: the pose of a query whose ranking did not verify
/// it (a closed shape). `None` when either view has no centres or sample, or no alignment is
/// found.
pub fn align_views(
    query: ShapeView,
    target: ShapeView,
    params: &MatchParams,
) -> Option<(Vec<verify::Alignment>, f64)> {
    if query.sample.is_empty()
        || target.sample.is_empty()
        || query.centres.is_empty()
        || target.centres.is_empty()
    {
        return None;
    }
    let d = crate::assign::distances(query.descriptors, target.descriptors);
    align(query, target, &d, params).map(|v| {
        let mut all = vec![v.alignment()];
        all.extend(v.alternatives());
        (all, v.fitness)
    })
}

/// Step 6's alignment of `query` onto `target` ([`verify::fitness`]) from the tentative pairs
/// of the distance matrix `d`; `None` when none was found.
fn align(
    query: ShapeView,
    target: ShapeView,
    d: &[f32],
    params: &MatchParams,
) -> Option<verify::Verified> {
    let (mq, mt) = (query.descriptors.len(), target.descriptors.len());
    let max_d = params.max_distance.max(f32::MIN_POSITIVE);
    verify::fitness(
        query,
        target,
        &verify::tentative_pairs(d, mq, mt, max_d * verify::PAIR_REACH),
        params.file_units.then_some(1.0),
        params.verify_tolerance,
        params.verify_search,
    )
}

/// Adds to `alive` (positions in `matches`, kept sorted) the assigned pairs the checks dropped
/// whose centres land together under the alignment `v`, and returns how many it added.
fn keep_aligned(
    query: ShapeView,
    target: ShapeView,
    matches: &[ComponentMatch],
    alive: &mut Vec<usize>,
    v: &verify::Verified,
) -> usize {
    let k0 = matches.len();
    let mut kept_again = 0;
    let mut kept = vec![false; k0];
    for &a in alive.iter() {
        kept[a] = true;
    }
    for (a, m) in matches.iter().enumerate() {
        if !kept[a]
            && let (Some(q), Some(t)) = (query.centres.get(m.query), target.centres.get(m.target))
            && v.agrees(q, t)
        {
            alive.push(a);
            kept_again += 1;
        }
    }
    alive.sort_unstable();
    kept_again
}

/// The score's verification factor `1 − γ·(1 − f)` (step 6), γ the verification weight and f
/// the `fitness`: 1 when verification did not run (`None`).
fn verification_factor(fitness: Option<f64>, params: &MatchParams) -> f64 {
    let gamma = unit_weight(params.verify_weight);
    1.0 - gamma * (1.0 - fitness.unwrap_or(1.0))
}
