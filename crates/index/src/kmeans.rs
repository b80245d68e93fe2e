//! k-means by Lloyd's iterations, from initial centroids the caller chooses.
//!
//! S. P. Lloyd, "Least squares quantization in PCM", IEEE Transactions on Information Theory
//! 28(2), 1982. Each iteration:
//! 1. assigns every point to its nearest centroid (squared Euclidean distance in eight partial
//!    sums, [`crate::squared_distance_fast`]; ties to the lower index);
//! 2. stops if no point changed centroid since the previous iteration (the centroids would not
//!    move), or after [`KMeansParams::max_iterations`];
//! 3. moves each centroid to the mean of its points, summed in `f64` in point order, so that the
//!    result does not depend on the thread count; a centroid no point is nearest to is kept or
//!    moved to a far point, as [`KMeansParams::empty`] says.
//!
//! An iteration costs `O(n k d)` for `n` points, `k` centroids of `d` values. The choice of
//! initial centroids is the caller's: the inverted file (`ivf`) takes evenly spaced sample
//! points, the FPFH bag of words of `keycomp-bench` k-means++ (D. Arthur and
//! S. Vassilvitskii, "k-means++: the advantages of careful seeding", SODA 2007).

use rayon::prelude::*;

use crate::distance::squared_distance_fast;

/// What becomes of a centroid that no point is nearest to after an assignment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EmptyCluster {
    /// It stays where it is.
    Keep,
    /// It moves to the point farthest from its own centroid; empty centroids take points in
    /// their order, each point at most once.
    Farthest,
}

/// Parameters of [`kmeans`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KMeansParams {
    /// Most Lloyd iterations (assignment then update; default 50). Fewer stop earlier, with
    /// centroids less settled; iterations stop anyway once the assignment no longer changes.
    pub max_iterations: usize,
    /// What becomes of an empty cluster's centroid (default [`EmptyCluster::Keep`]).
    pub empty: EmptyCluster,
}

impl Default for KMeansParams {
    fn default() -> Self {
        KMeansParams {
            max_iterations: 50,
            empty: EmptyCluster::Keep,
        }
    }
}

/// The nearest of `centroids` (flat, `d` values each) to `p`, and its squared distance; ties
/// to the lower index (index 0 and an infinite distance when no distance is below infinity).
pub fn nearest_centroid(centroids: &[f32], d: usize, p: &[f32]) -> (usize, f32) {
    let mut best = (0, f32::INFINITY);
    for (i, c) in centroids.chunks_exact(d).enumerate() {
        let dist = squared_distance_fast(c, p);
        if dist < best.1 {
            best = (i, dist);
        }
    }
    best
}

/// k-means of `points` (`d` values each) from `centroids` (flat, `d` values each: `k` of them),
/// by Lloyd's iterations (see the [module docs](self)); returns the centroids, flat. Points and
/// centroids are assigned and averaged in parallel (rayon), with the same result for any
/// thread count.
pub fn kmeans(
    points: &[&[f32]],
    d: usize,
    mut centroids: Vec<f32>,
    params: KMeansParams,
) -> Vec<f32> {
    if d == 0 || points.is_empty() {
        return centroids;
    }
    let k = centroids.len() / d;
    let mut assignment: Vec<usize> = Vec::new();
    for _ in 0..params.max_iterations {
        let step: Vec<(usize, f32)> = points
            .par_iter()
            .map(|p| nearest_centroid(&centroids, d, p))
            .collect();
        if step.iter().map(|s| s.0).eq(assignment.iter().copied()) {
            break;
        }
        assignment = step.iter().map(|s| s.0).collect();
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); k];
        for (i, &c) in assignment.iter().enumerate() {
            members[c].push(i);
        }
        // means in f64, each cluster's points summed in point order
        let means: Vec<Option<Vec<f32>>> = members
            .par_iter()
            .map(|m| {
                if m.is_empty() {
                    return None;
                }
                let mut sum = vec![0f64; d];
                for &i in m {
                    for (s, v) in sum.iter_mut().zip(points[i]) {
                        *s += f64::from(*v);
                    }
                }
                Some(sum.iter().map(|s| (s / m.len() as f64) as f32).collect())
            })
            .collect();
        // each point's distance to its centroid, for empty clusters to take the farthest
        let mut far: Vec<f32> = Vec::new();
        for (j, mean) in means.into_iter().enumerate() {
            let target = &mut centroids[j * d..(j + 1) * d];
            match (mean, params.empty) {
                (Some(m), _) => target.copy_from_slice(&m),
                (None, EmptyCluster::Keep) => {}
                (None, EmptyCluster::Farthest) => {
                    if far.is_empty() {
                        far = step.iter().map(|s| s.1).collect();
                    }
                    let (i, _) =
                        far.iter()
                            .enumerate()
                            .fold((0, f32::NEG_INFINITY), |best, (i, &dist)| {
                                if dist > best.1 { (i, dist) } else { best }
                            });
                    far[i] = f32::NEG_INFINITY;
                    target.copy_from_slice(points[i]);
                }
            }
        }
    }
    centroids
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn refs(flat: &[f32], d: usize) -> Vec<&[f32]> {
        flat.chunks_exact(d).collect()
    }

    /// Four well separated clusters, one centroid started in each: the centroids end at the
    /// clusters' means, whatever the thread count.
    #[test]
    fn separated_clusters_are_recovered() {
        let d = 5;
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let centres = [0.0f32, 10.0, 20.0, 30.0];
        let flat: Vec<f32> = (0..400)
            .flat_map(|i| {
                let c = centres[i % 4];
                (0..d)
                    .map(|_| c + rng.random_range(-1.0..1.0))
                    .collect::<Vec<f32>>()
            })
            .collect();
        let points = refs(&flat, d);
        let start: Vec<f32> = (0..4).flat_map(|i| points[i].to_vec()).collect();
        let got = kmeans(&points, d, start.clone(), KMeansParams::default());
        for (c, centroid) in got.chunks_exact(d).enumerate() {
            let members: Vec<&[f32]> = points.iter().skip(c).step_by(4).copied().collect();
            for (v, x) in centroid.iter().enumerate() {
                let mean =
                    members.iter().map(|p| f64::from(p[v])).sum::<f64>() / members.len() as f64;
                assert_eq!(*x, mean as f32);
            }
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let one = pool.install(|| kmeans(&points, d, start.clone(), KMeansParams::default()));
        assert_eq!(got, one);
        let none = KMeansParams {
            max_iterations: 0,
            ..KMeansParams::default()
        };
        assert_eq!(kmeans(&points, d, start.clone(), none), start);
    }

    /// Two equal initial centroids: the second gets no point (ties go to the lower index). Kept,
    /// it takes the points near it later; moved to the farthest point, it takes that point's
    /// cluster at once.
    #[test]
    fn an_empty_cluster_is_kept_or_moved_to_the_farthest_point() {
        let flat = [0.0f32, 1.0, 10.0];
        let points = refs(&flat, 1);
        let keep = KMeansParams {
            max_iterations: 10,
            empty: EmptyCluster::Keep,
        };
        assert_eq!(kmeans(&points, 1, vec![0.0, 0.0], keep), vec![10.0, 0.5]);
        let farthest = KMeansParams {
            empty: EmptyCluster::Farthest,
            ..keep
        };
        assert_eq!(
            kmeans(&points, 1, vec![0.0, 0.0], farthest),
            vec![0.5, 10.0]
        );
        let one = KMeansParams {
            max_iterations: 1,
            ..keep
        };
        assert_eq!(
            kmeans(&points, 1, vec![0.0, 0.0], one),
            vec![(11.0f64 / 3.0) as f32, 0.0]
        );
    }

    #[test]
    fn nearest_centroid_ties_go_to_the_lower_index() {
        let c = [1.0f32, 1.0, 3.0, 3.0, 1.0, 1.0];
        assert_eq!(nearest_centroid(&c, 2, &[1.0, 1.0]), (0, 0.0));
        assert_eq!(nearest_centroid(&c, 2, &[2.0, 2.0]), (0, 2.0));
        assert_eq!(nearest_centroid(&c, 2, &[2.9, 3.0]).0, 1);
    }
}
