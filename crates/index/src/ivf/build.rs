//! Building the inverted file from the descriptors ([`Ivf::build`]):
//! 1. `c = ⌈√(n / CELL_SIZE)⌉` coarse centroids by k-means over a sample of all the
//!    descriptors, and every descriptor assigned to its nearest;
//! 2. per coarse cell, `c` fine centroids by k-means over a sample of its members, and every
//!    descriptor assigned to the nearest fine centroid of its coarse cell;
//! 3. per fine cell, the range of each residual value over its members (the scalar quantiser's
//!    levels), and every descriptor's code.
//!
//! k-means ([`crate::kmeans`]) starts from evenly spaced points of an evenly spaced sample of
//! [`SAMPLE_PER_CENTROID`] points per centroid, runs [`ITERATIONS`] Lloyd iterations and keeps
//! an emptied cluster's centroid: the result depends on the descriptors only, whatever the
//! thread count. Assigning costs `O(n c d)` per level for `n` descriptors of `d` values.
//! Every pass over all the descriptors reads them in item order, the order they are stored in:
//! on an index larger than memory, any other order rereads them from disk.

use rayon::prelude::*;

use crate::kmeans::{EmptyCluster, KMeansParams, kmeans, nearest_centroid};

use super::lists::Ivf;
use super::quantiser::Sq;

/// Descriptors per fine cell aimed at.
pub const CELL_SIZE: usize = 512;
/// Lloyd iterations of each k-means.
const ITERATIONS: usize = 8;
/// Sample points per centroid that k-means is fitted on.
const SAMPLE_PER_CENTROID: usize = 48;

/// The descriptors an inverted file is built on: point `i` for `i < len()`, `dim()` values
/// each (the reader's live descriptors in place, or a flat array).
pub(crate) trait Points: Sync {
    /// How many points.
    fn len(&self) -> usize;
    /// Point `i` (`i < len()`).
    fn point(&self, i: u32) -> &[f32];
}

/// Points stored one after the other in one array, `d` values each.
pub(crate) struct Flat<'a> {
    /// The values.
    pub data: &'a [f32],
    /// Values per point.
    pub d: usize,
}

impl Points for Flat<'_> {
    fn len(&self) -> usize {
        self.data.len() / self.d.max(1)
    }
    fn point(&self, i: u32) -> &[f32] {
        &self.data[i as usize * self.d..(i as usize + 1) * self.d]
    }
}

/// `k` centroids (flat; fewer when there are fewer members) of the points `points.point(i)`
/// for `i` in `members`, fitted on about `k × SAMPLE_PER_CENTROID` evenly spaced members,
/// starting from evenly spaced ones of them.
fn centroids(points: &impl Points, d: usize, members: &[u32], k: usize) -> Vec<f32> {
    let sample_size = k * SAMPLE_PER_CENTROID;
    let k = k.clamp(1, members.len().max(1));
    let step = (members.len() / sample_size.max(k)).max(1);
    let sample: Vec<&[f32]> = members
        .iter()
        .step_by(step)
        .map(|&i| points.point(i))
        .collect();
    let start: Vec<f32> = (0..k)
        .flat_map(|j| sample[j * sample.len() / k].to_vec())
        .collect();
    let params = KMeansParams {
        max_iterations: ITERATIONS,
        empty: EmptyCluster::Keep,
    };
    kmeans(&sample, d, start, params)
}

impl Ivf {
    /// Builds the inverted file of `points` (`d` values each; item `i` is point `i`).
    pub(crate) fn build(points: &impl Points, d: usize) -> Ivf {
        let n = points.len();
        let c = ((n as f64 / CELL_SIZE as f64).sqrt().ceil() as usize).max(1);
        let all: Vec<u32> = (0..n as u32).collect();
        let coarse = centroids(points, d, &all, c);
        let point = |i: u32| points.point(i);
        let top: Vec<u32> = all
            .par_iter()
            .map(|&i| nearest_centroid(&coarse, d, point(i)).0 as u32)
            .collect();
        let mut members: Vec<Vec<u32>> = vec![Vec::new(); coarse.len() / d];
        for (i, &t) in top.iter().enumerate() {
            members[t as usize].push(i as u32);
        }
        // each coarse cell's fine centroids, fitted on a sample of its members
        let fine: Vec<Vec<f32>> = members
            .par_iter()
            .map(|m| {
                if m.is_empty() {
                    Vec::new()
                } else {
                    centroids(points, d, m, c)
                }
            })
            .collect();
        drop(members);
        let mut bases = Vec::with_capacity(fine.len());
        let mut base = 0u32;
        for f in &fine {
            bases.push(base);
            base += (f.len() / d) as u32;
        }
        let cell: Vec<u32> = all
            .par_iter()
            .map(|&i| {
                let t = top[i as usize] as usize;
                bases[t] + nearest_centroid(&fine[t], d, point(i)).0 as u32
            })
            .collect();
        drop(top);
        Ivf::with_cells(points, d, coarse, fine, &cell)
    }

    /// The inverted file of `points` (`d` values each) with these centroids, item `i` in
    /// global fine cell `cell[i]` (fine cells numbered coarse cell by coarse cell, each in
    /// range): the quantiser fitted to the cells' residuals, and every item's code.
    pub(super) fn with_cells(
        points: &impl Points,
        d: usize,
        coarse: Vec<f32>,
        fine: Vec<Vec<f32>>,
        cell: &[u32],
    ) -> Ivf {
        let n = points.len();
        let point = |i: u32| points.point(i);
        // the quantiser: each fine cell's range of each residual value, over all its members
        let flat_fine = fine.concat();
        let cells = flat_fine.len() / d;
        let residual = |i: u32| -> Vec<f32> {
            let g = cell[i as usize] as usize;
            let c = &flat_fine[g * d..(g + 1) * d];
            point(i).iter().zip(c).map(|(v, c)| v - c).collect()
        };
        const PIECE: usize = 1 << 16;
        let pieces = n.div_ceil(PIECE);
        let empty = || {
            (
                vec![f32::INFINITY; cells * d],
                vec![f32::NEG_INFINITY; cells * d],
            )
        };
        let (lo, hi) = (0..pieces)
            .into_par_iter()
            // a few accumulators (each holds two values per cell and descriptor value)
            .with_min_len(pieces.div_ceil(4).max(1))
            .fold(empty, |(mut lo, mut hi), p| {
                let items = p * PIECE..((p + 1) * PIECE).min(n);
                for (i, &g) in items.clone().zip(&cell[items]) {
                    let g = g as usize;
                    let c = &flat_fine[g * d..(g + 1) * d];
                    let (lo, hi) = (&mut lo[g * d..(g + 1) * d], &mut hi[g * d..(g + 1) * d]);
                    for (((l, h), v), c) in lo.iter_mut().zip(hi).zip(point(i as u32)).zip(c) {
                        let r = v - c;
                        *l = l.min(r);
                        *h = h.max(r);
                    }
                }
                (lo, hi)
            })
            .reduce(empty, |(mut lo, mut hi), (l, h)| {
                lo.iter_mut().zip(l).for_each(|(a, b)| *a = a.min(b));
                hi.iter_mut().zip(h).for_each(|(a, b)| *a = a.max(b));
                (lo, hi)
            });
        let pq = Sq::from_ranges(&lo, &hi, d);
        drop((lo, hi));
        let mut ivf = Ivf::from_cells(n, d, coarse, fine, pq, cell, n)
            .expect("cells computed from the centroids are in range");
        // the codes, items in item order a block at a time, each put in its place
        let m = ivf.pq.bytes();
        let place = ivf.places();
        const BLOCK: usize = 1 << 18;
        let mut block = vec![0u8; BLOCK * m];
        let mut second = vec![0u8; BLOCK * m];
        for start in (0..n).step_by(BLOCK) {
            let len = (n - start).min(BLOCK);
            let pq = &ivf.pq;
            block[..len * m]
                .par_chunks_mut(m)
                .zip(second[..len * m].par_chunks_mut(m))
                .enumerate()
                .for_each(|(k, (a, b))| {
                    let i = start + k;
                    pq.encode(cell[i] as usize, &residual(i as u32), a, b)
                });
            for k in 0..len {
                let j = place[start + k] as usize;
                ivf.codes[j * m..(j + 1) * m].copy_from_slice(&block[k * m..(k + 1) * m]);
                ivf.refine[j * m..(j + 1) * m].copy_from_slice(&second[k * m..(k + 1) * m]);
            }
        }
        ivf
    }
}
