//! Settling the `k`-th place of an approximate search ([`Settle`]): a code's distance is
//! within a known bound of the true one, so the candidates whose bounds overlap the `k`-th
//! place's are told apart by their descriptors, read for those few only, and the rest are
//! placed by their codes.

/// The `k` nearest of `found` ([`Settle`]), nearest first, the open ones placed by
/// `exact(item)`.
#[cfg(test)]
pub(crate) fn resolve(
    found: &[(u32, f32, f32)],
    k: usize,
    exact: impl Fn(u32) -> Option<f32>,
) -> Vec<(u32, f32)> {
    Settle::new(found, k).finish(exact)
}

/// The `k` nearest of a search's candidates (items with a squared distance and the largest
/// error of its square root, as [`Ivf::search_bounded`](super::Ivf::search_bounded) gives
/// them): an item that fewer than `k` others may be nearer than is in, one that `k` others are
/// surely nearer than is out, and the places left go to the others ([`Settle::open`]) by their
/// true squared distances, so that codes whose distances are too close to tell apart at the
/// `k`-th place are told apart by the descriptors, read for those only.
pub(crate) struct Settle {
    k: usize,
    /// Items surely among the `k` nearest, with their codes' distances.
    sure: Vec<(u32, f32)>,
    /// Items that may be among them or not, with their codes' distances.
    open: Vec<(u32, f32)>,
}

impl Settle {
    /// Sorts `found` (items, codes' squared distances, errors of their square roots).
    pub(crate) fn new(found: &[(u32, f32, f32)], k: usize) -> Settle {
        if found.len() <= k {
            return Settle {
                k,
                sure: found.iter().map(|f| (f.0, f.1)).collect(),
                open: Vec::new(),
            };
        }
        let bounds: Vec<(f32, f32)> = found
            .iter()
            .map(|&(_, d, e)| {
                let r = d.max(0.0).sqrt();
                let lo = (r - e).max(0.0);
                (lo * lo, (r + e) * (r + e))
            })
            .collect();
        let mut los: Vec<f32> = bounds.iter().map(|b| b.0).collect();
        let mut his: Vec<f32> = bounds.iter().map(|b| b.1).collect();
        los.sort_by(f32::total_cmp);
        his.sort_by(f32::total_cmp);
        let (mut sure, mut open) = (Vec::new(), Vec::new());
        for (f, &(lo, hi)) in found.iter().zip(&bounds) {
            // others that may be nearer (the item itself counted when its own bounds differ)
            let may = los.partition_point(|&l| l < hi) - usize::from(lo < hi);
            // others surely nearer
            let surely = his.partition_point(|&h| h < lo);
            if may < k {
                sure.push((f.0, f.1));
            } else if surely < k {
                open.push((f.0, f.1));
            }
        }
        Settle { k, sure, open }
    }

    /// The items whose true distances are needed.
    pub(crate) fn open(&self) -> impl Iterator<Item = &u32> {
        self.open.iter().map(|o| &o.0)
    }

    /// The `k` nearest, nearest first (ties by item), the open items placed by `exact`.
    pub(crate) fn finish(self, exact: impl Fn(u32) -> Option<f32>) -> Vec<(u32, f32)> {
        let by = |a: &(u32, f32), b: &(u32, f32)| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0));
        let Settle { k, mut sure, open } = self;
        let mut open: Vec<(u32, f32)> = open
            .into_iter()
            .map(|(i, d)| (i, exact(i).unwrap_or(d)))
            .collect();
        open.sort_by(by);
        open.truncate(k.saturating_sub(sure.len()));
        sure.extend(open);
        sure.sort_by(by);
        // items of equal distances at the k-th place, all sure: the first by item
        sure.truncate(k);
        sure
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Found items as `search_bounded` gives them: true distances `truth`, code distances
    /// moved within `err` of them (in square roots).
    fn noisy(truth: &[f32], err: f32, rng: &mut ChaCha8Rng) -> Vec<(u32, f32, f32)> {
        let mut found: Vec<(u32, f32, f32)> = truth
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let r = (t.sqrt() + rng.random_range(-err..=err)).max(0.0);
                (i as u32, r * r, err)
            })
            .collect();
        found.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        found
    }

    proptest::proptest! {
        /// Whatever the rounding (within the bound given), the k nearest by true distance are
        /// the result, and descriptors are read only for items whose bounds overlap the k-th
        /// place's.
        #[test]
        fn resolve_gives_the_true_k_nearest(
            seed in 0u64..1000,
            n in 1usize..200,
            k in 1usize..80,
            err in 0.0f32..0.05,
        ) {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let truth: Vec<f32> = (0..n).map(|_| rng.random_range(0.0f32..1.0)).collect();
            let found = noisy(&truth, err, &mut rng);
            let reads = std::cell::Cell::new(0usize);
            let got = resolve(&found, k, |i| {
                reads.set(reads.get() + 1);
                Some(truth[i as usize])
            });
            let mut want: Vec<u32> = (0..n as u32).collect();
            want.sort_by(|a, b| truth[*a as usize].total_cmp(&truth[*b as usize]).then(a.cmp(b)));
            want.truncate(k);
            want.sort_unstable();
            let mut ids: Vec<u32> = got.iter().map(|g| g.0).collect();
            ids.sort_unstable();
            proptest::prop_assert_eq!(ids, want);
            if err == 0.0 || n <= k {
                proptest::prop_assert_eq!(reads.get(), 0);
            }
            // nearest first
            proptest::prop_assert!(got.windows(2).all(|w| w[0].1 <= w[1].1));
        }
    }

    #[test]
    fn resolve_breaks_ties_at_the_kth_place_by_item() {
        let found = [(4, 1.0, 0.0), (2, 2.0, 0.0), (9, 2.0, 0.0), (1, 2.0, 0.0)];
        let got = resolve(&found, 2, |_| panic!("no descriptor is needed"));
        assert_eq!(got, vec![(4, 1.0), (1, 2.0)]);
    }
}
