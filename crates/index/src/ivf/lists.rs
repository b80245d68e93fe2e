//! The inverted file's structure ([`Ivf`]): the coarse and fine centroids, the items of each
//! fine cell (its inverted list) with their codes, and what is derived from them: an item's
//! cell, a new item's nearest cell, how far a code may be from its descriptor.

use crate::distance::squared_distance_fast;
use crate::kmeans::nearest_centroid;

use super::quantiser::Sq;

/// The inverted file (see the [`ivf`](super) module documentation).
#[derive(Debug, PartialEq)]
pub(crate) struct Ivf {
    pub(super) d: usize,
    /// Coarse centroids, flat.
    pub(super) coarse: Vec<f32>,
    /// Per coarse cell: its fine centroids, flat.
    pub(super) fine: Vec<Vec<f32>>,
    /// Per coarse cell: the global number of its first fine cell.
    pub(super) bases: Vec<usize>,
    /// Per coarse cell, per fine cell: the range of `items` / `data` it holds.
    pub(super) ranges: Vec<Vec<(u32, u32)>>,
    /// Item ids (positions in the reader's component list), grouped by fine cell.
    pub(super) items: Vec<u32>,
    /// The quantiser of the residuals.
    pub(super) pq: Sq,
    /// The first bytes of the codes of `items`, in the same order, `pq.bytes()` each.
    pub(super) codes: Vec<u8>,
    /// The second bytes of the same codes, laid out alike.
    pub(super) refine: Vec<u8>,
    /// Items the centroids were fitted on.
    pub(super) trained: usize,
}

impl Ivf {
    /// For each item, its place in cell order (the inverse of `items`).
    pub(super) fn places(&self) -> Vec<u32> {
        let mut place = vec![0u32; self.items.len()];
        for (j, &i) in self.items.iter().enumerate() {
            place[i as usize] = j as u32;
        }
        place
    }

    /// The global fine cell `g`'s centroid, if there is one.
    pub(super) fn fine_centroid(&self, g: usize) -> Option<&[f32]> {
        let d = self.d;
        // the last coarse cell whose first fine cell is not beyond g (empty ones share it)
        let ci = self.bases.partition_point(|&b| b <= g).checked_sub(1)?;
        let k = g - self.bases[ci];
        self.fine[ci].get(k * d..(k + 1) * d)
    }

    /// The global fine cell nearest `p`: in the nearest coarse cell that has fine cells, the
    /// nearest fine centroid (fine cells numbered coarse cell by coarse cell); `None` when no
    /// coarse cell has fine cells (a damaged cache). A distance that is not a number or is
    /// infinite loses to every finite one, and the first such cell is taken when none is finite.
    pub(super) fn assign(&self, p: &[f32]) -> Option<u32> {
        let d = self.d;
        let mut best: Option<(f32, usize)> = None;
        for (i, c) in self.coarse.chunks_exact(d).enumerate() {
            if self.fine[i].is_empty() {
                continue;
            }
            let dist = match squared_distance_fast(c, p) {
                x if x.is_nan() => f32::INFINITY,
                x => x,
            };
            if best.is_none_or(|(b, _)| dist < b) {
                best = Some((dist, i));
            }
        }
        let (_, cell) = best?;
        u32::try_from(self.bases[cell] + nearest_centroid(&self.fine[cell], d, p).0).ok()
    }

    /// Each item's global fine cell.
    pub(super) fn cells(&self) -> Vec<u32> {
        let mut cell = vec![0u32; self.items.len()];
        let mut g = 0u32;
        for ranges in &self.ranges {
            for &(start, end) in ranges {
                for j in start..end {
                    cell[self.items[j as usize] as usize] = g;
                }
                g += 1;
            }
        }
        cell
    }

    /// The inverted file of `n` items with these centroids and quantiser, item `i` in global
    /// fine cell `cell[i]` (fine cells numbered coarse cell by coarse cell), every code zero
    /// (the caller writes them, in cell order). Each cell lists its items in increasing order.
    /// `None` when the parts do not fit together (a damaged cache).
    pub(super) fn from_cells(
        n: usize,
        d: usize,
        coarse: Vec<f32>,
        fine: Vec<Vec<f32>>,
        pq: Sq,
        cell: &[u32],
        trained: usize,
    ) -> Option<Ivf> {
        let m = pq.bytes();
        if d == 0
            || cell.len() != n
            || !coarse.len().is_multiple_of(d)
            || coarse.len() / d != fine.len()
            || fine.iter().any(|f| !f.len().is_multiple_of(d))
        {
            return None;
        }
        let cells: usize = fine.iter().map(|f| f.len() / d).sum();
        if !pq.fits(d, cells) {
            return None;
        }
        let mut counts = vec![0u32; cells + 1];
        for &c in cell {
            *counts.get_mut(c as usize + 1)? += 1;
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        let mut next = counts.clone();
        let mut items = vec![0u32; n];
        for (i, &c) in cell.iter().enumerate() {
            let slot = &mut next[c as usize];
            items[*slot as usize] = i as u32;
            *slot += 1;
        }
        let mut ranges = Vec::with_capacity(fine.len());
        let mut bases = Vec::with_capacity(fine.len());
        let mut g = 0;
        for f in &fine {
            let r: Vec<(u32, u32)> = (0..f.len() / d)
                .map(|k| (counts[g + k], counts[g + k + 1]))
                .collect();
            bases.push(g);
            g += r.len();
            ranges.push(r);
        }
        Some(Ivf {
            d,
            coarse,
            fine,
            bases,
            ranges,
            items,
            pq,
            codes: vec![0u8; n.checked_mul(m)?],
            refine: vec![0u8; n.checked_mul(m)?],
            trained,
        })
    }

    /// The largest distance between a residual within its cell's ranges and the one its code
    /// stands for (half a level per value, in the cell of the coarsest levels): the square root
    /// of a code's squared distance to a query differs from the true one by at most this, for
    /// parts within the ranges of their cells (every part the cells were built with; a part
    /// put in a cell later may lie beyond, and its end levels may differ more).
    pub(crate) fn code_error(&self) -> f32 {
        let d = self.pq.bytes().max(1);
        self.pq
            .step
            .chunks(d)
            .map(|cell| {
                cell.iter()
                    .map(|s| (0.5 * s) * (0.5 * s))
                    .sum::<f32>()
                    .sqrt()
            })
            .fold(0.0, f32::max)
    }

    /// Bytes held (centroids, items, codes and the quantiser).
    pub(crate) fn bytes(&self) -> usize {
        4 * (self.coarse.len()
            + self.fine.iter().map(Vec::len).sum::<usize>()
            + self.items.len()
            + 2 * self.pq.min.len())
            + self.codes.len()
            + self.refine.len()
            + 8 * self.ranges.iter().map(Vec::len).sum::<usize>()
    }
}
