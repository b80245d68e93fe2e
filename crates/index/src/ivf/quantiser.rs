//! The scalar quantiser of the inverted file's residuals ([`Sq`]): two bytes per value, levels
//! per fine cell and per value, the first byte alone naming a run of levels for the scan and
//! both bytes the level for the re-ranking; and the distances a search computes from codes:
//! by first bytes, by whole codes, and to a cell's box (the bound that lets the search skip
//! cells).
//!
//! Two bytes per value, with ranges per cell, because near-duplicate parts differ by less than
//! a level of one byte over the whole range of residuals, and ranges per cell make the levels
//! fine where such parts crowd (BENCHMARKS.md, *The index at scale*).

/// Levels of the scalar quantiser (two bytes per value: the scan reads the first, the
/// re-ranking both).
const LEVELS: usize = 65_536;
/// Levels in the run that a code's first byte names (its second byte picks one of them).
const RUN: usize = 256;

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
    pub(super) d: u32,
    /// Per cell and value: the first level.
    pub(super) min: Vec<f32>,
    /// Per cell and value: the step between levels.
    pub(super) step: Vec<f32>,
}

/// A query's residual from one fine centroid, prepared for [`Sq::coarse_distance`] and
/// [`Sq::distance`] of that cell's codes.
pub(super) struct Shifted<'a> {
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
    pub(super) error: f32,
}

impl Sq {
    /// The quantiser of cells whose residual values range from `lo` to `hi` (per cell, `d`
    /// values each; a cell without members has infinite bounds).
    pub(super) fn from_ranges(lo: &[f32], hi: &[f32], d: usize) -> Sq {
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
    pub(super) fn bytes(&self) -> usize {
        self.d as usize
    }

    /// Whether the quantiser fits `cells` cells of vectors of `d` values, with finite levels.
    pub(super) fn fits(&self, d: usize, cells: usize) -> bool {
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
    pub(super) fn encode(&self, g: usize, r: &[f32], first: &mut [u8], second: &mut [u8]) {
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
    pub(super) fn shift(&self, g: usize, r: &[f32]) -> Shifted<'_> {
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
    pub(super) fn coarse_distance(q: &Shifted, first: &[u8]) -> f32 {
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
    pub(super) fn box_distance(&self, g: usize, q: &[f32], c: &[f32]) -> f32 {
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
    pub(super) fn distance(q: &Shifted, first: &[u8], second: &[u8]) -> f32 {
        let mut sum = 0f32;
        for i in 0..q.fine.len() {
            let level = f32::from(u16::from_be_bytes([first[i], second[i]]));
            let d = q.fine[i] - q.step[i] * level;
            sum += d * d;
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

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
}
