//! Searching the inverted file ([`Ivf::search_bounded`]) for the `k` nearest items to a query:
//! 1. rank the coarse centroids, keep the [`COARSE_PROBES`] nearest;
//! 2. rank their fine cells by the distance from the query to each cell's box (the points its
//!    codes can stand for, [`Sq::box_distance`]), keep the [`FINE_PROBES`] nearest (at most
//!    [`FINE_SHARE`] of all fine cells, at least [`MIN_FINE_PROBES`]);
//! 3. scan them nearest box first, ranking every code by its first bytes
//!    ([`Sq::coarse_distance`]), and stop at the first cell whose box is farther than the
//!    [`RERANK`]` × k`-th nearest code found so far: no code of it or of the cells after it
//!    could enter them (branch and bound, Fukunaga and Narendra 1975);
//! 4. rank those [`RERANK`]` × k` again by their whole codes ([`Sq::distance`]), each with the
//!    bound of its error that [`Settle`](super::settle::Settle) uses to settle the `k`-th
//!    place.
//!
//! A step costs `O(c d)` for the coarse ranking, `O(c d)` for the boxes of the probed coarse
//! cells' fine cells, and `O(m d)` for the `m` codes scanned (about [`CELL_SIZE`] per cell). No
//! descriptor is read. [`SearchEffort`] sets how much is read: more is slower and misses fewer
//! true neighbours.

use crate::distance::squared_distance_fast;

use super::build::CELL_SIZE;
use super::lists::Ivf;
use super::quantiser::Sq;

/// Coarse cells whose fine cells are candidates for scanning.
pub const COARSE_PROBES: usize = 4;
/// Fine cells examined per query, at most.
pub const FINE_PROBES: usize = 160;
/// Share of all fine cells examined per query, at most (but at least [`MIN_FINE_PROBES`]
/// cells): an index of a few thousand shapes has few cells, of parts less alike, whose boxes
/// skip little.
pub const FINE_SHARE: f32 = 0.01;
/// Fine cells examined per query whatever the share.
pub const MIN_FINE_PROBES: usize = 12;
/// Candidates ranked by the first bytes of their codes that are ranked again by whole codes,
/// as a multiple of the neighbours asked for.
pub const RERANK: usize = 2;

/// How much of the inverted file a search reads: more is slower, and misses fewer true
/// neighbours (the trade-off of `nprobe` in an IVF index). The default is
/// [`COARSE_PROBES`], [`FINE_PROBES`], [`FINE_SHARE`], [`RERANK`], and settling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchEffort {
    /// Coarse cells whose fine cells are candidates for scanning (at least 1).
    pub coarse_probes: usize,
    /// Fine cells examined per query, at most (at least 1).
    pub fine_probes: usize,
    /// Share of all fine cells examined per query, at most (but at least
    /// [`MIN_FINE_PROBES`]); 1 for no limit.
    pub fine_share: f32,
    /// Candidates by first bytes that are ranked again by whole codes, as a multiple of the
    /// neighbours asked for (at least 1).
    pub rerank: usize,
    /// Whether codes too close to the `k`-th place to tell apart are settled by reading their
    /// descriptors (a few per search; without, no descriptor is read, and two parts whose
    /// distances differ by less than the codes' rounding may change places at the `k`-th).
    pub settle: bool,
}

impl Default for SearchEffort {
    fn default() -> Self {
        SearchEffort {
            coarse_probes: COARSE_PROBES,
            fine_probes: FINE_PROBES,
            fine_share: FINE_SHARE,
            rerank: RERANK,
            settle: true,
        }
    }
}

/// Keeps the `n` smallest elements of `v` by `cmp` (a total order), in no particular order.
fn keep_smallest<T>(v: &mut Vec<T>, n: usize, cmp: impl FnMut(&T, &T) -> std::cmp::Ordering) {
    if n == 0 {
        v.clear();
    } else if v.len() > n {
        v.select_nth_unstable_by(n - 1, cmp);
        v.truncate(n);
    }
}

impl Ivf {
    /// About the `k` nearest items to `q` (see the module documentation), nearest first, with
    /// their squared distances to `q` as their codes give them (the residual each code stands
    /// for, added to its cell's centroid; [`Ivf::code_error`] bounds how far that is from the
    /// descriptor itself); ties by item id. No descriptor is read: on an index larger than
    /// memory, the search touches only the inverted file.
    #[cfg(test)]
    pub(crate) fn search(&self, q: &[f32], k: usize, effort: SearchEffort) -> Vec<(u32, f32)> {
        let mut found = self.search_bounded(q, k, effort);
        found.truncate(k);
        found.into_iter().map(|(i, d, _)| (i, d)).collect()
    }

    /// The search behind [`Ivf::search`]: the `rerank × k` candidates ranked by whole codes
    /// (fewer if fewer were found; the `k` nearest only when `effort.settle` is off, so that
    /// no descriptor is read), nearest first, each with its distance as its code gives it
    /// and how far the square root of that may be from the true one (half a level per value
    /// of its cell, and float rounding), for [`Settle`] to settle the `k`-th place.
    pub(crate) fn search_bounded(
        &self,
        q: &[f32],
        k: usize,
        effort: SearchEffort,
    ) -> Vec<(u32, f32, f32)> {
        let d = self.d;
        let mut coarse: Vec<(f32, usize)> = self
            .coarse
            .chunks_exact(d)
            .enumerate()
            .map(|(i, c)| (squared_distance_fast(c, q), i))
            .collect();
        keep_smallest(&mut coarse, effort.coarse_probes.max(1), |a, b| {
            a.0.total_cmp(&b.0).then(a.1.cmp(&b.1))
        });
        // each fine cell of those coarse cells with the distance from the query to its box
        // (no more than to any of its codes: see `Sq::box_distance`)
        let mut fine: Vec<(f32, usize, usize)> = Vec::new();
        for &(_, ci) in &coarse {
            for (fi, c) in self.fine[ci].chunks_exact(d).enumerate() {
                let g = self.bases[ci] + fi;
                fine.push((self.pq.box_distance(g, q, c), ci, fi));
            }
        }
        let by_cell = |a: &(f32, usize, usize), b: &(f32, usize, usize)| {
            a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2)))
        };
        // the quantiser has `d` ranges per fine cell
        let cells = self.pq.min.len() / d;
        let share = (cells as f64 * f64::from(effort.fine_share.clamp(0.0, 1.0))).ceil() as usize;
        let examined = effort.fine_probes.min(share.max(MIN_FINE_PROBES)).max(1);
        keep_smallest(&mut fine, examined, by_cell);
        fine.sort_by(by_cell);
        let m = self.pq.bytes();
        let keep = k.saturating_mul(effort.rerank.max(1));
        // (place in cell order, distance, the scanned cell's position in `shifted`)
        let by = |a: &(u32, f32, u32), b: &(u32, f32, u32)| {
            a.1.total_cmp(&b.1)
                .then_with(|| self.items[a.0 as usize].cmp(&self.items[b.0 as usize]))
        };
        let mut found: Vec<(u32, f32, u32)> = Vec::with_capacity(keep.min(1 << 12) + CELL_SIZE);
        let mut shifted = Vec::with_capacity(fine.len());
        // the largest distance among the `keep` nearest found so far, once there are `keep`
        let mut threshold = f32::INFINITY;
        let mut residual = vec![0f32; d];
        for &(bound, ci, fi) in &fine {
            // every code of the cell stands for a point of its box: a cell whose box is
            // farther than the `keep`-th nearest found holds none nearer, nor do the cells
            // after it
            if bound > threshold {
                break;
            }
            let c = &self.fine[ci][fi * d..(fi + 1) * d];
            for ((r, q), c) in residual.iter_mut().zip(q).zip(c) {
                *r = q - c;
            }
            let g = self.bases[ci] + fi;
            let prepared = self.pq.shift(g, &residual);
            let probe = shifted.len() as u32;
            let (start, end) = self.ranges[ci][fi];
            for j in start as usize..end as usize {
                let code = &self.codes[j * m..(j + 1) * m];
                let dist = Sq::coarse_distance(&prepared, code);
                if dist <= threshold {
                    found.push((j as u32, dist, probe));
                }
            }
            shifted.push(prepared);
            if found.len() >= keep {
                keep_smallest(&mut found, keep, by);
                threshold = found.iter().map(|f| f.1).fold(f32::NEG_INFINITY, f32::max);
            }
        }
        // the nearest by first bytes, ranked again by whole codes
        keep_smallest(&mut found, keep, by);
        for f in &mut found {
            let j = f.0 as usize;
            let (first, second) = (
                &self.codes[j * m..(j + 1) * m],
                &self.refine[j * m..(j + 1) * m],
            );
            f.1 = Sq::distance(&shifted[f.2 as usize], first, second);
        }
        found.sort_by(by);
        if !effort.settle {
            found.truncate(k);
        }
        found
            .into_iter()
            .map(|(j, dist, probe)| {
                let e = shifted[probe as usize].error;
                (
                    self.items[j as usize],
                    dist,
                    e * 1.01 + 1e-6 * dist.max(0.0).sqrt(),
                )
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ivf::build::{Flat, Points};
    use crate::ivf::settle::resolve;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn exact(points: &[f32], d: usize, q: &[f32], k: usize) -> Vec<u32> {
        let mut all: Vec<(u32, f32)> = points
            .chunks_exact(d)
            .enumerate()
            .map(|(i, p)| (i as u32, squared_distance_fast(p, q)))
            .collect();
        all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        all.into_iter().take(k).map(|x| x.0).collect()
    }

    /// The items `ivf` finds nearest `q` with `effort`, the `k`-th place settled by the true
    /// distances to `points`, in increasing order.
    fn settled(ivf: &Ivf, points: &Flat, q: &[f32], k: usize, effort: SearchEffort) -> Vec<u32> {
        let found = ivf.search_bounded(q, k, effort);
        let got = resolve(&found, k, |i| {
            Some(squared_distance_fast(points.point(i), q))
        });
        let mut got: Vec<u32> = got.into_iter().map(|g| g.0).collect();
        got.sort_unstable();
        got
    }

    /// `n` points of `d` values about `centres` random centres (point `i` about centre
    /// `i mod centres`), each value moved by up to ±`spread`.
    fn clustered(
        rng: &mut ChaCha8Rng,
        centres: usize,
        n: usize,
        d: usize,
        spread: f32,
    ) -> Vec<f32> {
        let centres: Vec<Vec<f32>> = (0..centres)
            .map(|_| (0..d).map(|_| rng.random_range(0.0..1.0)).collect())
            .collect();
        (0..n)
            .flat_map(|i| {
                let c = &centres[i % centres.len()];
                c.iter()
                    .map(|x| x + rng.random_range(-spread..spread))
                    .collect::<Vec<f32>>()
            })
            .collect()
    }

    /// Clustered points (as real descriptors are): every point is stored once, the search is
    /// deterministic, finds a point's own copy first and most of its exact neighbours.
    #[test]
    fn finds_most_exact_neighbours_of_clustered_points() {
        let d = 16;
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let n = 20_000;
        let points = clustered(&mut rng, 40, n, d, 0.05);
        let flat = Flat { data: &points, d };
        let ivf = Ivf::build(&flat, d);
        let mut stored = ivf.items.clone();
        stored.sort_unstable();
        assert_eq!(stored, (0..n as u32).collect::<Vec<_>>());
        let again = Ivf::build(&flat, d);
        assert_eq!(again.items, ivf.items);
        let (mut hits, mut total) = (0, 0);
        for qi in (0..n).step_by(97) {
            let q = &points[qi * d..(qi + 1) * d];
            let got = ivf.search(q, 20, SearchEffort::default());
            assert_eq!(got[0].0, qi as u32);
            assert_eq!(got, again.search(q, 20, SearchEffort::default()));
            // each distance by code is within the rounding bound of the true one
            for &(i, dc) in &got {
                let de = squared_distance_fast(flat.point(i), q);
                assert!(
                    (dc.sqrt() - de.sqrt()).abs() <= ivf.code_error() * 1.001 + 1e-5,
                    "item {i}: by code {dc}, exact {de}, bound {}",
                    ivf.code_error()
                );
            }
            let want = exact(&points, d, q, 20);
            hits += got.iter().filter(|g| want.contains(&g.0)).count();
            total += want.len();
        }
        assert!(hits as f64 >= 0.9 * total as f64, "recall {hits}/{total}");
    }

    /// Near-duplicate points (a few sources, many copies each moved by up to ±0.01, as the
    /// scale benchmarks grow an index): with every cell examined and every candidate re-ranked
    /// by whole codes, skipping cells by their boxes loses nothing, and settling the k-th
    /// place by the true distances gives exactly the exact search's neighbours.
    #[test]
    fn every_cell_examined_gives_the_exact_neighbours() {
        let d = 16;
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let n = 6_000;
        let points = clustered(&mut rng, 6, n, d, 0.01);
        let flat = Flat { data: &points, d };
        let ivf = Ivf::build(&flat, d);
        let all = SearchEffort {
            coarse_probes: usize::MAX,
            fine_probes: usize::MAX,
            fine_share: 1.0,
            rerank: n,
            settle: true,
        };
        let k = 30;
        for qi in (0..n).step_by(211) {
            let q: Vec<f32> = points[qi * d..(qi + 1) * d]
                .iter()
                .map(|x| x + rng.random_range(-0.01..0.01))
                .collect();
            let got = settled(&ivf, &flat, &q, k, all);
            let mut want = exact(&points, d, &q, k);
            want.sort_unstable();
            assert_eq!(got, want, "query {qi}");
        }
    }

    /// The search with cells skipped by their boxes gives what a scan of every code gives:
    /// the `rerank × k` nearest by first bytes, ranked again by whole codes.
    #[test]
    fn skipping_cells_by_their_boxes_loses_nothing() {
        let d = 16;
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let n = 20_000;
        let points = clustered(&mut rng, 4, n, d, 0.01);
        let flat = Flat { data: &points, d };
        let ivf = Ivf::build(&flat, d);
        let effort = SearchEffort {
            coarse_probes: usize::MAX,
            fine_probes: usize::MAX,
            fine_share: 1.0,
            rerank: 2,
            settle: true,
        };
        let m = ivf.pq.bytes();
        let k = 20;
        for qi in (0..n).step_by(331) {
            let q: Vec<f32> = points[qi * d..(qi + 1) * d]
                .iter()
                .map(|x| x + rng.random_range(-0.01..0.01))
                .collect();
            // every code of every cell, by first bytes, then the best by whole codes
            let mut all: Vec<(u32, f32, f32)> = Vec::new();
            for (ci, cells) in ivf.ranges.iter().enumerate() {
                for (fi, &(start, end)) in cells.iter().enumerate() {
                    let c = &ivf.fine[ci][fi * d..(fi + 1) * d];
                    let r: Vec<f32> = q.iter().zip(c).map(|(q, c)| q - c).collect();
                    let shifted = ivf.pq.shift(ivf.bases[ci] + fi, &r);
                    for j in start as usize..end as usize {
                        let (first, second) = (
                            &ivf.codes[j * m..(j + 1) * m],
                            &ivf.refine[j * m..(j + 1) * m],
                        );
                        all.push((
                            ivf.items[j],
                            Sq::coarse_distance(&shifted, first),
                            Sq::distance(&shifted, first, second),
                        ));
                    }
                }
            }
            all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            all.truncate(2 * k);
            all.sort_by(|a, b| a.2.total_cmp(&b.2).then(a.0.cmp(&b.0)));
            let want: Vec<(u32, f32)> = all.iter().map(|a| (a.0, a.2)).collect();
            let got: Vec<(u32, f32)> = ivf
                .search_bounded(&q, k, effort)
                .into_iter()
                .map(|g| (g.0, g.1))
                .collect();
            assert_eq!(got, want, "query {qi}");
        }
    }

    /// Parts put in a cell whose centroid is far from them (as when a coarse cell's fine
    /// centroids were fitted on a sample that missed them): the cell is ranked by its box,
    /// which holds them, so one cell examined is enough to find them, where the cell with the
    /// nearest centroid holds none.
    #[test]
    fn cells_are_ranked_by_their_boxes_not_their_centroids() {
        let d = 8;
        let mut rng = ChaCha8Rng::seed_from_u64(14);
        let at = |x: f32, y: f32| {
            let mut p = vec![0f32; d];
            p[0] = x;
            p[1] = y;
            p
        };
        let (f0, f1, z) = (at(0.0, 0.0), at(10.0, 0.0), at(3.0, 5.0));
        let mut points = Vec::new();
        let mut cell = Vec::new();
        for (centre, g, count) in [(&f0, 0, 200), (&f1, 1, 200), (&z, 1, 30)] {
            for _ in 0..count {
                points.extend(centre.iter().map(|c| c + rng.random_range(-0.1..0.1)));
                cell.push(g);
            }
        }
        let flat = Flat { data: &points, d };
        let ivf = Ivf::with_cells(&flat, d, vec![0.0; d], vec![[f0, f1].concat()], &cell);
        // the query is nearer the centroid of cell 0, and inside the box of cell 1
        assert!(
            squared_distance_fast(&z, &ivf.fine[0][..d])
                < squared_distance_fast(&z, &ivf.fine[0][d..])
        );
        let one = SearchEffort {
            coarse_probes: 1,
            fine_probes: 1,
            fine_share: 1.0,
            rerank: 2,
            settle: true,
        };
        let k = 10;
        let got = settled(&ivf, &flat, &z, k, one);
        let mut want = exact(&points, d, &z, k);
        want.sort_unstable();
        assert_eq!(got, want);
        assert!(want.iter().all(|&i| i >= 400));
    }
}
