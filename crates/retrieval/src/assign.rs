//! Steps 1–2 of matching (crate documentation, *Steps*): the similarity of two parts by
//! descriptor distance and the one-to-one assignment of query parts to target parts that
//! maximises the total (weighted) similarity.
//!
//! The assignment is the linear assignment problem (H. W. Kuhn, "The Hungarian method for the
//! assignment problem", Naval Research Logistics Quarterly 2, 1955), solved by shortest
//! augmenting paths (R. Jonker, A. Volgenant, "A shortest augmenting path algorithm for dense
//! and sparse linear assignment problems", Computing 38, 1987) for rectangular matrices as in
//! D. F. Crouse, "On implementing 2D rectangular assignment algorithms", IEEE Trans. Aerospace
//! and Electronic Systems 52, 2016 (the `lsap` crate). Similarities are rounded to whole
//! multiples of 10⁻⁶ first, so the solver's sums are exact and its optimum does not depend on
//! the order of its additions.
//!
//! Cost: `mq × mt` descriptor distances, then O(m³) for the assignment of m parts.

use keycomp_describe::Descriptor;
use serde::{Deserialize, Serialize};

use crate::params::MatchParams;

/// One matched pair of components.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ComponentMatch {
    /// Index of the query (first shape's) component.
    pub query: usize,
    /// Index of the target (second shape's) component.
    pub target: usize,
    /// Descriptor distance.
    pub distance: f32,
}

/// The weight of query part `i`: `weights[i]` when it is a finite number ≥ 0, else 1.
pub(crate) fn part_weight(weights: &[f64], i: usize) -> f64 {
    weights
        .get(i)
        .copied()
        .filter(|w| w.is_finite() && *w >= 0.0)
        .unwrap_or(1.0)
}

/// The sum of the query's part weights ([`part_weight`] of each of its `mq` parts): the
/// score's denominator.
pub(crate) fn total_weight(mq: usize, weights: &[f64]) -> f64 {
    (0..mq).map(|i| part_weight(weights, i)).sum()
}

/// The similarity of two parts at descriptor distance `dd`, `max(0, 1 − dd / d_max)` (step 1
/// of *Steps*), as the score sums it.
pub(crate) fn similarity(dd: f32, params: &MatchParams) -> f64 {
    let max_d = params.max_distance.max(f32::MIN_POSITIVE);
    (1.0 - (dd / max_d) as f64).max(0.0)
}

/// Descriptor distances of every query part to every target part, `mq × mt` row-major.
pub(crate) fn distances(query: &[Descriptor], target: &[Descriptor]) -> Vec<f32> {
    let mut d = Vec::with_capacity(query.len() * target.len());
    for q in query {
        d.extend(
            target
                .iter()
                .map(|t| keycomp_index::squared_distance_fast(q, t).sqrt()),
        );
    }
    d
}

/// Steps 1–2 of matching: the assignment maximising the total similarity of the
/// `mq × mt` distance matrix `d`, as its pairs closer than the largest distance, by query
/// part. `None` when either shape has no parts.
pub(crate) fn pair(
    mq: usize,
    mt: usize,
    d: &[f32],
    params: &MatchParams,
    weights: &[f64],
) -> Option<Vec<ComponentMatch>> {
    let weight_of = |i: usize| part_weight(weights, i);
    if mq == 0 || mt == 0 {
        return None;
    }
    let max_d = params.max_distance.max(f32::MIN_POSITIVE);
    // similarities in units of 1e-6, whole numbers: the solver's sums are then exact, so its
    // optimum does not depend on the order of its additions
    const SCALE: f64 = 1e6;
    let weight = |i: usize, dd: f32| -> f64 {
        let w = (1.0 - dd / max_d).max(0.0) as f64 * weight_of(i);
        if w.is_finite() {
            (w * SCALE).round()
        } else {
            0.0
        }
    };
    // the solver takes rows ≤ columns without copying: put the smaller side on the rows
    let transpose = mq > mt;
    let (rows, cols) = if transpose { (mt, mq) } else { (mq, mt) };
    // costs: the similarities negated, as the solver minimises
    let mut costs = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        for c in 0..cols {
            let (i, a) = if transpose { (c, r) } else { (r, c) };
            costs.push(-weight(i, d[i * mt + a]));
        }
    }
    // finite costs always have an assignment: an error is not expected
    let (_, assignment) = lsap::solve(rows, cols, &costs, false).ok()?;
    let mut matches: Vec<ComponentMatch> = assignment
        .iter()
        .enumerate()
        .map(|(r, &c)| if transpose { (c, r) } else { (r, c) })
        .filter(|&(i, a)| d[i * mt + a] < max_d)
        .map(|(i, a)| ComponentMatch {
            query: i,
            target: a,
            distance: d[i * mt + a],
        })
        .collect();
    matches.sort_by_key(|m| m.query);
    Some(matches)
}
