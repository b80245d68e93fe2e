//! Steps 3–5 of matching (crate documentation, *Steps*): whether the assigned pairs agree with
//! one another geometrically.
//!
//! * [`layout`]: the geodesic distances between matched centres must agree up to one scale
//!   for the whole shape (a fragment normalised to unit area on its own differs from its
//!   source by an unknown factor); the match that disagrees with most others is dropped
//!   until every kept match agrees with at least half of those it is compared with.
//! * [`sizes`]: matched parts' areas must agree with the square of that scale (the
//!   descriptors are scale-free, so a small patch can look like a large one).
//! * [`pose`]: straight-line distances between matched centres, which bending changes where
//!   geodesic ones stay, give each kept pair a factor on its similarity (off by default).
//!
//! Cost: O(k²) ratios for k matches, and O(k²) per dropped match.

use crate::assign::ComponentMatch;
use crate::params::{MatchParams, unit_weight};
use crate::view::ShapeView;

/// Distance, in the layout's length unit, within which two straight-line distances always
/// agree in the pose check: a centre found again on a fragment may sit a few vertices away.
pub const POSE_SLACK: f64 = 0.02;

/// Steps 1–4 of the crate documentation's *Steps* (the assignment, the layout and size
/// checks): what does not depend on verification, the pose check or the score, so that a query
/// can verify its shortlist without assigning again ([`crate::score::finish`]).
#[derive(Debug, Clone)]
pub(crate) struct Assigned {
    /// Every assigned pair closer than the largest distance, by query part.
    pub(crate) matches: Vec<ComponentMatch>,
    /// Positions in `matches` of the pairs the checks kept.
    pub(crate) alive: Vec<usize>,
    /// Pairs the checks dropped.
    pub(crate) rejected: usize,
    /// The layout's scale.
    pub(crate) scale: Option<f64>,
}

/// The median of `v` (the mean of the two middle values for an even count), reordering `v`.
fn median_in_place(v: &mut [f64]) -> Option<f64> {
    let n = v.len();
    if n == 0 {
        return None;
    }
    let (low, mid, _) = v.select_nth_unstable_by(n / 2, f64::total_cmp);
    let mid = *mid;
    Some(if n % 2 == 1 {
        mid
    } else {
        let below = low.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (below + mid)
    })
}

/// Steps 3–4 of matching on the assigned pairs `matches` ([`crate::assign::pair`]): the layout
/// check, then the size check.
pub(crate) fn check(
    query: ShapeView,
    target: ShapeView,
    matches: Vec<ComponentMatch>,
    params: &MatchParams,
) -> Assigned {
    let (mut alive, layout_rejected, scale) = layout(query, target, &matches, params);
    let rejected = layout_rejected + sizes(query, target, &matches, scale, params, &mut alive);
    Assigned {
        matches,
        alive,
        rejected,
        scale,
    }
}

/// Step 3, the layout check: the positions in `matches` of the pairs it keeps (in order), how
/// many it dropped, and the layout's scale (target/query length ratio; `None` with fewer than
/// three matches or no pair of them with a distance on both sides).
pub(crate) fn layout(
    query: ShapeView,
    target: ShapeView,
    matches: &[ComponentMatch],
    params: &MatchParams,
) -> (Vec<usize>, usize, Option<f64>) {
    // |ln(r / s)| > ln(T) ⇔ r / s outside [1/T, T]: compared without a logarithm per pair
    let tol = params.layout_tolerance.max(1.0);
    let mut rejected = 0;
    let mut scale = None;
    // ratios dt/dq of every pair of matches, computed once (NaN: no distance on one side)
    let k0 = matches.len();
    let mut ratios = vec![f64::NAN; k0 * k0];
    if k0 >= 3 {
        for a in 0..k0 {
            for b in a + 1..k0 {
                let (x, y) = (&matches[a], &matches[b]);
                let (dq, dt) = (
                    query.dist(x.query, y.query),
                    target.dist(x.target, y.target),
                );
                if dq > 0.0 && dt > 0.0 && dq.is_finite() && dt.is_finite() {
                    ratios[a * k0 + b] = dt / dq;
                    ratios[b * k0 + a] = dt / dq;
                }
            }
        }
    }
    // positions (in the original order) of the matches still kept
    let mut alive: Vec<usize> = (0..k0).collect();
    let mut pooled = Vec::with_capacity(k0 * k0 / 2);
    while alive.len() >= 3 {
        pooled.clear();
        for (i, &a) in alive.iter().enumerate() {
            for &b in &alive[i + 1..] {
                let r = ratios[a * k0 + b];
                if !r.is_nan() {
                    pooled.push(r);
                }
            }
        }
        let Some(mut s) = median_in_place(&mut pooled) else {
            break;
        };
        if params.file_units {
            s = 1.0;
        }
        scale = Some(s);
        // per kept match: (pairs that disagree, pairs with a distance on both sides)
        let counts: Vec<(usize, usize)> = alive
            .iter()
            .map(|&a| {
                alive
                    .iter()
                    .filter(|&&b| b != a)
                    .map(|&b| ratios[a * k0 + b])
                    .filter(|r| !r.is_nan())
                    .fold((0, 0), |(bad, all), r| {
                        let q = r / s;
                        (bad + usize::from(q > tol || q * tol < 1.0), all + 1)
                    })
            })
            .collect();
        let worst = (0..alive.len()).max_by(|&i, &j| {
            counts[i].0.cmp(&counts[j].0).then(
                matches[alive[i]]
                    .distance
                    .total_cmp(&matches[alive[j]].distance)
                    .then(j.cmp(&i)),
            )
        });
        match worst {
            Some(w) if 2 * counts[w].0 > counts[w].1 => {
                alive.remove(w);
                rejected += 1;
            }
            _ => break,
        }
    }
    (alive, rejected, scale)
}

/// Step 4, the size check: drops from `alive` (positions in `matches`) the pairs whose part
/// areas disagree with the square of the layout's `scale` by more than
/// [`MatchParams::area_tolerance`], and returns how many it dropped. Off without a scale, with
/// a tolerance of at most 1, or when a side gives no areas.
pub(crate) fn sizes(
    query: ShapeView,
    target: ShapeView,
    matches: &[ComponentMatch],
    scale: Option<f64>,
    params: &MatchParams,
    alive: &mut Vec<usize>,
) -> usize {
    let mut rejected = 0;
    // the parts' sizes must agree with the layout's scale too
    if let Some(s) = scale
        && params.area_tolerance > 1.0
        && !query.areas.is_empty()
        && !target.areas.is_empty()
    {
        let tol = params.area_tolerance;
        alive.retain(|&a| {
            let m = &matches[a];
            let (aq, at) = (
                query.areas.get(m.query).copied().unwrap_or(f32::NAN) as f64,
                target.areas.get(m.target).copied().unwrap_or(f32::NAN) as f64,
            );
            let q = at / (s * s * aq);
            let keep = !(q > tol || q * tol < 1.0);
            rejected += usize::from(!keep);
            keep
        });
    }
    rejected
}

/// Step 5, the pose check, on the kept pairs `matches`: each pair's factor on its similarity,
/// `1 − β·(1 − c)` with c the fraction of the pairs it was compared with whose straight-line
/// distances agree (empty, every factor 1, when the check does not run: off, no layout
/// `scale`, or a side without centres), and the fraction of all compared pairs of pairs that
/// agree (`None` when none was compared).
pub(crate) fn pose(
    query: ShapeView,
    target: ShapeView,
    matches: &[ComponentMatch],
    scale: Option<f64>,
    params: &MatchParams,
) -> (Vec<f64>, Option<f64>) {
    // the pose check: the fraction of a kept match's partners whose straight-line distance
    // agrees with the scaled query one
    let beta = unit_weight(params.pose_weight);
    // each kept match's pose factor; empty (every factor 1) when the check does not run
    let mut pose: Vec<f64> = Vec::new();
    let mut agreement = None;
    if scale.is_some() && beta > 0.0 && !query.centres.is_empty() && !target.centres.is_empty() {
        // straight-line distances (query, target) of every pair of kept matches that the
        // layout compares too (the whole-surface part has no place)
        let k = matches.len();
        let mut pairs: Vec<(usize, usize, f64, f64)> = Vec::new();
        for a in 0..k {
            for b in a + 1..k {
                let (x, y) = (&matches[a], &matches[b]);
                if !(query.dist(x.query, y.query) > 0.0 && target.dist(x.target, y.target) > 0.0) {
                    continue;
                }
                let (eq, et) = (
                    query.straight(x.query, y.query),
                    target.straight(x.target, y.target),
                );
                if eq > 0.0 && eq.is_finite() && et.is_finite() {
                    pairs.push((a, b, eq, et));
                }
            }
        }
        // the scale of straight lines: 1 in file units, else their median ratio (the
        // geodesic one is off on a scan, whose holes lengthen its geodesics)
        let s = if params.file_units {
            Some(1.0)
        } else {
            median_in_place(&mut pairs.iter().map(|p| p.3 / p.2).collect::<Vec<_>>())
        };
        if let Some(s) = s {
            let tol = params.pose_tolerance.max(1.0);
            let mut counts = vec![(0usize, 0usize); k];
            for &(a, b, eq, et) in &pairs {
                let eq = s * eq;
                let agree = usize::from((et - eq).abs() <= (tol - 1.0) * eq.min(et) + POSE_SLACK);
                for i in [a, b] {
                    counts[i].0 += agree;
                    counts[i].1 += 1;
                }
            }
            pose = counts
                .iter()
                .map(|&(agree, compared)| {
                    let c = if compared > 0 {
                        agree as f64 / compared as f64
                    } else {
                        1.0
                    };
                    1.0 - beta * (1.0 - c)
                })
                .collect();
            if !pairs.is_empty() {
                let agree: usize = counts.iter().map(|c| c.0).sum();
                agreement = Some(agree as f64 / (2 * pairs.len()) as f64);
            }
        }
    }
    (pose, agreement)
}
