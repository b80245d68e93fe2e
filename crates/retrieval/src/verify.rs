//! Geometric verification: how much of the query's surface lies on the target's once the query
//! is moved onto it (see [`crate::MatchParams::verify_weight`]).
//!
//! 1. **Alignment from the matched parts.** Every kept match pairs a query part's centre with a
//!    target part's centre. RANSAC (M. A. Fischler, R. C. Bolles, "Random sample consensus",
//!    Communications of the ACM 24(6), 1981) over triples of matches: each triple gives the
//!    least-squares similarity transform (rotation, translation and, unless both shapes are in
//!    file units, a uniform scale; S. Umeyama, "Least-squares estimation of transformation
//!    parameters between two point patterns", IEEE TPAMI 13(4), 1991); the transform that brings
//!    most query centres within [`CENTRE_TOLERANCE`] times the tolerance of their partners wins
//!    and is fitted again on those inliers. Every triple when there are at most
//!    [`ALL_TRIPLES_UP_TO`] matches, else [`HYPOTHESES`] drawn by a seeded generator.
//! 2. **Refinement on the surfaces.** ICP (P. J. Besl, N. D. McKay, "A method for registration
//!    of 3-D shapes", IEEE TPAMI 14(2), 1992) of the query's surface sample onto the target's:
//!    [`ICP_ITERATIONS`] rounds of nearest neighbours (a KD-tree over the target's sample),
//!    pairs beyond three tolerances left out, and the transform fitted again; the scale stays
//!    within [`SCALE_DRIFT`] of the alignment's.
//! 3. **Fitness**: the fraction of the query's sample points within the tolerance of the
//!    target's sample. The exact source of a fragment scores near 1, the same parts in another
//!    pose less (what moved is off the surface), another shape less still.
//!
//! Cost: at most [`HYPOTHESES`] transforms checked against the matches, then
//! [`ICP_ITERATIONS`] × (sample size) KD-tree look-ups: well under a millisecond per pair.

use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use nalgebra::{Matrix3, Vector3};

use crate::ShapeView;

/// Tentative pairs per query part: its nearest target parts in descriptor space.
pub const PAIRS_PER_PART: usize = 3;
/// Most tentative pairs, the nearest in descriptor space first, checked against a transform.
pub const MAX_PAIRS: usize = 300;
/// The nearest pairs whose triples give the transforms tried.
pub const SEED_PAIRS: usize = 60;
/// Most transforms tried.
pub const HYPOTHESES: usize = 3000;
/// Largest factor by which the straight-line distances between two pairs' centres may
/// disagree (after the scale) for the pairs to be taken together.
pub const RATIO_TOLERANCE: f64 = 1.2;
/// ICP rounds.
pub const ICP_ITERATIONS: usize = 12;
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
}

/// What verification found: the alignment and how well the query fits under it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Verified {
    /// The share of the query's sample within the tolerance of the target's.
    pub fitness: f64,
    transform: Similarity,
    tolerance: f64,
}

impl Verified {
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
/// file units, `None` when the scale is unknown; `tolerance` in the target's length unit.
/// `None` when either shape has no centres or no sample, or fewer than three pairs have
/// centres (nothing to align with).
pub(crate) fn fitness(
    query: ShapeView,
    target: ShapeView,
    tentative: &[(usize, usize, f32)],
    fixed_scale: Option<f64>,
    tolerance: f64,
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
    let m = n.min(SEED_PAIRS);
    let ratio_of = |a: usize, b: usize| -> Option<f64> {
        let (x, y) = (pairs[a], pairs[b]);
        if x.0 == y.0 || x.1 == y.1 {
            return None;
        }
        let (eq, et) = ((src[a] - src[b]).norm(), (dst[a] - dst[b]).norm());
        if !(eq > 0.0 && et > 0.0) {
            return None;
        }
        let r = et / eq;
        let ok = match fixed_scale {
            Some(s) => (et - s * eq).abs() <= (RATIO_TOLERANCE - 1.0) * et.max(s * eq) + tol,
            None => (SCALE_RANGE.0..=SCALE_RANGE.1).contains(&r),
        };
        ok.then_some(r)
    };
    // every seed pair's ratio with every other, computed once
    let ratios: Vec<Option<f64>> = (0..m * m).map(|k| ratio_of(k / m, k % m)).collect();
    let ratio = |a: usize, b: usize| ratios[a * m + b];
    let agree = |r: f64, q: f64| r <= q * RATIO_TOLERANCE && q <= r * RATIO_TOLERANCE;
    let mut triples: Vec<[usize; 3]> = Vec::new();
    'seeds: for a in 0..m {
        for b in a + 1..m {
            let Some(rab) = ratio(a, b) else { continue };
            for c in b + 1..m {
                let (Some(rac), Some(rbc)) = (ratio(a, c), ratio(b, c)) else {
                    continue;
                };
                if fixed_scale.is_some() || (agree(rab, rac) && agree(rab, rbc)) {
                    triples.push([a, b, c]);
                    if triples.len() >= HYPOTHESES {
                        break 'seeds;
                    }
                }
            }
        }
    }
    let mut best: Option<(usize, Similarity)> = None;
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
        let count = (0..n).filter(|&i| is_inlier(&t, i)).count();
        if best.as_ref().is_none_or(|(k, _)| count > *k) {
            best = Some((count, t));
        }
    }
    let (_, mut t) = best?;
    let inliers: Vec<usize> = (0..n).filter(|&i| is_inlier(&t, i)).collect();
    if inliers.len() >= 3 {
        let s: Vec<_> = inliers.iter().map(|&i| src[i]).collect();
        let d: Vec<_> = inliers.iter().map(|&i| dst[i]).collect();
        if let Some(refit) = umeyama(&s, &d, fixed_scale)
            && scale_ok(refit.s)
        {
            t = refit;
        }
    }
    // 2. ICP of the query's sample onto the target's
    let targets: Vec<[f64; 3]> = target
        .sample
        .iter()
        .map(|p| [p[0] as f64, p[1] as f64, p[2] as f64])
        .collect();
    let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(&targets);
    let q: Vec<Vector3<f64>> = query.sample.iter().map(point).collect();
    let nearest = |t: &Similarity, p: &Vector3<f64>| {
        let x = t.apply(p);
        let nb = tree.nearest_one::<SquaredEuclidean>(&[x.x, x.y, x.z]);
        (nb.distance, nb.item as usize)
    };
    let base_scale = t.s;
    let keep2 = (3.0 * tol).powi(2);
    let (mut s, mut d) = (Vec::with_capacity(q.len()), Vec::with_capacity(q.len()));
    for _ in 0..ICP_ITERATIONS {
        s.clear();
        d.clear();
        for p in &q {
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
        if moved < 1e-6 {
            break;
        }
    }
    // 3. the share of the query's sample on the target's surface
    let tol2 = tol * tol;
    let on = q.iter().filter(|p| nearest(&t, p).0 <= tol2).count();
    Some(Verified {
        fitness: on as f64 / q.len() as f64,
        transform: t,
        tolerance: tol,
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
        let view = |centres: &'static [[f32; 3]], sample: &'static [[f32; 3]]| ShapeView {
            descriptors: &[],
            layout: &[],
            areas: &[],
            centres,
            sample,
        };
        let leak = |v: Vec<[f32; 3]>| -> &'static [[f32; 3]] { Vec::leak(v) };
        let (qc, tc, part) = (leak(qc), leak(tc), leak(part));
        let f = fitness(
            view(qc, part),
            view(tc, leak(whole.clone())),
            &matches,
            None,
            0.02,
        )
        .expect("verified")
        .fitness;
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
        let g = fitness(view(qc, part), view(tc, leak(bent)), &matches, None, 0.02)
            .expect("verified")
            .fitness;
        assert!(g < 0.9 * f, "fitness on the bent copy {g}, source {f}");
        // fewer than three matches or no sample: nothing to verify
        assert!(fitness(view(qc, part), view(tc, &[]), &matches, None, 0.02).is_none());
        assert!(fitness(view(qc, part), view(tc, part), &matches[..2], None, 0.02).is_none());
    }
}
