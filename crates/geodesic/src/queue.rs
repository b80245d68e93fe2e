//! The priority queue of a fast-marching front, as the solver's loop sees it ([`FrontQueue`]):
//! the indexed 4-ary heap ([`crate::heap`], the default) and the monotone bucket queues
//! ([`crate::bucket`]) implement it.

/// The priority queue of a front: insert-or-lower and pop-min, keys ≥ 0.
pub(crate) trait FrontQueue {
    /// Records that `v` has the tentative value `key`, lower than any value it had before.
    fn push(&mut self, key: f64, v: u32);
    /// Removes an entry with the smallest key (exact queues) or a key in the smallest
    /// non-empty bucket (untidy queue). May return *stale* entries — a vertex with a key it has
    /// since lowered, or a vertex already popped — which the caller must skip: a stale entry's
    /// key differs from the vertex's current value.
    fn pop(&mut self) -> Option<(f64, u32)>;
}
