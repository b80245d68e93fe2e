//! Retrieval quality of a labelled collection (`keycomp bench retrieval`): whole-shape and
//! partial queries, the Princeton Shape Benchmark measures ([`metrics`]), two baselines, the D2
//! shape distribution ([`d2`]) and an FPFH bag of words ([`fpfh`]), both drawing their points
//! with one area sampler ([`keycomp_mesh::sample`]), and class labels ([`labels`]); the
//! partial queries are cut from the collection by `keycomp_fragment`.
//!
//! The command (in the `keycomp` binary) ranks the collection for every query by
//! key-components through the on-disk index and `keycomp_retrieval::rank`, by D2 histogram
//! distance and by the cosine distance of FPFH bags of words, and scores every ranking with
//! the same measures. This module holds what does not depend on the product: the measures, the
//! baselines and [`complete_ranking`], which turns a partial result list into a
//! ranking of the whole collection.

pub mod d2;
pub mod fpfh;
pub mod labels;
pub mod metrics;

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use crate::svg::{Curve, line_plot_svg};

/// A ranking of every collection shape but `exclude` (the query itself, for whole-shape
/// queries): first `returned` (shape indices in the order the method returned them; duplicates,
/// out-of-range indices and `exclude` are dropped), then every shape the method did not return,
/// in a random order drawn from `seed`.
///
/// A method that returns nothing for a shape gives no information about it; ranking the rest
/// by a seeded shuffle scores it as a random guess would (in expectation), rather than favouring
/// whatever order the files happen to be listed in.
pub fn complete_ranking(
    returned: &[usize],
    n: usize,
    exclude: Option<usize>,
    seed: u64,
) -> Vec<usize> {
    let mut used = vec![false; n];
    if let Some(e) = exclude.filter(|&e| e < n) {
        used[e] = true;
    }
    let mut out = Vec::with_capacity(n);
    for &i in returned {
        if i < n && !used[i] {
            used[i] = true;
            out.push(i);
        }
    }
    let mut rest: Vec<usize> = (0..n).filter(|&i| !used[i]).collect();
    rest.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    out.extend(rest);
    out
}

/// Indices of `distances` from nearest to farthest (ties by index), leaving out `exclude`.
pub fn rank_by_distance(distances: &[f64], exclude: Option<usize>) -> Vec<usize> {
    let mut order: Vec<usize> = (0..distances.len())
        .filter(|&i| Some(i) != exclude)
        .collect();
    order.sort_by(|&a, &b| distances[a].total_cmp(&distances[b]).then(a.cmp(&b)));
    order
}

/// A precision–recall plot (SVG) of mean interpolated precision at the recall levels of
/// [`metrics::PR_LEVELS`], one curve per method.
pub fn pr_svg(title: &str, curves: &[Curve]) -> String {
    let levels: Vec<f64> = (0..metrics::PR_LEVELS).map(metrics::recall_level).collect();
    line_plot_svg(title, "Recall", "Precision", &levels, curves)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn completion_keeps_the_returned_order_and_covers_the_rest_once() {
        let r = complete_ranking(&[4, 2, 4, 9, 0], 6, Some(0), 7);
        assert_eq!(&r[..2], &[4, 2]);
        let mut sorted = r.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, [1, 2, 3, 4, 5]);
        assert_eq!(r, complete_ranking(&[4, 2, 4, 9, 0], 6, Some(0), 7));
        // the tail is shuffled: over seeds, shape 1 is not always first after the returned ones
        let firsts: std::collections::BTreeSet<usize> = (0..20)
            .map(|s| complete_ranking(&[], 6, None, s)[0])
            .collect();
        assert!(firsts.len() > 2, "{firsts:?}");
    }

    #[test]
    fn distance_ranking() {
        assert_eq!(rank_by_distance(&[0.3, 0.1, 0.3, 0.0], Some(3)), [1, 0, 2]);
        assert_eq!(rank_by_distance(&[0.3, 0.1], None), [1, 0]);
    }

    #[test]
    fn pr_plot_has_the_axes() {
        let svg = pr_svg(
            "whole",
            &[Curve {
                label: "D2".into(),
                values: vec![0.5; metrics::PR_LEVELS],
            }],
        );
        assert!(svg.contains(">Recall<") && svg.contains(">Precision<"));
        assert_eq!(svg.matches("<polyline").count(), 1);
    }
}
