//! Approximate nearest-neighbour search over component descriptors: an inverted file with a
//! two-level k-means quantiser and quantised residuals (the IVFADC scheme of H. Jégou,
//! M. Douze and C. Schmid, "Product quantization for nearest neighbor search", IEEE TPAMI
//! 33(1), 2011, Section IV, with a scalar quantiser of the residuals instead of a product
//! quantiser, and the best re-ranked by a finer code, as in Jégou, Tavenard, Douze and Amsaleg,
//! ICASSP 2011: see [`Sq`]).
//!
//! The descriptors are split into `c` coarse cells by k-means, each coarse cell into `c` fine
//! cells by k-means over its members, with `c ≈ √(n / CELL_SIZE)` so that a fine cell holds about
//! [`CELL_SIZE`] descriptors. Each descriptor is stored once, in its fine cell, as a code of two
//! bytes per value: its residual from the fine centroid, each value rounded to the nearest of
//! 65,536 levels spanning that value's range over the cell's members (128 bytes instead of 256
//! for 64 values), kept as two arrays: the first bytes, the second bytes. A query ranks the
//! coarse centroids, takes the fine cells of its [`COARSE_PROBES`] nearest coarse cells, and
//! examines the [`FINE_PROBES`] of them with the nearest boxes (at most [`FINE_SHARE`] of all
//! fine cells, at least [`MIN_FINE_PROBES`]), nearest first. A cell's box holds the points its
//! codes can stand for (each value from its first level to its last), so its distance to the
//! query is no more than any of its codes': the cells are scanned in that order until a box is
//! farther than the [`RERANK`]` × k`-th nearest code found so far, when no code of it or of
//! the cells after it could enter them (the branch-and-bound search of K. Fukunaga and
//! P. M. Narendra, "A branch and bound algorithm for computing k-nearest neighbors", IEEE
//! Trans. Computers C-24(7), 1975, with boxes for its bounds). Ranked by their centroids
//! instead, the cells examined missed some of the nearest codes at a million shapes: a cell's
//! centroid is the mean of its members, its box bounds every one of them (BENCHMARKS.md,
//! "A million shapes: fine cells ranked by their boxes"). The scan ranks
//! codes by the levels their first bytes stand for (asymmetric distances, Jégou et al.
//! Section III.A); the [`RERANK`]` × k` nearest are ranked again by their whole codes, and
//! the few whose whole-code distances are too close to the `k`-th place to tell apart (within
//! half a level per value) are settled by their descriptors ([`Settle`]). Near-duplicate
//! parts fill many neighbouring cells, all of them needed for the `k` nearest; cells of other
//! parts have far boxes, and the scan stops at the first of them. Codes are read instead of
//! the `n` descriptors, so that an index larger than memory is searched from the inverted
//! file alone. A true neighbour is missed when it lies in a cell not
//! examined, or when rounding puts it beyond the re-ranked ones, so recall is measured, not
//! guaranteed ([`SearchEffort`] trades speed for it).
//!
//! One byte per value with one range for all cells, and no re-ranking, was measured too: the
//! ranking's top 10 then matched the exact one's for 9 of 20 queries at 100,000 shapes, against
//! 20 of 20 with two bytes (BENCHMARKS.md, "Candidate search"): a level of 256 over the whole
//! range of residuals is coarser than the differences between near-duplicate parts. Ranges
//! per cell make the levels fine where parts crowd.
//!
//! A product quantiser (16 bytes per 64 values, 256 centroids per run of 4 values) was
//! measured first: its codes are 4 times smaller, but its rounding is coarser than the
//! differences between near-duplicate parts, and the ranking's top 10 matched the exact one's
//! for 7 of 10 queries at 100,000 shapes (BENCHMARKS.md, "Candidate search").
//!
//! Everything is deterministic: initial centroids are evenly spaced sample points, and every
//! sum is taken in a fixed order whatever the thread count.

use rayon::prelude::*;

/// Descriptors per fine cell aimed at.
pub const CELL_SIZE: usize = 512;
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
/// Lloyd iterations of each k-means.
const ITERATIONS: usize = 8;
/// Sample points per centroid that k-means is fitted on.
const SAMPLE_PER_CENTROID: usize = 48;
/// Levels of the scalar quantiser (two bytes per value: the scan reads the first, the
/// re-ranking both).
const LEVELS: usize = 65_536;
/// Levels in the run that a code's first byte names (its second byte picks one of them).
const RUN: usize = 256;
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
/// The first field of a search cache's payload: caches whose payload is laid out otherwise
/// (an earlier layout of the same format version) are rebuilt instead of misread.
const CACHE_TAG: u64 = u64::from_le_bytes(*b"KCIVF16\0");

/// Squared Euclidean distance over eight partial sums, so that the loop vectorises (the
/// summation order differs from [`crate::squared_distance`]: results agree to rounding).
#[inline]
pub fn distance_sq(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..8 {
            let d = x[l] - y[l];
            acc[l] += d * d;
        }
    }
    let mut tail = 0f32;
    for (x, y) in ra.iter().zip(rb) {
        let d = x - y;
        tail += d * d;
    }
    acc.iter().sum::<f32>() + tail
}

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

/// Index of the nearest of `centroids` (flat, `d` values each) to `p`; ties to the lower index.
fn nearest(centroids: &[f32], d: usize, p: &[f32]) -> usize {
    let mut best = (f32::INFINITY, 0);
    for (i, c) in centroids.chunks_exact(d).enumerate() {
        let dist = distance_sq(c, p);
        if dist < best.0 {
            best = (dist, i);
        }
    }
    best.1
}

/// k-means (Lloyd) of the points `points.point(i)` for `i` in `members`, `k` centroids, flat.
/// Centroids start at evenly spaced members of an evenly spaced sample; an emptied cluster keeps
/// its centroid.
fn kmeans(points: &impl Points, d: usize, members: &[u32], k: usize) -> Vec<f32> {
    kmeans_with(points, d, members, k, k * SAMPLE_PER_CENTROID, true)
}

/// [`kmeans`] fitted on about `sample_size` evenly spaced members, its iterations in parallel
/// when `parallel` (the caller's own loop may be the parallel one).
fn kmeans_with(
    points: &impl Points,
    d: usize,
    members: &[u32],
    k: usize,
    sample_size: usize,
    parallel: bool,
) -> Vec<f32> {
    let k = k.clamp(1, members.len().max(1));
    let step = (members.len() / sample_size.max(k)).max(1);
    let sample: Vec<u32> = members.iter().step_by(step).copied().collect();
    let point = |i: u32| points.point(i);
    let mut centroids: Vec<f32> = (0..k)
        .flat_map(|j| point(sample[j * sample.len() / k]).to_vec())
        .collect();
    for _ in 0..ITERATIONS {
        let assigned: Vec<usize> = if parallel {
            sample
                .par_iter()
                .map(|&i| nearest(&centroids, d, point(i)))
                .collect()
        } else {
            sample
                .iter()
                .map(|&i| nearest(&centroids, d, point(i)))
                .collect()
        };
        let mut of: Vec<Vec<u32>> = vec![Vec::new(); k];
        for (&i, &c) in sample.iter().zip(&assigned) {
            of[c].push(i);
        }
        let mean = |(j, pts): (usize, &Vec<u32>)| -> Vec<f32> {
            if pts.is_empty() {
                return centroids[j * d..(j + 1) * d].to_vec();
            }
            let mut sum = vec![0f64; d];
            for &i in pts {
                for (s, v) in sum.iter_mut().zip(point(i)) {
                    *s += f64::from(*v);
                }
            }
            sum.iter().map(|s| (s / pts.len() as f64) as f32).collect()
        };
        let next: Vec<Vec<f32>> = if parallel {
            of.par_iter().enumerate().map(mean).collect()
        } else {
            of.iter().enumerate().map(mean).collect()
        };
        centroids = next.concat();
    }
    centroids
}

/// Where a shape's descriptors come from, as the search cache identifies them: a segment (its
/// number, length and checksum: segments are immutable) and the record's position in it.
/// Items are the shapes' components, shape after shape, in the order the caller lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct Origin {
    /// The segment's number, length and checksum.
    pub segment: (u64, u64, u64),
    /// The record's position in the segment.
    pub position: u32,
    /// The shape's components (its items).
    pub components: u32,
}

/// The cells of one segment's records, as a cache file holds them.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
struct SegmentCells {
    /// The segment's number, length and checksum.
    segment: (u64, u64, u64),
    /// Positions in the segment of the records held, increasing.
    positions: Vec<u32>,
    /// Per record held, its first entry in `cells`; one more entry closes the last.
    starts: Vec<u32>,
    /// Global fine cell of each component of each record held.
    cells: Vec<u32>,
    /// The first byte per value of the code of each component of each record held, in the
    /// order of `cells`.
    #[serde(with = "serde_bytes")]
    codes: Vec<u8>,
    /// The second bytes of the same codes, in the same order.
    #[serde(with = "serde_bytes")]
    refine: Vec<u8>,
}

/// The start of a cache payload, as written (followed by a `u64` segment count and each
/// segment's [`SegmentCells`]).
#[derive(serde::Serialize)]
struct Head<'a> {
    tag: u64,
    key: u64,
    d: u32,
    trained: u64,
    coarse: &'a [f32],
    fine: &'a [Vec<f32>],
    pq: &'a Sq,
}

/// [`Head`] as read.
#[derive(serde::Deserialize)]
struct HeadOwned {
    tag: u64,
    key: u64,
    d: u32,
    trained: u64,
    coarse: Vec<f32>,
    fine: Vec<Vec<f32>>,
    pq: Sq,
}

/// What a cache file holds, as one value (the tests craft caches with it).
#[cfg(test)]
#[derive(Clone, serde::Serialize, serde::Deserialize)]
struct Stored {
    tag: u64,
    /// The snapshot key the cache was written for (equal: nothing to update).
    key: u64,
    d: u32,
    /// Items the centroids were fitted on.
    trained: u64,
    coarse: Vec<f32>,
    fine: Vec<Vec<f32>>,
    pq: Sq,
    segments: Vec<SegmentCells>,
}

/// An inverted file read from a cache file (see [`Ivf::from_cache`]).
pub(crate) struct FromCache {
    /// The inverted file of the current items.
    pub ivf: Ivf,
    /// Whether the cache was written for exactly these items (else it is worth rewriting).
    pub exact: bool,
    /// Items of records the cache did not hold, put in their nearest cells.
    pub assigned: usize,
}

/// A cache whose centroids were fitted on `trained` items is extended (new items put in their
/// nearest cells) only while the items number between `trained / GROWTH` and
/// `trained × GROWTH`; beyond, cells are too crowded or too sparse and the inverted file is
/// built again.
pub(crate) const GROWTH: usize = 2;

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
/// error of its square root, as [`Ivf::search_bounded`] gives them): an item that fewer than
/// `k` others may be nearer than is in, one that `k` others are surely nearer than is out, and
/// the places left go to the others ([`Settle::open`]) by their true squared distances, so
/// that codes whose distances are too close to tell apart at the `k`-th place are told apart
/// by the descriptors, read for those only.
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

/// Keeps the `n` smallest elements of `v` by `cmp` (a total order), in no particular order.
fn keep_smallest<T>(v: &mut Vec<T>, n: usize, cmp: impl FnMut(&T, &T) -> std::cmp::Ordering) {
    if n == 0 {
        v.clear();
    } else if v.len() > n {
        v.select_nth_unstable_by(n - 1, cmp);
        v.truncate(n);
    }
}

/// The inverted file (see the module documentation).
#[derive(Debug, PartialEq)]
pub(crate) struct Ivf {
    d: usize,
    /// Coarse centroids, flat.
    coarse: Vec<f32>,
    /// Per coarse cell: its fine centroids, flat.
    fine: Vec<Vec<f32>>,
    /// Per coarse cell: the global number of its first fine cell.
    bases: Vec<usize>,
    /// Per coarse cell, per fine cell: the range of `items` / `data` it holds.
    ranges: Vec<Vec<(u32, u32)>>,
    /// Item ids (positions in the reader's component list), grouped by fine cell.
    items: Vec<u32>,
    /// The quantiser of the residuals.
    pq: Sq,
    /// The first bytes of the codes of `items`, in the same order, `pq.bytes()` each.
    codes: Vec<u8>,
    /// The second bytes of the same codes, laid out alike.
    refine: Vec<u8>,
    /// Items the centroids were fitted on.
    trained: usize,
}

/// A scalar quantiser of residuals, one per fine cell: value `i` of a residual in cell `g` is
/// coded by two bytes, the nearest of 65,536 levels evenly spaced from `min[g·d + i]` by
/// `step[g·d + i]` (the range of that value over the cell's members when it was built; values
/// beyond it, of parts put in the cell later, take the end levels). Ranges per cell follow the
/// data's density: where parts crowd (near duplicates), a cell is small and so are its steps.
/// The first byte alone names a run of 256 levels, which stands for the middle of the run: the
/// scan ranks codes by their first bytes (a half of the memory read), and the best are ranked
/// again by both bytes (re-ranking with a finer code of the first one's rounding, as in
/// H. Jégou, R. Tavenard, M. Douze and L. Amsaleg, "Searching in one billion vectors: re-rank
/// with source coding", ICASSP 2011).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct Sq {
    /// Bytes per code half (values per descriptor).
    d: u32,
    min: Vec<f32>,
    step: Vec<f32>,
}

/// A query's residual from one fine centroid, prepared for [`Sq::coarse_distance`] and
/// [`Sq::distance`] of that cell's codes.
struct Shifted<'a> {
    /// The residual minus the first level.
    fine: Vec<f32>,
    /// The residual minus the middle of the first run of levels.
    coarse: Vec<f32>,
    /// The step between runs of levels ([`RUN`] steps).
    run: Vec<f32>,
    /// The step between levels.
    step: &'a [f32],
    /// The largest distance between a residual of the cell and the one its code stands for
    /// (half a step per value).
    error: f32,
}

impl Sq {
    /// The quantiser of cells whose residual values range from `lo` to `hi` (per cell, `d`
    /// values each; a cell without members has infinite bounds).
    fn from_ranges(lo: &[f32], hi: &[f32], d: usize) -> Sq {
        let mut min = Vec::with_capacity(lo.len());
        let mut step = Vec::with_capacity(lo.len());
        for (&l, &h) in lo.iter().zip(hi) {
            if l.is_finite() && h.is_finite() && h > l {
                min.push(l);
                step.push((h - l) / (LEVELS - 1) as f32);
            } else {
                // no member, or one value: every code stands for it
                min.push(if l.is_finite() { l } else { 0.0 });
                step.push(0.0);
            }
        }
        Sq {
            d: d as u32,
            min,
            step,
        }
    }

    /// Bytes per code, in each of its two halves.
    fn bytes(&self) -> usize {
        self.d as usize
    }

    /// Whether the quantiser fits `cells` cells of vectors of `d` values, with finite levels.
    fn fits(&self, d: usize, cells: usize) -> bool {
        d >= 1
            && self.d as usize == d
            && cells.checked_mul(d) == Some(self.min.len())
            && self.step.len() == self.min.len()
            && self.min.iter().all(|v| v.is_finite())
            && self.step.iter().all(|v| v.is_finite() && *v >= 0.0)
    }

    /// The levels' origins and steps of cell `g`.
    fn cell(&self, g: usize) -> (&[f32], &[f32]) {
        let d = self.d as usize;
        (
            &self.min[g * d..(g + 1) * d],
            &self.step[g * d..(g + 1) * d],
        )
    }

    /// The code of `r`, a residual in cell `g`: its first bytes into `first`, its second bytes
    /// into `second` (each `bytes()` long).
    fn encode(&self, g: usize, r: &[f32], first: &mut [u8], second: &mut [u8]) {
        let (min, step) = self.cell(g);
        for (i, v) in r.iter().enumerate() {
            let (m, s) = (min[i], step[i]);
            let level = if s > 0.0 {
                ((v - m) / s).round().clamp(0.0, (LEVELS - 1) as f32) as u16
            } else {
                0
            };
            [first[i], second[i]] = level.to_be_bytes();
        }
    }

    /// `r`, a query's residual from the centroid of cell `g`, prepared for the distances to
    /// that cell's codes.
    fn shift(&self, g: usize, r: &[f32]) -> Shifted<'_> {
        let (min, step) = self.cell(g);
        let half_run = 0.5 * (RUN - 1) as f32;
        let mut out = Shifted {
            fine: Vec::with_capacity(r.len()),
            coarse: Vec::with_capacity(r.len()),
            run: Vec::with_capacity(r.len()),
            step,
            error: step.iter().map(|s| 0.25 * s * s).sum::<f32>().sqrt(),
        };
        for ((v, m), s) in r.iter().zip(min).zip(step) {
            out.fine.push(v - m);
            out.coarse.push(v - m - half_run * s);
            out.run.push(RUN as f32 * s);
        }
        out
    }

    /// Squared distance between a residual and the middle of the runs of levels that the
    /// first bytes of a code name (eight partial sums, so that the loop vectorises).
    #[inline]
    fn coarse_distance(q: &Shifted, first: &[u8]) -> f32 {
        let mut acc = [0f32; 8];
        let chunks = q
            .coarse
            .chunks_exact(8)
            .zip(first.chunks_exact(8))
            .zip(q.run.chunks_exact(8));
        for ((a, c), s) in chunks {
            for l in 0..8 {
                let d = a[l] - s[l] * f32::from(c[l]);
                acc[l] += d * d;
            }
        }
        let done = q.coarse.len() / 8 * 8;
        let tail: f32 = q.coarse[done..]
            .iter()
            .zip(&q.run[done..])
            .zip(&first[done..])
            .map(|((a, s), c)| {
                let d = a - s * f32::from(*c);
                d * d
            })
            .sum();
        acc.iter().sum::<f32>() + tail
    }

    /// Squared distance between `q - c`, a query's residual from `c`, the centroid of cell `g`,
    /// and the box of the points the cell's codes can stand for (each value from the first
    /// level to the last): no more than its distance to any code of the cell, by first bytes
    /// ([`Sq::coarse_distance`]: the middles of runs lie in the box) or whole
    /// ([`Sq::distance`]).
    fn box_distance(&self, g: usize, q: &[f32], c: &[f32]) -> f32 {
        let (min, step) = self.cell(g);
        let top = (LEVELS - 1) as f32;
        // how far the residual value `q - c` lies outside the levels from `lo` by `s`,
        // squared (comparisons rather than `f32::max`, and eight partial sums, so that the
        // loop vectorises; the residual is never written out)
        let out = |q: f32, c: f32, lo: f32, s: f32| {
            let v = q - c;
            let (below, above) = (lo - v, v - (lo + s * top));
            let o = if below > above { below } else { above };
            let o = if o > 0.0 { o } else { 0.0 };
            o * o
        };
        let mut acc = [0f32; 8];
        let chunks = q
            .chunks_exact(8)
            .zip(c.chunks_exact(8))
            .zip(min.chunks_exact(8).zip(step.chunks_exact(8)));
        for ((q, c), (lo, s)) in chunks {
            for l in 0..8 {
                acc[l] += out(q[l], c[l], lo[l], s[l]);
            }
        }
        let done = q.len() / 8 * 8;
        let tail: f32 = (done..q.len())
            .map(|i| out(q[i], c[i], min[i], step[i]))
            .sum();
        acc.iter().sum::<f32>() + tail
    }

    /// Squared distance between a residual and the one a whole code stands for.
    fn distance(q: &Shifted, first: &[u8], second: &[u8]) -> f32 {
        let mut sum = 0f32;
        for i in 0..q.fine.len() {
            let level = f32::from(u16::from_be_bytes([first[i], second[i]]));
            let d = q.fine[i] - q.step[i] * level;
            sum += d * d;
        }
        sum
    }
}

impl Ivf {
    /// Builds the inverted file of `points` (`d` values each; item `i` is point `i`).
    pub(crate) fn build(points: &impl Points, d: usize) -> Ivf {
        let n = points.len();
        let c = ((n as f64 / CELL_SIZE as f64).sqrt().ceil() as usize).max(1);
        let all: Vec<u32> = (0..n as u32).collect();
        let coarse = kmeans(points, d, &all, c);
        let point = |i: u32| points.point(i);
        // Every pass over all the descriptors reads them in item order, the order they are
        // stored in: on an index larger than memory, any other order rereads them from disk.
        let top: Vec<u32> = all
            .par_iter()
            .map(|&i| nearest(&coarse, d, point(i)) as u32)
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
                    kmeans(points, d, m, c)
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
                bases[t] + nearest(&fine[t], d, point(i)) as u32
            })
            .collect();
        drop(top);
        Ivf::with_cells(points, d, coarse, fine, &cell)
    }

    /// The inverted file of `points` (`d` values each) with these centroids, item `i` in
    /// global fine cell `cell[i]` (fine cells numbered coarse cell by coarse cell, each in
    /// range): the quantiser fitted to the cells' residuals, and every item's code.
    fn with_cells(
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

    /// For each item, its place in cell order (the inverse of `items`).
    fn places(&self) -> Vec<u32> {
        let mut place = vec![0u32; self.items.len()];
        for (j, &i) in self.items.iter().enumerate() {
            place[i as usize] = j as u32;
        }
        place
    }

    /// The global fine cell `g`'s centroid, if there is one.
    fn fine_centroid(&self, g: usize) -> Option<&[f32]> {
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
    fn assign(&self, p: &[f32]) -> Option<u32> {
        let d = self.d;
        let mut best: Option<(f32, usize)> = None;
        for (i, c) in self.coarse.chunks_exact(d).enumerate() {
            if self.fine[i].is_empty() {
                continue;
            }
            let dist = match distance_sq(c, p) {
                x if x.is_nan() => f32::INFINITY,
                x => x,
            };
            if best.is_none_or(|(b, _)| dist < b) {
                best = Some((dist, i));
            }
        }
        let (_, cell) = best?;
        u32::try_from(self.bases[cell] + nearest(&self.fine[cell], d, p)).ok()
    }

    /// Each item's global fine cell.
    fn cells(&self) -> Vec<u32> {
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
    fn from_cells(
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

    /// The inverted file as a cache file for the snapshot identified by `key`, whose items
    /// come from `origins` (in item order): the centroids, the quantiser, and the cell and code
    /// of every item, grouped by segment, sealed like the index's files.
    pub(crate) fn to_cache(&self, key: u64, origins: &[Origin]) -> Vec<u8> {
        let mut payload = Vec::new();
        // writing into memory cannot fail
        let _ = self.write_payload(key, origins, &mut payload);
        crate::file::seal(
            payload,
            crate::file::KIND_SEARCH_CACHE,
            crate::version::FORMAT_VERSION,
        )
        .0
    }

    /// [`Ivf::to_cache`] written to `dir/name` atomically, segment by segment (never the whole
    /// payload in memory).
    pub(crate) fn write_cache(
        &self,
        dir: &std::path::Path,
        name: &str,
        key: u64,
        origins: &[Origin],
    ) -> crate::error::Result<std::path::PathBuf> {
        crate::file::write_atomic_sealed(
            dir,
            name,
            crate::file::KIND_SEARCH_CACHE,
            crate::version::FORMAT_VERSION,
            |w| self.write_payload(key, origins, w),
        )
    }

    /// The cache payload (see [`Ivf::to_cache`]) into `w`: the fields of [`Head`], the
    /// segment count, then each segment's [`SegmentCells`] (bincode, as one [`Stored`] would
    /// be encoded).
    fn write_payload(
        &self,
        key: u64,
        origins: &[Origin],
        w: &mut impl std::io::Write,
    ) -> std::io::Result<()> {
        let cell = self.cells();
        let place = self.places();
        let m = self.pq.bytes();
        // per segment: (record position, its first item, its items)
        type Records = Vec<(u32, usize, usize)>;
        let mut by_segment: std::collections::BTreeMap<(u64, u64, u64), Records> =
            std::collections::BTreeMap::new();
        let mut first = 0usize;
        for o in origins {
            let end = (first + o.components as usize).min(cell.len());
            by_segment
                .entry(o.segment)
                .or_default()
                .push((o.position, first, end - first));
            first = end;
        }
        let config = crate::codec::bincode_config();
        let enc = |e: bincode::error::EncodeError| std::io::Error::other(e.to_string());
        let head = Head {
            tag: CACHE_TAG,
            key,
            d: self.d as u32,
            trained: self.trained as u64,
            coarse: &self.coarse,
            fine: &self.fine,
            pq: &self.pq,
        };
        bincode::serde::encode_into_std_write(&head, w, config).map_err(enc)?;
        w.write_all(&(by_segment.len() as u64).to_le_bytes())?;
        for (segment, mut records) in by_segment {
            records.sort_by_key(|r| r.0);
            let mut starts = Vec::with_capacity(records.len() + 1);
            let mut cells = Vec::new();
            let mut codes = Vec::new();
            let mut refine = Vec::new();
            for &(_, first, count) in &records {
                starts.push(cells.len() as u32);
                for i in first..first + count {
                    cells.push(cell[i]);
                    let j = place[i] as usize;
                    codes.extend_from_slice(&self.codes[j * m..(j + 1) * m]);
                    refine.extend_from_slice(&self.refine[j * m..(j + 1) * m]);
                }
            }
            starts.push(cells.len() as u32);
            let seg = SegmentCells {
                segment,
                positions: records.iter().map(|r| r.0).collect(),
                starts,
                cells,
                codes,
                refine,
            };
            bincode::serde::encode_into_std_write(&seg, w, config).map_err(enc)?;
        }
        Ok(())
    }

    /// The inverted file of `points` (items from `origins`, in order) from a cache file's bytes
    /// (read from `path`), or `None` when the file is damaged or of another format, or when
    /// the items are too many or too few for its centroids (see [`GROWTH`]). Records the cache
    /// holds keep their cells; the others' items go to their nearest cells.
    pub(crate) fn from_cache(
        path: &std::path::Path,
        bytes: &[u8],
        key: u64,
        points: &impl Points,
        d: usize,
        origins: &[Origin],
    ) -> Option<FromCache> {
        // a cache written by another format version (whose payload differs) is rebuilt
        let (_, version) = crate::file::check_footer(
            path,
            bytes,
            crate::file::KIND_SEARCH_CACHE,
            crate::version::FORMAT_VERSION,
            true,
        )
        .ok()?;
        if version != crate::version::FORMAT_VERSION {
            return None;
        }
        Ivf::from_payload(
            &bytes[..bytes.len() - crate::file::FOOTER_LEN],
            key,
            points,
            d,
            origins,
        )
    }

    /// [`Ivf::from_cache`] on a cache file's payload (its footer and checksum already checked).
    /// Reads the segments' cells, then their codes, one segment at a time, straight into place
    /// (the payload is never decoded whole).
    pub(crate) fn from_payload(
        payload: &[u8],
        key: u64,
        points: &impl Points,
        d: usize,
        origins: &[Origin],
    ) -> Option<FromCache> {
        let (head, mut at): (HeadOwned, usize) = crate::codec::decode_bounded(payload).ok()?;
        let n = points.len();
        let trained = usize::try_from(head.trained).ok()?;
        if head.tag != CACHE_TAG
            || head.d as usize != d
            || n > trained.saturating_mul(GROWTH)
            || n.saturating_mul(GROWTH) < trained
        {
            return None;
        }
        // the centroids alone, to assign the items the cache does not hold
        let centroids = Ivf::from_cells(0, d, head.coarse, head.fine, head.pq, &[], trained)?;
        let m = centroids.pq.bytes();
        // where each live record's items are: (segment, position) -> (first item, items)
        type Wanted = std::collections::HashMap<((u64, u64, u64), u32), (usize, usize)>;
        let mut wanted = Wanted::with_capacity(origins.len());
        let mut first = 0usize;
        for o in origins {
            wanted.insert((o.segment, o.position), (first, o.components as usize));
            first += o.components as usize;
        }
        if first != n {
            return None;
        }
        let count = u64::from_le_bytes(payload.get(at..at + 8)?.try_into().ok()?);
        at += 8;
        // the records of a decoded segment the cache holds for this snapshot:
        // (first item, first entry in the segment's lists, items)
        let held = |seg: &SegmentCells| -> Option<Vec<(usize, usize, usize)>> {
            let mut out = Vec::new();
            for (i, &pos) in seg.positions.iter().enumerate() {
                let (a, b) = (
                    *seg.starts.get(i)? as usize,
                    *seg.starts.get(i + 1)? as usize,
                );
                if let Some(&(first, items)) = wanted.get(&(seg.segment, pos))
                    && b.checked_sub(a) == Some(items)
                    && b <= seg.cells.len()
                    && b.checked_mul(m).is_some_and(|e| e <= seg.codes.len())
                    && seg.refine.len() == seg.codes.len()
                {
                    out.push((first, a, items));
                }
            }
            Some(out)
        };
        // pass 1: the cells (a cell beyond the centroids' is a damaged cache)
        let cells_total: usize = centroids.fine.iter().map(|f| f.len() / d).sum();
        let mut cell = vec![u32::MAX; n];
        let mut offsets = Vec::new();
        for _ in 0..count {
            offsets.push(at);
            let (seg, used): (SegmentCells, usize) =
                crate::codec::decode_bounded(payload.get(at..)?).ok()?;
            at += used;
            for (first, a, items) in held(&seg)? {
                let cells = &seg.cells[a..a + items];
                if cells.iter().any(|&c| c as usize >= cells_total) {
                    return None;
                }
                cell[first..first + items].copy_from_slice(cells);
            }
        }
        if at != payload.len() {
            return None;
        }
        let fresh: Vec<u32> = (0..n as u32)
            .filter(|&i| cell[i as usize] == u32::MAX)
            .collect();
        let assigned: Vec<u32> = fresh
            .par_iter()
            .map(|&i| centroids.assign(points.point(i)))
            .collect::<Option<_>>()?;
        for (&i, g) in fresh.iter().zip(assigned) {
            cell[i as usize] = g;
        }
        let mut ivf = Ivf::from_cells(
            n,
            d,
            centroids.coarse,
            centroids.fine,
            centroids.pq,
            &cell,
            trained,
        )?;
        let place = ivf.places();
        // pass 2: the codes, in cell order
        for &off in &offsets {
            let (seg, _): (SegmentCells, usize) =
                crate::codec::decode_bounded(&payload[off..]).ok()?;
            for (first, a, items) in held(&seg)? {
                for k in 0..items {
                    let j = place[first + k] as usize;
                    ivf.codes[j * m..(j + 1) * m]
                        .copy_from_slice(&seg.codes[(a + k) * m..(a + k + 1) * m]);
                    ivf.refine[j * m..(j + 1) * m]
                        .copy_from_slice(&seg.refine[(a + k) * m..(a + k + 1) * m]);
                }
            }
        }
        let coded: Vec<(usize, Vec<u8>, Vec<u8>)> = fresh
            .par_iter()
            .map(|&i| {
                let p = points.point(i);
                let j = place[i as usize] as usize;
                let c = ivf.fine_centroid(cell[i as usize] as usize)?;
                let r: Vec<f32> = p.iter().zip(c).map(|(v, c)| v - c).collect();
                let (mut first, mut second) = (vec![0u8; m], vec![0u8; m]);
                ivf.pq
                    .encode(cell[i as usize] as usize, &r, &mut first, &mut second);
                Some((j, first, second))
            })
            .collect::<Option<_>>()?;
        for (j, first, second) in coded {
            ivf.codes[j * m..(j + 1) * m].copy_from_slice(&first);
            ivf.refine[j * m..(j + 1) * m].copy_from_slice(&second);
        }
        Some(FromCache {
            ivf,
            exact: head.key == key && fresh.is_empty(),
            assigned: fresh.len(),
        })
    }

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
            .map(|(i, c)| (distance_sq(c, q), i))
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn exact(points: &[f32], d: usize, q: &[f32], k: usize) -> Vec<u32> {
        let mut all: Vec<(u32, f32)> = points
            .chunks_exact(d)
            .enumerate()
            .map(|(i, p)| (i as u32, distance_sq(p, q)))
            .collect();
        all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        all.into_iter().take(k).map(|x| x.0).collect()
    }

    /// The items `ivf` finds nearest `q` with `effort`, the `k`-th place settled by the true
    /// distances to `points`, in increasing order.
    fn settled(ivf: &Ivf, points: &Flat, q: &[f32], k: usize, effort: SearchEffort) -> Vec<u32> {
        let found = ivf.search_bounded(q, k, effort);
        let got = resolve(&found, k, |i| Some(distance_sq(points.point(i), q)));
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

    #[test]
    fn distance_matches_the_plain_sum() {
        let a: Vec<f32> = (0..67).map(|i| i as f32 * 0.1).collect();
        let b: Vec<f32> = (0..67).map(|i| (i as f32 * 0.37).sin()).collect();
        let plain: f32 = a.iter().zip(&b).map(|(x, y)| (x - y) * (x - y)).sum();
        assert!((distance_sq(&a, &b) - plain).abs() <= 1e-4 * plain);
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
                let de = distance_sq(flat.point(i), q);
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
        assert!(distance_sq(&z, &ivf.fine[0][..d]) < distance_sq(&z, &ivf.fine[0][d..]));
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

    /// A cell's box is no farther from a query than any code of the cell, by first bytes or
    /// whole.
    #[test]
    fn a_cell_box_bounds_its_codes() {
        let d = 8;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let lo: Vec<f32> = (0..d).map(|_| rng.random_range(-1.0..0.0)).collect();
        let hi: Vec<f32> = lo.iter().map(|l| l + rng.random_range(0.0..2.0)).collect();
        let sq = Sq::from_ranges(&lo, &hi, d);
        for _ in 0..500 {
            let r: Vec<f32> = (0..d).map(|_| rng.random_range(-3.0..3.0)).collect();
            let x: Vec<f32> = lo
                .iter()
                .zip(&hi)
                .map(|(l, h)| rng.random_range(*l..=*h))
                .collect();
            let (mut first, mut second) = (vec![0u8; d], vec![0u8; d]);
            sq.encode(0, &x, &mut first, &mut second);
            let shifted = sq.shift(0, &r);
            let bound = sq.box_distance(0, &r, &vec![0.0; d]);
            let slack = 1e-5 * (1.0 + bound);
            assert!(bound <= Sq::coarse_distance(&shifted, &first) + slack);
            assert!(bound <= Sq::distance(&shifted, &first, &second) + slack);
        }
    }

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

    /// `shapes` shapes of `per` components each, in two segments.
    fn origins(shapes: u32, per: u32) -> Vec<Origin> {
        (0..shapes)
            .map(|i| Origin {
                segment: if i < shapes / 2 {
                    (1, 100, 7)
                } else {
                    (2, 200, 9)
                },
                position: i % (shapes / 2),
                components: per,
            })
            .collect()
    }

    /// A cache file gives back the same inverted file; a flipped byte, a truncated file, cells
    /// out of range or too few give none (the reader then builds it).
    #[test]
    fn cache_round_trip_and_damage() {
        let d = 8;
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let points: Vec<f32> = (0..5_000 * d).map(|_| rng.random_range(0.0..1.0)).collect();
        let flat = Flat { data: &points, d };
        let ivf = Ivf::build(&flat, d);
        let key = 0x5eed_cafe;
        let path = std::path::Path::new("SEARCH-CACHE");
        let origins = origins(500, 10);
        let bytes = ivf.to_cache(key, &origins);
        let back = Ivf::from_cache(path, &bytes, key, &flat, d, &origins).expect("read");
        assert_eq!(back.ivf, ivf);
        assert!(back.exact);
        // the same payload sealed as another format version (version 4 held other fields)
        let payload = bytes[..bytes.len() - crate::file::FOOTER_LEN].to_vec();
        let (older, _) = crate::file::seal(payload, crate::file::KIND_SEARCH_CACHE, 4);
        assert!(Ivf::from_cache(path, &older, key, &flat, d, &origins).is_none());
        assert_eq!(back.assigned, 0);
        // another snapshot key: the same cells, but the cache is worth rewriting
        let other = Ivf::from_cache(path, &bytes, key ^ 1, &flat, d, &origins).expect("read");
        assert_eq!(other.ivf, ivf);
        assert!(!other.exact);
        for at in [0, bytes.len() / 3, bytes.len() / 2, bytes.len() - 40] {
            let mut bad = bytes.clone();
            bad[at] ^= 0x5a;
            assert!(
                Ivf::from_cache(path, &bad, key, &flat, d, &origins).is_none(),
                "byte {at}"
            );
        }
        assert!(
            Ivf::from_cache(path, &bytes[..bytes.len() / 2], key, &flat, d, &origins).is_none()
        );
        // well sealed, but a cell beyond the centroids, or more items listed than points
        let seal = |stored: &Stored| {
            let payload = bincode::serde::encode_to_vec(stored, crate::codec::bincode_config())
                .expect("encode");
            crate::file::seal(
                payload,
                crate::file::KIND_SEARCH_CACHE,
                crate::version::FORMAT_VERSION,
            )
            .0
        };
        let stored = Stored {
            tag: CACHE_TAG,
            key,
            d: d as u32,
            trained: 5_000,
            coarse: ivf.coarse.clone(),
            fine: ivf.fine.clone(),
            pq: ivf.pq.clone(),
            segments: vec![SegmentCells {
                segment: (1, 100, 7),
                positions: (0..250).collect(),
                starts: (0..=250).map(|i| i * 10).collect(),
                cells: vec![u32::MAX; 2_500],
                codes: vec![0; 2_500 * ivf.pq.bytes()],
                refine: vec![0; 2_500 * ivf.pq.bytes()],
            }],
        };
        assert!(Ivf::from_cache(path, &seal(&stored), key, &flat, d, &origins).is_none());
        // the cells in range: read; under another layout's tag: rebuilt
        let in_range = Stored {
            segments: vec![SegmentCells {
                cells: vec![0; 2_500],
                ..stored.segments[0].clone()
            }],
            ..stored.clone()
        };
        assert!(Ivf::from_cache(path, &seal(&in_range), key, &flat, d, &origins).is_some());
        let other_layout = Stored {
            tag: CACHE_TAG ^ 1,
            ..in_range
        };
        assert!(Ivf::from_cache(path, &seal(&other_layout), key, &flat, d, &origins).is_none());
        assert!(Ivf::from_cache(path, &bytes, key, &flat, d, &self::origins(501, 10)).is_none());
        // items the cache does not hold, but no fine cell to put them in
        let empty = Stored {
            fine: vec![Vec::new(); ivf.fine.len()],
            segments: Vec::new(),
            ..stored
        };
        assert!(Ivf::from_cache(path, &seal(&empty), key, &flat, d, &origins).is_none());
        // centroids that are not numbers or overflow: the items still get a cell each
        let mut wild = ivf.coarse.clone();
        wild[0] = f32::NAN;
        wild[d] = f32::MAX;
        let odd = Stored {
            coarse: wild,
            fine: ivf.fine.clone(),
            ..empty
        };
        let read = Ivf::from_cache(path, &seal(&odd), key, &flat, d, &origins).expect("read");
        assert_eq!(read.assigned, 5_000);
        assert_eq!(read.ivf.cells().len(), 5_000);
    }

    /// Shapes the cache does not hold go to their nearest cells, and are found; removed ones
    /// are left out; too many new items for the centroids give none.
    #[test]
    fn a_cache_is_extended_with_new_shapes() {
        let d = 8;
        let mut rng = ChaCha8Rng::seed_from_u64(10);
        let points: Vec<f32> = (0..6_000 * d).map(|_| rng.random_range(0.0..1.0)).collect();
        let path = std::path::Path::new("SEARCH-CACHE");
        // the cache: the first 400 shapes of 10 components
        let old = Flat {
            data: &points[..4_000 * d],
            d,
        };
        let old_origins = origins(400, 10);
        let built = Ivf::build(&old, d);
        let bytes = built.to_cache(1, &old_origins);
        // now: shapes 100..400 of the old segments, and 200 more in a third segment
        let mut now_origins: Vec<Origin> = old_origins[100..].to_vec();
        now_origins.extend((0..200).map(|i| Origin {
            segment: (3, 300, 11),
            position: i,
            components: 10,
        }));
        let now = Flat {
            data: &points[1_000 * d..],
            d,
        };
        let c = Ivf::from_cache(path, &bytes, 2, &now, d, &now_origins).expect("extended");
        assert!(!c.exact);
        assert_eq!(c.assigned, 2_000);
        // the old items keep their cells
        let cells = c.ivf.cells();
        assert_eq!(&cells[..3_000], &built.cells()[1_000..]);
        // every new item is found by its own descriptor
        for i in (3_000..5_000u32).step_by(97) {
            let q = now.point(i);
            // (its residual may lie beyond its cell's ranges: no bound on the distance)
            assert_eq!(c.ivf.search(q, 1, SearchEffort::default())[0].0, i);
        }
        // rewritten for the new snapshot, it reads back exactly
        let again = c.ivf.to_cache(2, &now_origins);
        let back = Ivf::from_cache(path, &again, 2, &now, d, &now_origins).expect("read");
        assert!(back.exact);
        assert_eq!(back.ivf, c.ivf);
        // more than GROWTH times the trained items: built again instead
        let many: Vec<f32> = (0..(GROWTH * 4_000 + 10) * d)
            .map(|_| rng.random_range(0.0..1.0))
            .collect();
        let many_flat = Flat { data: &many, d };
        let many_origins: Vec<Origin> = (0..(GROWTH * 400 + 1) as u32)
            .map(|i| Origin {
                segment: (4, 1, 1),
                position: i,
                components: 10,
            })
            .collect();
        assert!(Ivf::from_cache(path, &bytes, 3, &many_flat, d, &many_origins).is_none());
    }

    #[test]
    fn the_fuzzing_seed_is_accepted() {
        let seed = crate::fuzzing::search_cache_seed();
        assert!(crate::fuzzing::decode_search_cache_payload(&seed));
        assert!(!crate::fuzzing::decode_search_cache_payload(
            &seed[..seed.len() - 1]
        ));
    }
}
