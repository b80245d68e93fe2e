//! Matching two described shapes part to part ([`match_shapes`], [`match_weighted`]): the
//! steps of the crate documentation in order, the assignment ([`crate::assign`]), the
//! consistency checks ([`crate::checks`]), verification and the score ([`crate::score`]).

use crate::assign::{distances, pair};
use crate::checks::{Assigned, check};
use crate::params::MatchParams;
use crate::score::{ShapeMatch, finish};
use crate::view::ShapeView;

/// Matches the components of `query` to those of `target` (see the crate documentation),
/// every query component weighing the same.
pub fn match_shapes(query: ShapeView, target: ShapeView, params: &MatchParams) -> ShapeMatch {
    match_weighted(query, target, params, &[])
}

/// [`match_shapes`] with a weight per query component (`weights[i] ≥ 0`; missing or
/// non-finite weights count 1): the assignment maximises the weighted similarity and the
/// score is the weighted mean of the kept similarities over all query components.
pub fn match_weighted(
    query: ShapeView,
    target: ShapeView,
    params: &MatchParams,
    weights: &[f64],
) -> ShapeMatch {
    let d = distances(query.descriptors, target.descriptors);
    match_distances(query, target, &d, params, weights)
}

/// [`match_weighted`] given the distance matrix `d` ([`distances`]).
fn match_distances(
    query: ShapeView,
    target: ShapeView,
    d: &[f32],
    params: &MatchParams,
    weights: &[f64],
) -> ShapeMatch {
    match assign(query, target, d, params, weights) {
        Some(assigned) => finish(query, target, d, params, weights, assigned),
        None => ShapeMatch::none(),
    }
}

/// Steps 1–4 of [`match_distances`] (the assignment, the layout and size checks): see
/// [`Assigned`]. `None` when either shape has no parts.
fn assign(
    query: ShapeView,
    target: ShapeView,
    d: &[f32],
    params: &MatchParams,
    weights: &[f64],
) -> Option<Assigned> {
    let (mq, mt) = (query.descriptors.len(), target.descriptors.len());
    let matches = pair(mq, mt, d, params, weights)?;
    Some(check(query, target, matches, params))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assign::{distances, pair};
    use crate::score::{pairs_score, score_bound};
    use keycomp_describe::{DIM, Descriptor};

    fn desc(seed: usize) -> Descriptor {
        let mut d = [0f32; DIM];
        d[seed % DIM] = 1.0;
        d[(seed * 7 + 3) % DIM] += 0.5;
        d
    }

    /// Centres on a line at positions xs: layout = |xi − xj|.
    fn layout(xs: &[f32]) -> Vec<f32> {
        let m = xs.len();
        (0..m * m).map(|k| (xs[k / m] - xs[k % m]).abs()).collect()
    }

    #[test]
    fn identical_shapes_match_one_to_one_with_score_one() {
        let ds: Vec<Descriptor> = (0..5).map(desc).collect();
        let l = layout(&[0.0, 1.0, 2.5, 4.0, 7.0]);
        let v = ShapeView {
            descriptors: &ds,
            layout: &l,
            areas: &[],
            centres: &[],
            sample: &[],
        };
        let m = match_shapes(v, v, &MatchParams::default());
        assert_eq!(m.matches.len(), 5);
        assert!(m.matches.iter().all(|x| x.query == x.target));
        assert!((m.score - 1.0).abs() < 1e-9);
        assert_eq!(m.scale, Some(1.0));
    }

    #[test]
    fn permuted_and_scaled_target_is_found() {
        let xs = [0.0, 1.0, 2.5, 4.0, 7.0];
        let ds: Vec<Descriptor> = (0..5).map(desc).collect();
        let perm = [3, 0, 4, 1, 2]; // target component t holds query component perm[t]
        let dt: Vec<Descriptor> = perm.iter().map(|&p| ds[p]).collect();
        let xt: Vec<f32> = perm.iter().map(|&p| xs[p] * 3.0).collect();
        let (lq, lt) = (layout(&xs), layout(&xt));
        let m = match_shapes(
            ShapeView {
                descriptors: &ds,
                layout: &lq,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            ShapeView {
                descriptors: &dt,
                layout: &lt,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            &MatchParams::default(),
        );
        assert_eq!(m.matches.len(), 5);
        for x in &m.matches {
            assert_eq!(perm[x.target], x.query);
        }
        assert!((m.scale.expect("scale") - 3.0).abs() < 1e-6);
    }

    #[test]
    fn a_match_in_the_wrong_place_is_rejected() {
        let xs = [0.0, 1.0, 2.0, 3.0, 4.0];
        let ds: Vec<Descriptor> = (0..5).map(desc).collect();
        let mut xt = xs;
        xt[4] = 40.0; // same descriptor, far away from where it should be
        let (lq, lt) = (layout(&xs), layout(&xt));
        let m = match_shapes(
            ShapeView {
                descriptors: &ds,
                layout: &lq,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            ShapeView {
                descriptors: &ds,
                layout: &lt,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            &MatchParams::default(),
        );
        assert_eq!(m.rejected, 1);
        assert!(m.matches.iter().all(|x| x.query != 4));
        assert!((m.score - 0.8).abs() < 1e-9);
    }

    #[test]
    fn a_part_of_the_wrong_size_is_rejected() {
        // target three times as long: areas nine times as large, but part 2's is not
        let xs = [0.0, 1.0, 2.5, 4.0, 7.0];
        let ds: Vec<Descriptor> = (0..5).map(desc).collect();
        let xt: Vec<f32> = xs.iter().map(|x| x * 3.0).collect();
        let (lq, lt) = (layout(&xs), layout(&xt));
        let aq = [0.1f32, 0.2, 0.05, 0.1, 0.3];
        let mut at: Vec<f32> = aq.iter().map(|a| a * 9.0).collect();
        at[2] *= 6.0;
        let params = MatchParams {
            area_tolerance: 3.0,
            ..MatchParams::default()
        };
        let run = |at: &[f32], params: &MatchParams| {
            match_shapes(
                ShapeView {
                    descriptors: &ds,
                    layout: &lq,
                    areas: &aq,
                    centres: &[],
                    sample: &[],
                },
                ShapeView {
                    descriptors: &ds,
                    layout: &lt,
                    areas: at,
                    centres: &[],
                    sample: &[],
                },
                params,
            )
        };
        let m = run(&at, &params);
        assert_eq!(m.rejected, 1);
        assert!(m.matches.iter().all(|x| x.query != 2));
        // within the tolerance, or with the check off, or without areas: kept
        at[2] = aq[2] * 9.0 * 2.5;
        assert_eq!(run(&at, &params).rejected, 0);
        at[2] = aq[2] * 9.0 * 6.0;
        let off = MatchParams {
            area_tolerance: 0.0,
            ..params
        };
        assert_eq!(run(&at, &off).rejected, 0);
        assert_eq!(run(&[], &params).rejected, 0);
    }

    #[test]
    fn a_fragment_scores_by_its_own_components() {
        let ds: Vec<Descriptor> = (0..6).map(desc).collect();
        let l = layout(&[0.0, 1.0, 2.5, 4.0, 7.0, 9.0]);
        let part: Vec<Descriptor> = ds[1..4].to_vec();
        let lp = layout(&[1.0, 2.5, 4.0]);
        let m = match_shapes(
            ShapeView {
                descriptors: &part,
                layout: &lp,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            ShapeView {
                descriptors: &ds,
                layout: &l,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            &MatchParams::default(),
        );
        assert_eq!(m.matches.len(), 3);
        assert!((m.score - 1.0).abs() < 1e-9);
        // dissimilar descriptors do not match at all
        let far: Vec<Descriptor> = (0..3).map(|_| [5.0; DIM]).collect();
        let m = match_shapes(
            ShapeView {
                descriptors: &far,
                layout: &lp,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            ShapeView {
                descriptors: &ds,
                layout: &l,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            &MatchParams::default(),
        );
        assert!(m.matches.is_empty());
        assert_eq!(m.score, 0.0);
    }

    #[test]
    fn pairs_without_a_distance_are_not_held_against_a_match() {
        // five parts on a line plus a "whole" part with no layout distance (-1) to the others
        let ds: Vec<Descriptor> = (0..6).map(desc).collect();
        let mut l = layout(&[0.0, 1.0, 2.5, 4.0, 7.0, 0.0]);
        for i in 0..5 {
            l[i * 6 + 5] = -1.0;
            l[5 * 6 + i] = -1.0;
        }
        let v = ShapeView {
            descriptors: &ds,
            layout: &l,
            areas: &[],
            centres: &[],
            sample: &[],
        };
        let m = match_shapes(v, v, &MatchParams::default());
        assert_eq!(m.matches.len(), 6);
        assert_eq!(m.rejected, 0);
        assert!((m.score - 1.0).abs() < 1e-9);
    }

    proptest::proptest! {
        /// The bounds the ranking prunes with are never below the score, and the assignment's
        /// is the tighter: random descriptors near each other, random layouts and weights.
        #[test]
        fn score_bound_is_an_upper_bound(
            seed in 0u64..1000,
            mq in 1usize..9,
            mt in 1usize..9,
        ) {
            use rand::{Rng, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut descs = |m: usize| -> Vec<Descriptor> {
                (0..m)
                    .map(|_| std::array::from_fn(|_| rng.random_range(0.0f32..0.12)))
                    .collect()
            };
            let (dq, dt) = (descs(mq), descs(mt));
            let mut layout = |m: usize| -> Vec<f32> {
                (0..m * m).map(|k| if k / m == k % m { 0.0 } else { rng.random_range(0.1f32..2.0) }).collect()
            };
            let (lq, lt) = (layout(mq), layout(mt));
            let weights: Vec<f64> = (0..mq).map(|_| rng.random_range(0.0..2.0)).collect();
            let params = MatchParams::default();
            let q = ShapeView { descriptors: &dq, layout: &lq, areas: &[], centres: &[], sample: &[] };
            let t = ShapeView { descriptors: &dt, layout: &lt, areas: &[], centres: &[], sample: &[] };
            let m = match_weighted(q, t, &params, &weights);
            let d = distances(&dq, &dt);
            let bound = score_bound(mq, mt, &d, &params, &weights);
            let pairs = pair(mq, mt, &d, &params, &weights).unwrap_or_default();
            let assigned = pairs_score(mq, &pairs, &[], &params, &weights);
            proptest::prop_assert!(m.score <= assigned + 1e-12, "score {} assigned {}", m.score, assigned);
            proptest::prop_assert!(assigned <= bound + 1e-12, "assigned {} bound {}", assigned, bound);
        }
    }

    #[test]
    fn weights_scale_each_query_part() {
        let ds: Vec<Descriptor> = (0..4).map(desc).collect();
        let l = layout(&[0.0, 1.0, 2.5, 4.0]);
        let target: Vec<Descriptor> = ds[..2].to_vec();
        let lt = layout(&[0.0, 1.0]);
        let (q, t) = (
            ShapeView {
                descriptors: &ds,
                layout: &l,
                areas: &[],
                centres: &[],
                sample: &[],
            },
            ShapeView {
                descriptors: &target,
                layout: &lt,
                areas: &[],
                centres: &[],
                sample: &[],
            },
        );
        // parts 0 and 1 match exactly, 2 and 3 have no partner
        let plain = match_shapes(q, t, &MatchParams::default());
        assert!((plain.score - 0.5).abs() < 1e-9);
        let heavy = match_weighted(q, t, &MatchParams::default(), &[3.0, 3.0, 1.0, 1.0]);
        assert!((heavy.score - 0.75).abs() < 1e-9);
        // missing or invalid weights count 1
        let odd = match_weighted(q, t, &MatchParams::default(), &[f64::NAN]);
        assert!((odd.score - 0.5).abs() < 1e-9);
    }

    #[test]
    fn empty_shapes_give_no_match() {
        let ds: Vec<Descriptor> = (0..2).map(desc).collect();
        let l = layout(&[0.0, 1.0]);
        let e = ShapeView {
            descriptors: &[],
            layout: &[],
            areas: &[],
            centres: &[],
            sample: &[],
        };
        let v = ShapeView {
            descriptors: &ds,
            layout: &l,
            areas: &[],
            centres: &[],
            sample: &[],
        };
        assert_eq!(match_shapes(e, v, &MatchParams::default()).score, 0.0);
        assert_eq!(match_shapes(v, e, &MatchParams::default()).score, 0.0);
    }

    /// The same parts, the same geodesic layout: one target in the query's pose (scaled by
    /// 2), one with a limb bent (part 4 moved, its geodesic distances unchanged). The pose
    /// check ranks the first above the second, by a margin set by the weight, and changes
    /// nothing when it is off or when a side has no centres.
    #[test]
    fn a_bent_pose_scores_below_the_same_pose() {
        let xs = [0.0, 1.0, 2.0, 3.0, 4.0];
        let ds: Vec<Descriptor> = (0..5).map(desc).collect();
        let lq = layout(&xs);
        let lt = layout(&xs.map(|x| 2.0 * x));
        let straight: Vec<[f32; 3]> = xs.iter().map(|&x| [x, 0.0, 0.0]).collect();
        let same: Vec<[f32; 3]> = xs.iter().map(|&x| [2.0 * x, 5.0, -1.0]).collect();
        // part 4 folded back towards part 2: still 2 from part 3, but 2 from part 2 (not 4)
        let mut bent = same.clone();
        bent[4] = [5.0, 5.0 + 3f32.sqrt(), -1.0];
        let q = ShapeView {
            descriptors: &ds,
            layout: &lq,
            areas: &[],
            centres: &straight,
            sample: &[],
        };
        let t = |c: &[[f32; 3]], params: &MatchParams| {
            match_shapes(
                q,
                ShapeView {
                    descriptors: &ds,
                    layout: &lt,
                    areas: &[],
                    centres: c,
                    sample: &[],
                },
                params,
            )
        };
        let on = MatchParams {
            pose_weight: 0.5,
            ..MatchParams::default()
        };
        let (a, b) = (t(&same, &on), t(&bent, &on));
        assert_eq!(a.pose, Some(1.0));
        assert!((a.score - 1.0).abs() < 1e-9, "{}", a.score);
        // pairs (4, 0), (4, 1), (4, 2) disagree: 14 of 20 ordered pairs agree
        assert_eq!(b.pose, Some(14.0 / 20.0));
        // parts 0–2 agree with 3 of 4, part 3 with all, part 4 with 1 of 4
        let want = (3.0 * (1.0 - 0.5 * 0.25) + 1.0 + (1.0 - 0.5 * 0.75)) / 5.0;
        assert!((b.score - want).abs() < 1e-9, "{} against {want}", b.score);
        assert!(b.score < a.score);
        // off: both score 1
        let off = MatchParams::default();
        assert!((t(&bent, &off).score - 1.0).abs() < 1e-9);
        assert_eq!(t(&bent, &off).pose, None);
        // no centres on the target: no pose check either
        assert!((t(&[], &on).score - 1.0).abs() < 1e-9);
    }
}
