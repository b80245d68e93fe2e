//! Approximate nearest-neighbour search over component descriptors: an inverted file with a
//! two-level k-means quantiser (IVF; H. Jégou, M. Douze and C. Schmid, "Product quantization
//! for nearest neighbor search", IEEE TPAMI 33(1), 2011, Section IV, without the product
//! quantisation: the cells hold the descriptors themselves).
//!
//! The descriptors are split into `c` coarse cells by k-means, each coarse cell into `c` fine
//! cells by k-means over its members, with `c ≈ √(n / CELL_SIZE)` so that a fine cell holds about
//! [`CELL_SIZE`] descriptors. Every descriptor is stored once, in its fine cell, contiguously. A
//! query ranks the coarse centroids, takes the fine cells of its [`COARSE_PROBES`] nearest
//! coarse cells, and scans the [`FINE_PROBES`] fine cells with the nearest centroids exactly:
//! about `FINE_PROBES × CELL_SIZE` distances instead of `n`. A true neighbour is missed only
//! when it lies in a cell whose centroid is not among those, so recall is measured, not
//! guaranteed (BENCHMARKS.md, "Candidate search").
//!
//! Everything is deterministic: initial centroids are evenly spaced sample points, and every
//! sum is taken in a fixed order whatever the thread count.

use rayon::prelude::*;

/// Descriptors per fine cell aimed at.
pub const CELL_SIZE: usize = 512;
/// Coarse cells whose fine cells are candidates for scanning.
pub const COARSE_PROBES: usize = 4;
/// Fine cells scanned per query.
pub const FINE_PROBES: usize = 12;
/// Lloyd iterations of each k-means.
const ITERATIONS: usize = 8;
/// Sample points per centroid that k-means is fitted on.
const SAMPLE_PER_CENTROID: usize = 48;

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
    let k = k.clamp(1, members.len().max(1));
    let step = (members.len() / (k * SAMPLE_PER_CENTROID)).max(1);
    let sample: Vec<u32> = members.iter().step_by(step).copied().collect();
    let point = |i: u32| points.point(i);
    let mut centroids: Vec<f32> = (0..k)
        .flat_map(|j| point(sample[j * sample.len() / k]).to_vec())
        .collect();
    for _ in 0..ITERATIONS {
        let assigned: Vec<usize> = sample
            .par_iter()
            .map(|&i| nearest(&centroids, d, point(i)))
            .collect();
        let mut of: Vec<Vec<u32>> = vec![Vec::new(); k];
        for (&i, &c) in sample.iter().zip(&assigned) {
            of[c].push(i);
        }
        let next: Vec<Vec<f32>> = of
            .par_iter()
            .enumerate()
            .map(|(j, pts)| {
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
            })
            .collect();
        centroids = next.concat();
    }
    centroids
}

/// What a cache file holds.
#[derive(serde::Serialize, serde::Deserialize)]
struct Stored {
    key: u64,
    d: u32,
    coarse: Vec<f32>,
    fine: Vec<Vec<f32>>,
    cell: Vec<u32>,
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
    /// Per coarse cell, per fine cell: the range of `items` / `data` it holds.
    ranges: Vec<Vec<(u32, u32)>>,
    /// Item ids (positions in the reader's component list), grouped by fine cell.
    items: Vec<u32>,
    /// The descriptors of `items`, in the same order, flat.
    data: Vec<f32>,
}

impl Ivf {
    /// Builds the inverted file of `points` (`d` values each; item `i` is point `i`).
    pub(crate) fn build(points: &impl Points, d: usize) -> Ivf {
        let n = points.len();
        let c = ((n as f64 / CELL_SIZE as f64).sqrt().ceil() as usize).max(1);
        let all: Vec<u32> = (0..n as u32).collect();
        let coarse = kmeans(points, d, &all, c);
        let point = |i: u32| points.point(i);
        let top: Vec<usize> = all
            .par_iter()
            .map(|&i| nearest(&coarse, d, point(i)))
            .collect();
        let mut members: Vec<Vec<u32>> = vec![Vec::new(); coarse.len() / d];
        for (i, &t) in top.iter().enumerate() {
            members[t].push(i as u32);
        }
        // each coarse cell: its fine centroids and the fine cell of each member
        let cells: Vec<(Vec<f32>, Vec<u32>)> = members
            .par_iter()
            .map(|m| {
                if m.is_empty() {
                    return (Vec::new(), Vec::new());
                }
                let fine = kmeans(points, d, m, c);
                let of: Vec<u32> = m
                    .iter()
                    .map(|&i| nearest(&fine, d, point(i)) as u32)
                    .collect();
                (fine, of)
            })
            .collect();
        let mut cell = vec![0u32; n];
        let mut base = 0u32;
        let mut fine = Vec::with_capacity(cells.len());
        for ((centroids, of), m) in cells.into_iter().zip(&members) {
            for (&i, &f) in m.iter().zip(&of) {
                cell[i as usize] = base + f;
            }
            base += (centroids.len() / d) as u32;
            fine.push(centroids);
        }
        Ivf::from_parts(points, d, coarse, fine, &cell)
            .expect("cells computed from the centroids are in range")
    }

    /// The inverted file of `points` with these centroids, item `i` in global fine cell
    /// `cell[i]` (fine cells numbered coarse cell by coarse cell). Each cell lists its items in
    /// increasing order. `None` when the parts do not fit together (a damaged cache).
    fn from_parts(
        points: &impl Points,
        d: usize,
        coarse: Vec<f32>,
        fine: Vec<Vec<f32>>,
        cell: &[u32],
    ) -> Option<Ivf> {
        let n = points.len();
        if d == 0
            || cell.len() != n
            || !coarse.len().is_multiple_of(d)
            || coarse.len() / d != fine.len()
            || fine.iter().any(|f| !f.len().is_multiple_of(d))
        {
            return None;
        }
        let cells: usize = fine.iter().map(|f| f.len() / d).sum();
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
        let mut g = 0;
        for f in &fine {
            let r: Vec<(u32, u32)> = (0..f.len() / d)
                .map(|k| (counts[g + k], counts[g + k + 1]))
                .collect();
            g += r.len();
            ranges.push(r);
        }
        let mut data = Vec::with_capacity(n * d);
        for &i in &items {
            data.extend_from_slice(points.point(i));
        }
        Some(Ivf {
            d,
            coarse,
            fine,
            ranges,
            items,
            data,
        })
    }

    /// The inverted file as a cache file for the descriptors identified by `key` (the reader's
    /// key of its snapshot): the centroids and each item's cell, sealed like the index's files.
    pub(crate) fn to_cache(&self, key: u64) -> Vec<u8> {
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
        let stored = Stored {
            key,
            d: self.d as u32,
            coarse: self.coarse.clone(),
            fine: self.fine.clone(),
            cell,
        };
        let payload = bincode::serde::encode_to_vec(&stored, crate::manifest::bincode_config())
            .unwrap_or_default();
        crate::file::seal(
            payload,
            crate::file::KIND_SEARCH_CACHE,
            crate::FORMAT_VERSION,
        )
        .0
    }

    /// The inverted file of `points` from a cache file's bytes (read from `path`), or `None`
    /// when the file is damaged, of another format, or made for other descriptors than those
    /// identified by `key`.
    pub(crate) fn from_cache(
        path: &std::path::Path,
        bytes: Vec<u8>,
        key: u64,
        points: &impl Points,
        d: usize,
    ) -> Option<Ivf> {
        let opened = crate::file::unseal(
            path,
            bytes,
            crate::file::KIND_SEARCH_CACHE,
            crate::FORMAT_VERSION,
        )
        .ok()?;
        Ivf::from_payload(opened.payload(), key, points, d)
    }

    /// [`Ivf::from_cache`] on a cache file's payload (its footer and checksum already checked).
    pub(crate) fn from_payload(
        payload: &[u8],
        key: u64,
        points: &impl Points,
        d: usize,
    ) -> Option<Ivf> {
        let (stored, _): (Stored, usize) = crate::manifest::decode_bounded(payload).ok()?;
        if stored.key != key || stored.d as usize != d {
            return None;
        }
        Ivf::from_parts(points, d, stored.coarse, stored.fine, &stored.cell)
    }

    /// About the `k` nearest items to `q` (see the module documentation), nearest first, with
    /// their squared distances ([`distance_sq`]); ties by item id.
    pub(crate) fn search(&self, q: &[f32], k: usize) -> Vec<(u32, f32)> {
        let d = self.d;
        let mut coarse: Vec<(f32, usize)> = self
            .coarse
            .chunks_exact(d)
            .enumerate()
            .map(|(i, c)| (distance_sq(c, q), i))
            .collect();
        keep_smallest(&mut coarse, COARSE_PROBES, |a, b| {
            a.0.total_cmp(&b.0).then(a.1.cmp(&b.1))
        });
        let mut fine: Vec<(f32, usize, usize)> = Vec::new();
        for &(_, ci) in &coarse {
            for (fi, c) in self.fine[ci].chunks_exact(d).enumerate() {
                fine.push((distance_sq(c, q), ci, fi));
            }
        }
        keep_smallest(&mut fine, FINE_PROBES, |a, b| {
            a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2)))
        });
        let mut found: Vec<(u32, f32)> = Vec::new();
        for &(_, ci, fi) in &fine {
            let (start, end) = self.ranges[ci][fi];
            for j in start as usize..end as usize {
                found.push((
                    self.items[j],
                    distance_sq(&self.data[j * d..(j + 1) * d], q),
                ));
            }
        }
        let by = |a: &(u32, f32), b: &(u32, f32)| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0));
        keep_smallest(&mut found, k, by);
        found.sort_by(by);
        found
    }

    /// Bytes held (centroids, items and the copy of the descriptors).
    pub(crate) fn bytes(&self) -> usize {
        4 * (self.coarse.len()
            + self.fine.iter().map(Vec::len).sum::<usize>()
            + self.items.len()
            + self.data.len())
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
        let centres: Vec<Vec<f32>> = (0..40)
            .map(|_| (0..d).map(|_| rng.random_range(0.0..1.0)).collect())
            .collect();
        let n = 20_000;
        let points: Vec<f32> = (0..n)
            .flat_map(|i| {
                let c = &centres[i % centres.len()];
                c.iter()
                    .map(|x| x + rng.random_range(-0.05..0.05))
                    .collect::<Vec<f32>>()
            })
            .collect();
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
            let got = ivf.search(q, 20);
            assert_eq!(got[0].0, qi as u32);
            assert_eq!(got, again.search(q, 20));
            let want = exact(&points, d, q, 20);
            hits += got.iter().filter(|g| want.contains(&g.0)).count();
            total += want.len();
        }
        assert!(hits as f64 >= 0.9 * total as f64, "recall {hits}/{total}");
    }

    /// A cache file gives back the same inverted file; another key, a flipped byte, a
    /// truncated file or cells out of range give none (the reader then builds it).
    #[test]
    fn cache_round_trip_and_damage() {
        let d = 8;
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let points: Vec<f32> = (0..5_000 * d).map(|_| rng.random_range(0.0..1.0)).collect();
        let flat = Flat { data: &points, d };
        let ivf = Ivf::build(&flat, d);
        let key = 0x5eed_cafe;
        let path = std::path::Path::new("SEARCH-CACHE");
        let bytes = ivf.to_cache(key);
        assert_eq!(
            Ivf::from_cache(path, bytes.clone(), key, &flat, d).as_ref(),
            Some(&ivf)
        );
        assert!(Ivf::from_cache(path, bytes.clone(), key ^ 1, &flat, d).is_none());
        for at in [0, bytes.len() / 3, bytes.len() / 2, bytes.len() - 40] {
            let mut bad = bytes.clone();
            bad[at] ^= 0x5a;
            assert!(
                Ivf::from_cache(path, bad, key, &flat, d).is_none(),
                "byte {at}"
            );
        }
        assert!(Ivf::from_cache(path, bytes[..bytes.len() / 2].to_vec(), key, &flat, d).is_none());
        // well sealed, but a cell beyond the centroids, or fewer cells than points
        for cell in [vec![u32::MAX; 5_000], vec![0; 10]] {
            let stored = Stored {
                key,
                d: d as u32,
                coarse: ivf.coarse.clone(),
                fine: ivf.fine.clone(),
                cell,
            };
            let payload = bincode::serde::encode_to_vec(&stored, crate::manifest::bincode_config())
                .expect("encode");
            let sealed = crate::file::seal(
                payload,
                crate::file::KIND_SEARCH_CACHE,
                crate::FORMAT_VERSION,
            )
            .0;
            assert!(Ivf::from_cache(path, sealed, key, &flat, d).is_none());
        }
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
