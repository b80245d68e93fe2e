//! Geometric verification: how much of the query's surface lies on the target's once the query
//! is moved onto it (see [`crate::MatchParams::verify_weight`]).
//!
//! 1. **Alignment hypotheses from the parts.** Tentative pairs join each query part to its
//!    [`PAIRS_PER_PART`] nearest target parts by descriptor (a scan's parts are cropped, so its
//!    true partner is often not the nearest one). Triples of the nearest pairs
//!    ([`crate::MatchParams::verify_search`]: [`VerifySearch::AS_READ`], or
//!    [`VerifySearch::RESAMPLED`] on canonical surfaces) whose straight-line distances agree
//!    (RANSAC: M. A. Fischler, R. C. Bolles, "Random sample consensus", Communications of the ACM
//!    24(6), 1981) each give the least-squares similarity transform (rotation, translation and,
//!    unless both shapes are in file units, a uniform scale; S. Umeyama, "Least-squares estimation
//!    of transformation parameters between two point patterns", IEEE TPAMI 13(4), 1991), up to the
//!    search's cap; triples of the same places (parts stacked on one keypoint) give one transform,
//!    tried once. A hypothesis counts the places whose centres it brings within
//!    [`CENTRE_TOLERANCE`] tolerances (parts of several levels grown from one keypoint share a
//!    centre and count once); the [`CANDIDATES`] with most (and different inliers) are fitted again
//!    on their inliers.
//! 2. **Decided on the surfaces, not on the centres.** The count of agreeing places does not
//!    pick the right alignment: a left–right flip of a symmetric animal often has more. Each
//!    candidate gets [`SCREEN_ROUNDS`] rounds of ICP (P. J. Besl, N. D. McKay, "A method for
//!    registration of 3-D shapes", IEEE TPAMI 14(2), 1992) on every [`SCREEN_STEP`]-th point
//!    of the query's surface sample, onto the target's sample (a KD-tree); the [`REFINED`] that
//!    bring most of it near the target's surface get [`ICP_ITERATIONS`] rounds on the whole
//!    sample, and the one that fits best wins. ICP pairs a point with its nearest neighbour
//!    within a reach that shrinks from [`ICP_REACH`]`.0` to [`ICP_REACH`]`.1` tolerances (a
//!    start a few degrees off still converges); the scale stays within [`SCALE_DRIFT`] of the
//!    candidate's.
//! 3. **Fitness**: the fraction of the query's sample within the tolerance of the target's
//!    sample. Without a known scale the tolerance follows the query's size
//!    ([`SCALE_REFERENCE`]), so that shrinking a query until it fits anywhere does not pay.
//!    The exact source of a fragment scores highest, the same parts in another pose less (what
//!    moved is off the surface), another shape less still.
//!
//! Cost: at most [`VerifySearch::hypotheses`] transforms checked against the pairs, [`CANDIDATES`]
//! × [`SCREEN_ROUNDS`] rounds on a thinned sample and [`REFINED`] × [`ICP_ITERATIONS`] rounds of
//! KD-tree look-ups on the whole one: a few milliseconds per target, which is why a query verifies
//! only its best candidates (`rank::VERIFIED_CANDIDATES`).

use std::collections::HashSet;

use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::view::ShapeView;

/// Tentative pairs per query part: its nearest target parts in descriptor space.
pub const PAIRS_PER_PART: usize = 6;
/// Tentative pairs reach this many times the matching's largest descriptor distance
/// ([`crate::MatchParams::max_distance`]): cropping moves a scan's descriptors further from
/// their partners' than the assignment accepts.
pub const PAIR_REACH: f32 = 1.5;
/// Most tentative pairs, the nearest in descriptor space first, checked against a transform.
pub const MAX_PAIRS: usize = 300;
/// How wide verification searches for the alignment ([`crate::MatchParams::verify_search`]):
/// triples of the `seeds` nearest tentative pairs give the transforms tried, at most
/// `hypotheses` of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct VerifySearch {
    /// The nearest pairs whose triples give the transforms tried.
    pub seeds: usize,
    /// Most transforms tried (the triples whose distances agree).
    pub hypotheses: usize,
}

impl VerifySearch {
    /// The default: enough where a fragment keeps its source's tessellation, so that its parts
    /// are near copies of its source's.
    pub const AS_READ: VerifySearch = VerifySearch {
        seeds: 60,
        hypotheses: 3000,
    };
    /// On canonical surfaces ([`crate::verify_search_for`]): a resampled scan's parts are
    /// cropped and re-tessellated, so its true pairs lie further down the list by descriptor
    /// distance; with [`VerifySearch::AS_READ`] the bunny's raw scans missed their model's
    /// alignment where twice the seeds (eight times the triples) find it (BENCHMARKS.md, *Real
    /// range scans*).
    pub const RESAMPLED: VerifySearch = VerifySearch {
        seeds: 120,
        hypotheses: 20_000,
    };
}
/// Largest factor by which the straight-line distances between two pairs' centres may
/// disagree (after the scale) for the pairs to be taken together.
pub const RATIO_TOLERANCE: f64 = 1.2;
/// ICP rounds.
pub const ICP_ITERATIONS: usize = 12;
/// Alignments tried on the surfaces: the hypotheses that bring most places together (with
/// different inliers), each screened by a few ICP rounds on a thinned sample.
pub const CANDIDATES: usize = 32;
/// Candidates refined by ICP: those with most of a thinned sample near the target's surface.
pub const REFINED: usize = 3;
/// Two poses whose rotations differ by more than this many degrees are distinct
/// ([`crate::ShapeMatch::alternatives`]).
pub const DISTINCT_DEGREES: f64 = 10.0;
/// Every this-many-th sample point is used to screen the candidates.
pub const SCREEN_STEP: usize = 4;
/// ICP rounds on the thinned sample when screening.
pub const SCREEN_ROUNDS: usize = 3;
/// ICP pairs a point with its nearest neighbour when it lies within this many tolerances:
/// from the first (a start a few degrees off still converges) down to the second.
pub const ICP_REACH: (f64, f64) = (10.0, 3.0);
/// Factor by which the ICP reach shrinks per round.
pub const ICP_REACH_DECAY: f64 = 0.75;
/// Matched centres agree with a transform within this many tolerances (centres found again on
/// a fragment may sit a few vertices away, and matched parts of neighbouring levels share a
/// keypoint but not always the same one).
pub const CENTRE_TOLERANCE: f64 = 3.0;
/// Largest factor by which ICP may change the scale found from the matched centres.
pub const SCALE_DRIFT: f64 = 1.25;
/// Range of the target/query length ratio when the scale is unknown (both shapes scaled to
/// unit area on their own): a query is at most its target (with room for a different
/// tessellation and smoothing), at least a fragment of 9 % of its area. Shrinking the query
/// further would fit it anywhere.
pub const SCALE_RANGE: (f64, f64) = (0.3, 1.1);
/// Without a known scale, the fitness tolerance is the given one at this target/query length
/// ratio (a fragment of about a third of its shape's area) and proportional to the ratio.
pub const SCALE_REFERENCE: f64 = 0.6;

/// The places of a list of pairs of centres: parts of several levels grown from one keypoint
/// share their centre, so a transform that brings one stack of parts onto another matches
/// many pairs but one place. A hypothesis is scored by the places it brings together.
struct Places {
    /// Each pair's query place and target place (index of the first pair with that centre).
    ids: Vec<(usize, usize)>,
    /// Last count that saw each query place and each target place.
    seen: Vec<(u32, u32)>,
    round: u32,
}

impl Places {
    fn new(src: &[Vector3<f64>], dst: &[Vector3<f64>]) -> Self {
        let first = |pts: &[Vector3<f64>], i: usize| pts[..i].iter().position(|p| *p == pts[i]);
        let ids = (0..src.len())
            .map(|i| (first(src, i).unwrap_or(i), first(dst, i).unwrap_or(i)))
            .collect();
        Places {
            ids,
            seen: vec![(0, 0); src.len()],
            round: 0,
        }
    }

    /// The smaller of the numbers of distinct query places and of distinct target places
    /// among the given pairs.
    fn count(&mut self, pairs: impl Iterator<Item = usize>) -> usize {
        self.round += 1;
        let r = self.round;
        let (mut q, mut t) = (0, 0);
        for i in pairs {
            let (a, b) = self.ids[i];
            if self.seen[a].0 != r {
                self.seen[a].0 = r;
                q += 1;
            }
            if self.seen[b].1 != r {
                self.seen[b].1 = r;
                t += 1;
            }
        }
        q.min(t)
    }
}

/// A similarity transform `x ↦ s·R·x + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Similarity {
    r: Matrix3<f64>,
    s: f64,
    t: Vector3<f64>,
}

impl Similarity {
    fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.s * (self.r * p) + self.t
    }

    /// Whether `other` is another pose: rotations more than [`DISTINCT_DEGREES`] apart, or
    /// the origin moved to places more than `reach` apart.
    fn differs(&self, other: &Similarity, reach: f64) -> bool {
        let cos = (((self.r.transpose() * other.r).trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
        cos.acos().to_degrees() > DISTINCT_DEGREES || (self.t - other.t).norm() > reach
    }
}

/// A similarity transform `x ↦ scale · rotation · x + translation` (column vectors) taking a
/// query's frame to a target's: the alignment verification found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Alignment {
    /// Rotation matrix, row-major (`rotation[i][j]` is row i, column j).
    pub rotation: [[f64; 3]; 3],
    /// Translation.
    pub translation: [f64; 3],
    /// Uniform scale (1 in file units).
    pub scale: f64,
}

impl Alignment {
    /// `p` moved by the transform.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        std::array::from_fn(|i| {
            self.scale * (r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2]) + self.translation[i]
        })
    }
}

impl From<Similarity> for Alignment {
    fn from(t: Similarity) -> Self {
        Alignment {
            rotation: std::array::from_fn(|i| std::array::from_fn(|j| t.r[(i, j)])),
            translation: [t.t.x, t.t.y, t.t.z],
            scale: t.s,
        }
    }
}

/// What verification found: the alignment and how well the query fits under it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Verified {
    /// The share of the query's sample within the tolerance of the target's.
    pub fitness: f64,
    transform: Similarity,
    tolerance: f64,
    /// The other distinct poses screening passed, best screened first.
    others: Vec<Similarity>,
}

impl Verified {
    /// The alignment, query frame to target frame.
    pub fn alignment(&self) -> Alignment {
        self.transform.into()
    }

    /// The other distinct alignments screening passed, best screened first (fewer than
    /// [`CANDIDATES`]): a symmetric shape's other poses, or the right one when the thinned
    /// samples favoured another, which refinement on the full surfaces tells apart.
    pub fn alternatives(&self) -> Vec<Alignment> {
        self.others.iter().map(|&t| t.into()).collect()
    }

    /// Whether a query centre `q` lands within [`CENTRE_TOLERANCE`] tolerances of a target
    /// centre `t` under the alignment.
    pub fn agrees(&self, q: &[f32; 3], t: &[f32; 3]) -> bool {
        (self.transform.apply(&point(q)) - point(t)).norm() <= CENTRE_TOLERANCE * self.tolerance
    }
}

/// The least-squares similarity taking `src[i]` to `dst[i]` (Umeyama 1991), with the scale
/// fixed at `fixed_scale` when given; `None` for fewer than three points, points all in one
/// place, or a scale that is not a positive number.
pub(crate) fn umeyama(
    src: &[Vector3<f64>],
    dst: &[Vector3<f64>],
    fixed_scale: Option<f64>,
) -> Option<Similarity> {
    let n = src.len().min(dst.len());
    if n < 3 {
        return None;
    }
    let inv = 1.0 / n as f64;
    let ms = src[..n].iter().sum::<Vector3<f64>>() * inv;
    let md = dst[..n].iter().sum::<Vector3<f64>>() * inv;
    let mut cov = Matrix3::zeros();
    let mut var = 0.0;
    for (a, b) in src[..n].iter().zip(&dst[..n]) {
        let (x, y) = (a - ms, b - md);
        cov += y * x.transpose();
        var += x.norm_squared();
    }
    cov *= inv;
    var *= inv;
    if var.is_nan() || var <= 1e-12 {
        return None;
    }
    let svd = cov.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut d = Vector3::new(1.0, 1.0, 1.0);
    if u.determinant() * vt.determinant() < 0.0 {
        d[2] = -1.0;
    }
    let r = u * Matrix3::from_diagonal(&d) * vt;
    let s = match fixed_scale {
        Some(s) => s,
        None => svd.singular_values.dot(&d) / var,
    };
    if !(s > 0.0 && s.is_finite() && r.iter().all(|x| x.is_finite())) {
        return None;
    }
    Some(Similarity {
        r,
        s,
        t: md - s * (r * ms),
    })
}

fn point(p: &[f32; 3]) -> Vector3<f64> {
    Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// Tentative pairs of parts for [`fitness`]: each query part with its [`PAIRS_PER_PART`]
/// nearest target parts closer than `max_d`, as `(query part, target part, distance)`, from
/// the `mq × mt` row-major descriptor distances `d`.
pub(crate) fn tentative_pairs(
    d: &[f32],
    mq: usize,
    mt: usize,
    max_d: f32,
) -> Vec<(usize, usize, f32)> {
    let mut tentative = Vec::new();
    let mut row: Vec<(f32, usize)> = Vec::with_capacity(mt);
    for i in 0..mq {
        row.clear();
        row.extend((0..mt).map(|a| (d[i * mt + a], a)).filter(|x| x.0 < max_d));
        let k = row.len().min(PAIRS_PER_PART);
        if k > 0 {
            row.select_nth_unstable_by(k - 1, |x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            tentative.extend(row[..k].iter().map(|&(dd, a)| (i, a, dd)));
        }
    }
    tentative
}

/// The fitness of `query` on `target` (see the module documentation) given tentative pairs of
/// parts `(query part, target part, descriptor distance)`, in [0, 1]; `fixed_scale` is 1 in
/// file units, `None` when the scale is unknown; `tolerance` in the target's length unit;
/// `search` bounds the alignments tried.
/// `None` when either shape has no centres or no sample, or fewer than three pairs have
/// centres (nothing to align with).
pub(crate) fn fitness(
    query: ShapeView,
    target: ShapeView,
    tentative: &[(usize, usize, f32)],
    fixed_scale: Option<f64>,
    tolerance: f64,
    search: VerifySearch,
) -> Option<Verified> {
    if query.sample.is_empty() || target.sample.is_empty() {
        return None;
    }
    let mut pairs: Vec<(usize, usize, f32)> = tentative
        .iter()
        .copied()
        .filter(|&(i, a, _)| i < query.centres.len() && a < target.centres.len())
        .collect();
    pairs.sort_by(|x, y| x.2.total_cmp(&y.2).then((x.0, x.1).cmp(&(y.0, y.1))));
    pairs.truncate(MAX_PAIRS);
    let src: Vec<Vector3<f64>> = pairs.iter().map(|p| point(&query.centres[p.0])).collect();
    let dst: Vec<Vector3<f64>> = pairs.iter().map(|p| point(&target.centres[p.1])).collect();
    let n = src.len();
    if n < 3 {
        return None;
    }
    let tol = tolerance.max(f64::MIN_POSITIVE);
    let centre_tol2 = (CENTRE_TOLERANCE * tol).powi(2);
    let is_inlier =
        |t: &Similarity, i: usize| (t.apply(&src[i]) - dst[i]).norm_squared() <= centre_tol2;
    let scale_ok = |s: f64| fixed_scale.is_some() || (SCALE_RANGE.0..=SCALE_RANGE.1).contains(&s);
    // 1. hypotheses: triples of the best pairs whose straight-line distances agree
    let m = n.min(search.seeds);
    // two matched centres may each be off by the inlier tolerance; closer than one such
    // tolerance, two centres give no direction to align by
    let slack = 2.0 * CENTRE_TOLERANCE * tol;
    let apart = CENTRE_TOLERANCE * tol;
    let ratio_of = |a: usize, b: usize| -> Option<f64> {
        let (x, y) = (pairs[a], pairs[b]);
        if x.0 == y.0 || x.1 == y.1 {
            return None;
        }
        let (eq, et) = ((src[a] - src[b]).norm(), (dst[a] - dst[b]).norm());
        if !(et > apart && eq > 0.0) {
            return None;
        }
        let r = et / eq;
        let ok = match fixed_scale {
            Some(s) => (et - s * eq).abs() <= (RATIO_TOLERANCE - 1.0) * et.max(s * eq) + slack,
            None => (SCALE_RANGE.0..=SCALE_RANGE.1).contains(&r),
        };
        ok.then_some(r)
    };
    // every seed pair's ratio with every other, computed once
    let ratios: Vec<Option<f64>> = (0..m * m).map(|k| ratio_of(k / m, k % m)).collect();
    let ratio = |a: usize, b: usize| ratios[a * m + b];
    let agree = |r: f64, q: f64| r <= q * RATIO_TOLERANCE && q <= r * RATIO_TOLERANCE;
    // parts of several levels grown from one keypoint share a centre: triples of the same
    // places give the same transform and are tried once (they still count towards the cap)
    let mut places = Places::new(&src, &dst);
    let mut tried: HashSet<[(usize, usize); 3]> = HashSet::new();
    let mut tries = 0;
    let mut triples: Vec<[usize; 3]> = Vec::new();
    'seeds: for a in 0..m {
        for b in a + 1..m {
            let Some(rab) = ratio(a, b) else { continue };
            for c in b + 1..m {
                let (Some(rac), Some(rbc)) = (ratio(a, c), ratio(b, c)) else {
                    continue;
                };
                if fixed_scale.is_some() || (agree(rab, rac) && agree(rab, rbc)) {
                    let mut key = [places.ids[a], places.ids[b], places.ids[c]];
                    key.sort_unstable();
                    if tried.insert(key) {
                        triples.push([a, b, c]);
                    }
                    tries += 1;
                    if tries >= search.hypotheses {
                        break 'seeds;
                    }
                }
            }
        }
    }
    // every hypothesis with its count of places it brings together and a signature of its
    // inliers (FNV-1a over their positions), so that the choice below need not find them again
    let mut scored: Vec<(usize, u64, Similarity)> = Vec::new();
    for [a, b, c] in triples {
        let Some(t) = umeyama(
            &[src[a], src[b], src[c]],
            &[dst[a], dst[b], dst[c]],
            fixed_scale,
        ) else {
            continue;
        };
        if !scale_ok(t.s) {
            continue;
        }
        let mut signature: u64 = 0xcbf2_9ce4_8422_2325;
        let count = places.count((0..n).filter(|&i| is_inlier(&t, i)).inspect(|&i| {
            signature = (signature ^ i as u64).wrapping_mul(0x0100_0000_01b3);
        }));
        scored.push((count, signature, t));
    }
    // the best few, each fitted again on its inliers (transforms that keep the same inliers
    // count once)
    scored.sort_by_key(|x| std::cmp::Reverse(x.0));
    let mut signatures: Vec<u64> = Vec::with_capacity(CANDIDATES);
    let mut candidates: Vec<Similarity> = Vec::with_capacity(CANDIDATES);
    for (_, signature, t) in scored {
        if candidates.len() >= CANDIDATES {
            break;
        }
        if signatures.contains(&signature) {
            continue;
        }
        signatures.push(signature);
        let inliers: Vec<usize> = (0..n).filter(|&i| is_inlier(&t, i)).collect();
        let mut t = t;
        if inliers.len() >= 3 {
            let s: Vec<_> = inliers.iter().map(|&i| src[i]).collect();
            let d: Vec<_> = inliers.iter().map(|&i| dst[i]).collect();
            if let Some(refit) = umeyama(&s, &d, fixed_scale)
                && scale_ok(refit.s)
            {
                t = refit;
            }
        }
        candidates.push(t);
    }
    if candidates.is_empty() {
        return None;
    }
    // 2. ICP of the query's sample onto the target's, from each candidate; the best fit wins
    let targets: Vec<[f64; 3]> = target
        .sample
        .iter()
        .map(|p| [p[0] as f64, p[1] as f64, p[2] as f64])
        .collect();
    let tree: ImmutableKdTree<f64, u32, 3, 8> = ImmutableKdTree::new_from_slice(&targets);
    let q: Vec<Vector3<f64>> = query.sample.iter().map(point).collect();
    let nearest = |t: &Similarity, p: &Vector3<f64>| {
        let x = t.apply(p);
        let nb = tree.nearest_one::<SquaredEuclidean>(&[x.x, x.y, x.z]);
        (nb.distance, nb.item as usize)
    };
    let tol2 = tol * tol;
    // squared factor on the tolerance of the fitness: 1 in file units; without a known scale
    // the tolerance follows the query's size (a query shrunk onto the target must fit more
    // closely, else any small piece would fit anywhere)
    let relative = |t: &Similarity| match fixed_scale {
        Some(_) => 1.0,
        None => (t.s / SCALE_REFERENCE).powi(2),
    };
    let mut s = Vec::with_capacity(q.len());
    let mut d = Vec::with_capacity(q.len());
    // ICP from `start` over `points`, `rounds` rounds: the transform reached
    let mut icp = |start: Similarity, points: &[Vector3<f64>], rounds: usize| -> Similarity {
        let mut t = start;
        let base_scale = t.s;
        for round in 0..rounds {
            // pairs kept within a reach that shrinks from ICP_REACH.0 to ICP_REACH.1 tolerances
            let reach = (ICP_REACH.0 * ICP_REACH_DECAY.powi(round as i32)).max(ICP_REACH.1) * tol;
            let keep2 = reach * reach;
            s.clear();
            d.clear();
            for p in points {
                let (d2, j) = nearest(&t, p);
                if d2 <= keep2 {
                    s.push(*p);
                    d.push(Vector3::new(targets[j][0], targets[j][1], targets[j][2]));
                }
            }
            let Some(mut next) = umeyama(&s, &d, fixed_scale) else {
                break;
            };
            if fixed_scale.is_none() {
                let clamped = next
                    .s
                    .clamp(base_scale / SCALE_DRIFT, base_scale * SCALE_DRIFT)
                    .clamp(SCALE_RANGE.0, SCALE_RANGE.1);
                if clamped != next.s {
                    next = umeyama(&s, &d, Some(clamped)).unwrap_or(next);
                }
            }
            let moved = (next.r - t.r).norm() + (next.t - t.t).norm() + (next.s - t.s).abs();
            t = next;
            if moved < 1e-6 && reach <= ICP_REACH.1 * tol {
                break;
            }
        }
        t
    };
    // a first look at each candidate: a few ICP rounds on a thinned sample, then how much of
    // it lands near the surface
    let thin: Vec<Vector3<f64>> = q.iter().step_by(SCREEN_STEP).copied().collect();
    let near2 = (ICP_REACH.1 * tol).powi(2);
    let mut screened: Vec<(usize, Similarity)> = Vec::with_capacity(candidates.len());
    for start in &candidates {
        let t = icp(*start, &thin, SCREEN_ROUNDS);
        let limit = near2 * relative(&t);
        let on = thin.iter().filter(|p| nearest(&t, p).0 <= limit).count();
        screened.push((on, t));
    }
    screened.sort_by_key(|x| std::cmp::Reverse(x.0));
    // the screened poses that put some of the sample on the target and differ from every
    // pose before them: the alternatives refinement on the full surfaces chooses among (the
    // truth is often one of them when the thinned samples favour another)
    let mut distinct: Vec<Similarity> = Vec::new();
    for (k, t) in &screened {
        if *k > 0
            && distinct
                .iter()
                .all(|d| d.differs(t, CENTRE_TOLERANCE * tol))
        {
            distinct.push(*t);
        }
    }
    screened.truncate(REFINED);
    let mut fitted: Vec<(usize, Similarity)> = Vec::with_capacity(screened.len());
    for (_, start) in screened {
        let t = icp(start, &q, ICP_ITERATIONS);
        // 3. the share of the query's sample on the target's surface
        let limit = tol2 * relative(&t);
        let on = q.iter().filter(|p| nearest(&t, p).0 <= limit).count();
        fitted.push((on, t));
    }
    // the best fit wins (the first of equals)
    fitted.sort_by_key(|x| std::cmp::Reverse(x.0));
    let (on, t) = *fitted.first()?;
    let others = distinct
        .into_iter()
        .filter(|d| d.differs(&t, CENTRE_TOLERANCE * tol))
        .collect();
    Some(Verified {
        fitness: on as f64 / q.len() as f64,
        transform: t,
        tolerance: tol,
        others,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn cloud(n: usize, seed: u64) -> Vec<Vector3<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                Vector3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )
            })
            .collect()
    }

    /// A shape with only part centres and a surface sample, what [`fitness`] reads.
    fn view(centres: &'static [[f32; 3]], sample: &'static [[f32; 3]]) -> ShapeView<'static> {
        ShapeView {
            descriptors: &[],
            layout: &[],
            areas: &[],
            centres,
            sample,
        }
    }

    /// Points kept for the test's duration (a view borrows them).
    fn leak(v: Vec<[f32; 3]>) -> &'static [[f32; 3]] {
        Vec::leak(v)
    }

    #[test]
    fn a_stack_of_parts_on_one_centre_counts_as_one_place() {
        let p = |x: f64| Vector3::new(x, 0.0, 0.0);
        // pairs 0–2: three parts stacked on one query centre, paired with three parts stacked
        // on one target centre; pair 3 the same query centre with another target centre;
        // pairs 4 and 5 two other places
        let src = [p(0.0), p(0.0), p(0.0), p(0.0), p(1.0), p(2.0)];
        let dst = [p(5.0), p(5.0), p(5.0), p(7.0), p(6.0), p(8.0)];
        let mut places = Places::new(&src, &dst);
        assert_eq!(places.count(0..3), 1);
        // one query place on two target places: still one place brought together
        assert_eq!(places.count(0..4), 1);
        assert_eq!(places.count([0, 4, 5].into_iter()), 3);
        assert_eq!(places.count(0..6), 3);
        // counts do not leak from one call into the next
        assert_eq!(places.count(4..5), 1);
        assert_eq!(places.count(std::iter::empty()), 0);
    }

    #[test]
    fn umeyama_recovers_a_similarity() {
        let src = cloud(20, 1);
        let r = Rotation3::from_euler_angles(0.3, -0.7, 1.1).into_inner();
        let (s, t) = (2.5, Vector3::new(0.1, -3.0, 7.0));
        let dst: Vec<_> = src.iter().map(|p| s * (r * p) + t).collect();
        let f = umeyama(&src, &dst, None).expect("a transform");
        assert!((f.s - s).abs() < 1e-9);
        assert!((f.r - r).norm() < 1e-9);
        assert!((f.t - t).norm() < 1e-9);
        // with the scale fixed at the true one, the same; a reflection is never returned
        let g = umeyama(&src, &dst, Some(s)).expect("a transform");
        assert!((g.r - r).norm() < 1e-9);
        let mirrored: Vec<_> = src.iter().map(|p| Vector3::new(-p.x, p.y, p.z)).collect();
        let m = umeyama(&src, &mirrored, None).expect("a transform");
        assert!(m.r.determinant() > 0.0);
        // degenerate input
        assert!(umeyama(&src[..2], &dst[..2], None).is_none());
        assert!(umeyama(&[src[0]; 3], &dst[..3], None).is_none());
    }

    /// A part of a cloud, moved and scaled, fits the cloud it came from (fitness 1) and not a
    /// copy with a third of its points moved away.
    #[test]
    fn a_moved_part_fits_its_source_and_not_a_bent_copy() {
        let whole: Vec<[f32; 3]> = cloud(600, 2)
            .iter()
            .map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect();
        let r = Rotation3::from_euler_angles(-0.4, 0.2, 0.9).into_inner();
        let (s, t) = (1.7, Vector3::new(1.0, 2.0, -1.0));
        // the part: the points with x < 0.2, in another frame
        let kept: Vec<usize> = (0..whole.len()).filter(|&i| whole[i][0] < 0.2).collect();
        let part: Vec<[f32; 3]> = kept
            .iter()
            .map(|&i| {
                let p = s * (r * point(&whole[i])) + t;
                [p.x as f32, p.y as f32, p.z as f32]
            })
            .collect();
        // centres: ten of the part's points, matched to their originals
        let qc: Vec<[f32; 3]> = part.iter().step_by(30).copied().take(10).collect();
        let tc: Vec<[f32; 3]> = kept
            .iter()
            .step_by(30)
            .map(|&i| whole[i])
            .take(10)
            .collect();
        let matches: Vec<(usize, usize, f32)> = (0..qc.len()).map(|i| (i, i, 0.0)).collect();
        let (qc, tc, part) = (leak(qc), leak(tc), leak(part));
        let fit_on = |target: Vec<[f32; 3]>| {
            fitness(
                view(qc, part),
                view(tc, leak(target)),
                &matches,
                None,
                0.02,
                VerifySearch::AS_READ,
            )
            .expect("verified")
            .fitness
        };
        let f = fit_on(whole.clone());
        assert!(f > 0.99, "fitness on the source {f}");
        // the same shape with the points of y > 0.3 moved by 0.5: those do not fit any more
        let bent: Vec<[f32; 3]> = whole
            .iter()
            .map(|p| {
                if p[1] > 0.3 {
                    [p[0], p[1], p[2] + 0.5]
                } else {
                    *p
                }
            })
            .collect();
        let g = fit_on(bent);
        assert!(g < 0.9 * f, "fitness on the bent copy {g}, source {f}");
        // fewer than three matches or no sample: nothing to verify
        assert!(
            fitness(
                view(qc, part),
                view(tc, &[]),
                &matches,
                None,
                0.02,
                VerifySearch::AS_READ
            )
            .is_none()
        );
        assert!(
            fitness(
                view(qc, part),
                view(tc, part),
                &matches[..2],
                None,
                0.02,
                VerifySearch::AS_READ
            )
            .is_none()
        );
    }

    /// More matched centres agree with a wrong transform (a half-turn) than with the true one;
    /// the surfaces decide, and the true one wins.
    #[test]
    fn the_surface_decides_between_alignments_not_the_count_of_centres() {
        let whole: Vec<[f32; 3]> = cloud(800, 5)
            .iter()
            .map(|p| [p.x as f32, (0.5 * p.y) as f32, (0.3 * p.z) as f32])
            .collect();
        // the query: the points with x < 0.3, moved by a rigid transform
        let r = Rotation3::from_euler_angles(0.2, 0.4, -0.3).into_inner();
        let t = Vector3::new(0.5, -1.0, 2.0);
        let kept: Vec<usize> = (0..whole.len()).filter(|&i| whole[i][0] < 0.3).collect();
        let moved = |p: &[f32; 3]| {
            let x = r * point(p) + t;
            [x.x as f32, x.y as f32, x.z as f32]
        };
        let part: Vec<[f32; 3]> = kept.iter().map(|&i| moved(&whole[i])).collect();
        // 4 true pairs, then 6 pairs that agree with the query turned half a turn about z
        let half = Rotation3::from_euler_angles(0.0, 0.0, std::f64::consts::PI).into_inner();
        let mut qc = Vec::new();
        let mut tc = Vec::new();
        for &i in kept.iter().step_by(40).take(4) {
            qc.push(moved(&whole[i]));
            tc.push(whole[i]);
        }
        for &i in kept.iter().skip(7).step_by(25).take(6) {
            qc.push(moved(&whole[i]));
            let x = half * point(&whole[i]);
            tc.push([x.x as f32, x.y as f32, x.z as f32]);
        }
        let matches: Vec<(usize, usize, f32)> = (0..qc.len()).map(|i| (i, i, 0.1)).collect();
        let v = fitness(
            view(leak(qc), leak(part)),
            view(leak(tc), leak(whole)),
            &matches,
            Some(1.0),
            0.02,
            VerifySearch::AS_READ,
        )
        .expect("verified");
        assert!(v.fitness > 0.99, "fitness {}", v.fitness);
        assert!(
            (v.transform.r - r.transpose()).norm() < 1e-3,
            "the true rotation"
        );
        // the alternatives are other poses, each distinct from the chosen one and the others
        let others = &v.others;
        assert!(others.len() < CANDIDATES);
        for (i, a) in others.iter().enumerate() {
            assert!(a.differs(&v.transform, CENTRE_TOLERANCE * 0.02));
            assert!(
                others[..i]
                    .iter()
                    .all(|b| b.differs(a, CENTRE_TOLERANCE * 0.02))
            );
        }
    }

    #[test]
    fn poses_differ_by_rotation_or_place() {
        let turn = |deg: f64| Similarity {
            r: Rotation3::from_euler_angles(0.0, 0.0, deg.to_radians()).into_inner(),
            s: 1.0,
            t: Vector3::zeros(),
        };
        assert!(!turn(0.0).differs(&turn(DISTINCT_DEGREES - 1.0), 0.1));
        assert!(turn(0.0).differs(&turn(DISTINCT_DEGREES + 1.0), 0.1));
        let moved = Similarity {
            t: Vector3::new(0.2, 0.0, 0.0),
            ..turn(0.0)
        };
        assert!(turn(0.0).differs(&moved, 0.1));
        assert!(!turn(0.0).differs(&moved, 0.3));
    }
}
