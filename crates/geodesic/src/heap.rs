//! An indexed 4-ary min-heap of (distance, vertex) with decrease-key.
//!
//! Every vertex is in the heap at most once (its slot is kept in `pos`), so a front pops each
//! vertex exactly once and the heap never holds more than the current trial band. Lowering a
//! tentative value sifts the entry up in place. Four children per node halve the depth of a
//! binary heap, and the four keys of a node's children are compared as a small tournament
//! (two independent comparisons, then one), which the compiler turns into conditional moves.
//! A heap with lazy deletion instead of decrease-key would pop every vertex about twice. On the
//! shallow trial band of a front this heap is faster than the exact monotone bucket queue of
//! [`crate::bucket`] (crate documentation, *Priority queue*).
//!
//! Push / decrease-key O(log₄ m), pop O(4 log₄ m), m = entries in the heap. Ties are broken
//! by position, deterministically.

use crate::queue::FrontQueue;

/// Marks a vertex that is not in the heap.
const NONE: u32 = u32::MAX;
/// Children per node.
const ARITY: usize = 4;

#[derive(Debug, Clone, Default)]
pub(crate) struct IndexedHeap {
    items: Vec<(f64, u32)>,
    /// Slot of each vertex in `items`, or [`NONE`].
    pos: Vec<u32>,
}

impl IndexedHeap {
    /// Empties the heap and sizes it for vertices `0..n`.
    pub(crate) fn reset(&mut self, n: usize) {
        if self.pos.len() == n {
            for &(_, v) in &self.items {
                self.pos[v as usize] = NONE;
            }
        } else {
            self.pos.clear();
            self.pos.resize(n, NONE);
        }
        self.items.clear();
    }

    /// Inserts `v` with `key`, or lowers its key if it is already in the heap (`key` must not
    /// exceed its current key).
    #[inline(always)]
    pub(crate) fn push_or_decrease(&mut self, key: f64, v: u32) {
        let mut i = self.pos[v as usize] as usize;
        if i == NONE as usize {
            i = self.items.len();
            self.items.push((key, v));
        }
        while i > 0 {
            let parent = (i - 1) / ARITY;
            let pe = self.items[parent];
            if pe.0 <= key {
                break;
            }
            self.items[i] = pe;
            self.pos[pe.1 as usize] = i as u32;
            i = parent;
        }
        self.items[i] = (key, v);
        self.pos[v as usize] = i as u32;
    }

    /// Removes the entry with the smallest key.
    #[inline]
    pub(crate) fn pop(&mut self) -> Option<(f64, u32)> {
        let top = *self.items.first()?;
        let last = self.items.pop()?;
        self.pos[top.1 as usize] = NONE;
        let n = self.items.len();
        if n == 0 {
            return Some(top);
        }
        let mut i = 0;
        loop {
            let c = ARITY * i + 1;
            if c >= n {
                break;
            }
            let (m, mk) = if c + ARITY <= n {
                let k = [
                    self.items[c].0,
                    self.items[c + 1].0,
                    self.items[c + 2].0,
                    self.items[c + 3].0,
                ];
                let (a, ak) = if k[1] < k[0] { (1, k[1]) } else { (0, k[0]) };
                let (b, bk) = if k[3] < k[2] { (3, k[3]) } else { (2, k[2]) };
                if bk < ak { (c + b, bk) } else { (c + a, ak) }
            } else {
                let mut m = c;
                let mut mk = self.items[c].0;
                for j in c + 1..n {
                    let k = self.items[j].0;
                    if k < mk {
                        m = j;
                        mk = k;
                    }
                }
                (m, mk)
            };
            if mk >= last.0 {
                break;
            }
            self.items[i] = self.items[m];
            self.pos[self.items[i].1 as usize] = i as u32;
            i = m;
        }
        self.items[i] = last;
        self.pos[last.1 as usize] = i as u32;
        Some(top)
    }
}

impl FrontQueue for IndexedHeap {
    #[inline(always)]
    fn push(&mut self, key: f64, v: u32) {
        self.push_or_decrease(key, v);
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(f64, u32)> {
        IndexedHeap::pop(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn matches_a_sorted_reference_under_decrease_key() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 500;
        let mut h = IndexedHeap::default();
        h.reset(n);
        let mut key = vec![f64::INFINITY; n];
        let mut done = vec![false; n];
        for _ in 0..5000 {
            let v = rng.random_range(0..n);
            let k = rng.random_range(0.0..100.0);
            if !done[v] && k < key[v] {
                key[v] = k;
                h.push_or_decrease(k, v as u32);
            }
            if rng.random_bool(0.3) {
                let best = (0..n)
                    .filter(|&u| !done[u] && key[u].is_finite())
                    .map(|u| key[u])
                    .fold(f64::INFINITY, f64::min);
                match h.pop() {
                    Some((k, u)) => {
                        assert_eq!(k, best);
                        assert_eq!(key[u as usize], k);
                        done[u as usize] = true;
                    }
                    None => assert!(best.is_infinite()),
                }
            }
        }
        h.reset(n);
        assert!(h.pop().is_none());
        assert!(h.pos.iter().all(|&p| p == NONE));
    }
}
