//! Monotone bucket queues for the fast-marching front, options to the indexed heap of
//! [`crate::heap`]; both implement [`FrontQueue`], the interface the solver's loop is generic
//! over.
//!
//! Fast marching pops tentative values in non-decreasing order, and every value it inserts lies
//! within a bounded *span* above the value just popped (an edge update adds `|xp|`, a two-point
//! update adds `s ≤ |xt|`; the solver takes the span as the longest edge or virtual edge). A
//! circular array of `B` buckets of width Δ with `B·Δ` above the span therefore holds the whole
//! trial band without collisions: the entry with key k lives in bucket `⌊k/Δ⌋ mod B`, and the
//! buckets are visited in order by a cursor that only moves forward.
//!
//! The idea is the *untidy priority queue* of L. Yatziv, A. Bartesaghi and G. Sapiro, "O(N)
//! implementation of the fast marching algorithm", *Journal of Computational Physics*
//! 212(2):393–399, 2006: O(1) insertion, a decrease-key is a fresh insertion (the superseded,
//! *stale* entry stays in its bucket and the caller skips it when it is popped: its key no longer
//! matches the vertex's distance), and the entries of one bucket leave in no particular order.
//! Two modes:
//!
//! * **exact** ([`BucketQueue::configure`] with `exact = true`): the current bucket is kept
//!   sorted (sorted when the cursor enters it, sorted insertion into it afterwards), so entries
//!   leave in exact (key, vertex id) order — the same values as a heap, with ties broken by
//!   vertex id, independently of insertion order;
//! * **untidy** (`exact = false`): the current bucket is a stack. A vertex may then be frozen
//!   before another one of the same bucket with a smaller value, an ordering error below Δ.
//!
//! Cost: insertion O(1) (exact mode, into the current bucket: O(bucket occupancy)); the pops
//! of a front cost O(entries + buckets crossed), the buckets crossed being (largest key)/Δ, plus
//! in exact mode sorting each bucket once (O(m log m) for m entries). A front is O(n) with the
//! untidy queue (Yatziv et al.'s point) and O(n log m) in exact mode. With a decrease-key being
//! an insertion, a front inserts one entry per update that lowered a value: about 2.1 per vertex
//! on our meshes, so half the pops are stale. [`BucketQueue::reset`] costs what the previous
//! front left in the queue (after an early stop) plus the buckets between.
//!
//! Measured against the indexed 4-ary heap (crate documentation, *Priority queue*): the trial
//! band of a 50k-vertex front holds only about 600 entries within about one edge length, so the
//! heap is shallow; the exact mode is 13–34 % slower (the sort, the stale pops and the bucket
//! scan add unpredictable branches: 2.4× the heap's branch misses on `icosphere(6)`), and the
//! untidy mode runs 11–13 % fewer instructions but only 0–10 % fewer cycles (the front is bound
//! by memory latency, not by the queue). Neither is the default.

use crate::queue::FrontQueue;

/// Largest number of buckets: beyond it the bucket width grows instead (see
/// [`BucketQueue::configure`]), so that the array stays within the first levels of cache.
pub(crate) const MAX_BUCKETS: usize = 1 << 14;

/// A circular array of buckets (see the module documentation).
#[derive(Debug, Clone, Default)]
pub(crate) struct BucketQueue {
    buckets: Vec<Vec<(f64, u32)>>,
    /// `buckets.len() − 1` (the length is a power of two).
    mask: u64,
    /// 1 / Δ.
    inv_width: f64,
    /// Absolute index of the current bucket (`⌊key/Δ⌋` of the keys it holds).
    cur: u64,
    /// Entries held, stale ones included.
    len: usize,
    /// Whether the current bucket is kept sorted.
    exact: bool,
}

/// Whether entry a leaves the queue after entry b (buckets are sorted in decreasing order and
/// popped from the end).
#[inline(always)]
fn after(a: (f64, u32), b: (f64, u32)) -> bool {
    a.0 > b.0 || (a.0 == b.0 && a.1 > b.1)
}

impl BucketQueue {
    /// Sets the bucket width `width` (> 0) and makes room for keys up to `span` above the last
    /// popped key; empties the queue. When `span / width` would need more than
    /// [`MAX_BUCKETS`] buckets, the width grows to `span / (MAX_BUCKETS − 2)`. Returns the width
    /// used.
    pub(crate) fn configure(&mut self, width: f64, span: f64, exact: bool) -> f64 {
        let span = if span.is_finite() && span > 0.0 {
            span
        } else {
            1.0
        };
        let mut width = if width.is_finite() && width > 0.0 {
            width
        } else {
            span
        };
        // two buckets of margin: the current one is partly behind the cursor, and rounding
        let mut count = (span / width).ceil() + 2.0;
        if count > MAX_BUCKETS as f64 {
            width = span / (MAX_BUCKETS - 2) as f64;
            count = MAX_BUCKETS as f64;
        }
        let count = (count as usize).next_power_of_two();
        self.buckets.iter_mut().for_each(Vec::clear);
        self.buckets.resize_with(count, Vec::new);
        self.buckets.truncate(count);
        self.mask = count as u64 - 1;
        self.inv_width = 1.0 / width;
        self.cur = 0;
        self.len = 0;
        self.exact = exact;
        width
    }

    /// Empties the queue (cost: the entries left, and the buckets they spread over).
    pub(crate) fn reset(&mut self) {
        while self.len > 0 {
            let b = &mut self.buckets[(self.cur & self.mask) as usize];
            self.len -= b.len();
            b.clear();
            self.cur += 1;
        }
        self.cur = 0;
    }

    /// Whether the queue holds no entry.
    #[cfg(test)]
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl FrontQueue for BucketQueue {
    #[inline(always)]
    fn push(&mut self, key: f64, v: u32) {
        // keys are ≥ the last popped one and within the span: the clamp only guards against
        // misuse (it keeps the queue consistent, not the order)
        let idx = ((key * self.inv_width) as u64).clamp(self.cur, self.cur + self.mask);
        debug_assert!(
            (key * self.inv_width) as u64 >= self.cur
                && ((key * self.inv_width) as u64) <= self.cur + self.mask,
            "key {key} outside the bucket window"
        );
        let b = &mut self.buckets[(idx & self.mask) as usize];
        self.len += 1;
        if self.exact && idx == self.cur {
            let e = (key, v);
            let mut i = b.len();
            while i > 0 && after(e, b[i - 1]) {
                i -= 1;
            }
            b.insert(i, e);
        } else {
            b.push((key, v));
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(f64, u32)> {
        if self.len == 0 {
            return None;
        }
        loop {
            if let Some(e) = self.buckets[(self.cur & self.mask) as usize].pop() {
                self.len -= 1;
                return Some(e);
            }
            self.cur += 1;
            if self.exact {
                let b = &mut self.buckets[(self.cur & self.mask) as usize];
                if b.len() > 1 {
                    b.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(b.1.cmp(&a.1)));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::heap::IndexedHeap;
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A fast-marching-like workload: pop the minimum, then lower the keys of a few random
    /// vertices to values in [popped, popped + span]. Returns the popped (key, vertex) of the
    /// live entries, in order, skipping stale ones as the solver does.
    /// With `coarse`, keys are multiples of 1/8 above the popped key, and ties are frequent.
    fn run<Q: FrontQueue>(
        q: &mut Q,
        n: usize,
        span: f64,
        seed: u64,
        coarse: bool,
    ) -> Vec<(f64, u32)> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut key = vec![f64::INFINITY; n];
        let mut done = vec![false; n];
        let mut out = Vec::new();
        key[0] = 0.0;
        q.push(0.0, 0);
        for _ in 0..20 * n {
            let Some((k, v)) = q.pop() else { break };
            if done[v as usize] || key[v as usize] != k {
                continue; // stale
            }
            done[v as usize] = true;
            out.push((k, v));
            for _ in 0..rng.random_range(1..6) {
                let w = rng.random_range(0..n);
                let step = rng.random_range(0.0..span);
                let c = k + if coarse {
                    ((step * 8.0).floor() + 1.0) / 8.0
                } else {
                    step
                };
                if !done[w] && c < key[w] {
                    key[w] = c;
                    q.push(c, w as u32);
                }
            }
        }
        out
    }

    #[test]
    fn exact_mode_pops_in_non_decreasing_order_and_matches_the_heap() {
        for seed in 0..20 {
            let mut b = BucketQueue::default();
            b.configure(0.05, 3.2, true);
            let got = run(&mut b, 2000, 3.0, seed, true);
            assert!(got.len() > 1000, "{}", got.len());
            assert!(got.windows(2).all(|w| w[0].0 <= w[1].0));
            // ties leave in vertex order
            assert!(got.windows(2).all(|w| w[0].0 < w[1].0 || w[0].1 < w[1].1));
            assert!(got.windows(2).any(|w| w[0].0 == w[1].0));
            // without ties, the same sequence as the heap
            b.reset();
            let got = run(&mut b, 2000, 3.0, seed, false);
            let mut h = IndexedHeap::default();
            h.reset(2000);
            assert_eq!(got, run(&mut h, 2000, 3.0, seed, false));
        }
    }

    #[test]
    fn untidy_mode_orders_buckets_only() {
        let width = 0.25;
        let mut b = BucketQueue::default();
        b.configure(width, 3.0, false);
        let got = run(&mut b, 2000, 3.0, 9, false);
        assert!(
            got.windows(2)
                .all(|w| (w[0].0 / width).floor() <= (w[1].0 / width).floor())
        );
        assert!(got.windows(2).any(|w| w[0].0 > w[1].0));
    }

    #[test]
    fn too_many_buckets_widen_them_and_reset_empties() {
        let mut b = BucketQueue::default();
        let w = b.configure(1e-9, 1.0, true);
        assert_eq!(b.buckets.len(), MAX_BUCKETS);
        assert!(w * (MAX_BUCKETS - 2) as f64 >= 1.0 * (1.0 - 1e-12));
        b.push(0.0, 1);
        b.push(0.5, 2);
        b.push(0.99, 3);
        assert_eq!(b.pop(), Some((0.0, 1)));
        b.reset();
        assert!(b.is_empty() && b.buckets.iter().all(Vec::is_empty));
        assert_eq!(b.pop(), None);
        // and it runs a new front from key 0
        b.push(0.0, 4);
        assert_eq!(b.pop(), Some((0.0, 4)));
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

        /// Exact buckets pop the same sequence as the indexed heap (keys drawn without ties), for
        /// any width and span.
        #[test]
        fn exact_buckets_agree_with_the_heap(
            seed in 0u64..1_000_000,
            n in 2usize..600,
            span in 0.01f64..10.0,
            width_frac in 0.001f64..2.0,
        ) {
            let mut b = BucketQueue::default();
            b.configure(width_frac * span, span, true);
            let got = run(&mut b, n, span, seed, false);
            let mut h = IndexedHeap::default();
            h.reset(n);
            let want = run(&mut h, n, span, seed, false);
            prop_assert!(got.windows(2).all(|w| w[0].0 <= w[1].0));
            prop_assert_eq!(got, want);
        }
    }
}
