//! The offset volume: distances from grid nodes to the samples, and the outside.
//!
//! 1. A grid of spacing h covers the samples with a margin of the splat reach R = r + 1.5h
//!    plus one spacing, so its border is free.
//! 2. Each sample writes its distance to every node within R (the minimum is kept); nodes no
//!    sample reaches are at +∞. The grid is cut into slabs along z written in parallel, each
//!    from the samples within R of it (a minimum does not depend on the order of writes).
//! 3. Nodes at distance ≥ r are free; a flood fill over free nodes (6-neighbours) from the
//!    border marks the outside.
//!
//! Cost: O(S·(2R/h)³) for S samples, O(nodes) for the fill; 5 bytes per node.

use keycomp_mesh::Point3;
use rayon::prelude::*;

use crate::error::SurfaceError;
use crate::sample::Samples;

/// Most grid nodes of the offset volume (about 5 bytes each).
pub const MAX_NODES: usize = 16_000_000;

/// Nodes along z in one parallel slab.
const SLAB: usize = 8;

/// The splat reach for offset radius `r` on a grid of spacing `h`.
pub fn reach(r: f64, h: f64) -> f64 {
    r + 1.5 * h
}

/// The grid's margin around the samples for offset radius `r` and spacing `h`.
pub fn margin(r: f64, h: f64) -> f64 {
    reach(r, h) + h
}

/// Distances and the outside on a grid.
#[derive(Debug, Clone)]
pub struct Volume {
    /// Position of node (0, 0, 0).
    pub origin: Point3<f64>,
    /// Grid spacing h.
    pub h: f64,
    /// Nodes along x, y, z.
    pub dims: [usize; 3],
    /// Offset radius r.
    pub r: f64,
    /// Distance from each node to the nearest sample (+∞ beyond the reach), x fastest.
    pub dist: Vec<f32>,
    /// Whether the flood fill from the border reached the node.
    pub outside: Vec<bool>,
}

impl Volume {
    /// The volume of `samples` at spacing `h` and offset radius `r` (see the module docs).
    pub fn new(samples: &Samples, h: f64, r: f64) -> Result<Volume, SurfaceError> {
        if !(h > 0.0 && h.is_finite() && r > 0.0 && r.is_finite()) {
            return Err(SurfaceError::Params(format!(
                "grid spacing {h} and offset {r} must be positive"
            )));
        }
        let mut min = Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut max = -min;
        for p in &samples.positions {
            min = min.inf(p);
            max = max.sup(p);
        }
        if samples.positions.is_empty() {
            return Err(SurfaceError::NoArea);
        }
        let m = margin(r, h);
        let origin = min - nalgebra::Vector3::repeat(m);
        let ext = max - min;
        let dims = [ext.x, ext.y, ext.z].map(|e| ((e + 2.0 * m) / h).ceil() as usize + 1);
        let nodes = dims
            .iter()
            .try_fold(1usize, |acc, &d| acc.checked_mul(d))
            .filter(|&n| n <= MAX_NODES)
            .ok_or_else(|| {
                SurfaceError::Params(format!(
                    "a grid of {dims:?} nodes exceeds {MAX_NODES} (spacing {h:e})"
                ))
            })?;
        let mut vol = Volume {
            origin,
            h,
            dims,
            r,
            dist: vec![f32::INFINITY; nodes],
            outside: vec![false; nodes],
        };
        vol.splat(samples);
        vol.fill_outside();
        Ok(vol)
    }

    /// Index of node (i, j, k).
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Position of node (i, j, k).
    pub fn position(&self, i: usize, j: usize, k: usize) -> Point3<f64> {
        self.origin + nalgebra::Vector3::new(i as f64, j as f64, k as f64) * self.h
    }

    /// The node nearest `p`, if inside the grid.
    pub fn nearest_node(&self, p: &Point3<f64>) -> Option<usize> {
        let q = (p - self.origin) / self.h;
        let mut ijk = [0usize; 3];
        for (a, c) in [q.x, q.y, q.z].into_iter().enumerate() {
            let c = c.round();
            if !(c >= 0.0 && c < self.dims[a] as f64) {
                return None;
            }
            ijk[a] = c as usize;
        }
        Some(self.index(ijk[0], ijk[1], ijk[2]))
    }

    /// Whether node `n` is free (at least r from every sample).
    pub fn free(&self, n: usize) -> bool {
        f64::from(self.dist[n]) >= self.r
    }

    /// The field whose zero level is the surface: `d − r` outside (positive), negative in the
    /// shell and the space it encloses; distances capped at the reach.
    pub fn value(&self, n: usize) -> f64 {
        let cap = reach(self.r, self.h);
        let d = f64::from(self.dist[n]).min(cap);
        if self.outside[n] || d < self.r {
            d - self.r
        } else {
            -(d - self.r) - 1e-6 * self.h
        }
    }

    fn splat(&mut self, samples: &Samples) {
        let [nx, ny, nz] = self.dims;
        let (h, origin) = (self.h, self.origin);
        let reach = reach(self.r, h);
        let span = reach / h;
        // samples sorted by z, to find those near a slab
        let mut by_z: Vec<(f64, u32)> = samples
            .positions
            .iter()
            .enumerate()
            .map(|(i, p)| (p.z, i as u32))
            .collect();
        by_z.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let zs: Vec<f64> = by_z.iter().map(|e| e.0).collect();
        let slab_len = nx * ny * SLAB;
        self.dist
            .par_chunks_mut(slab_len)
            .enumerate()
            .for_each(|(s, slab)| {
                let k0 = s * SLAB;
                let k1 = (k0 + SLAB).min(nz); // exclusive
                let z0 = origin.z + k0 as f64 * h - reach;
                let z1 = origin.z + (k1 - 1) as f64 * h + reach;
                let a = zs.partition_point(|&z| z < z0);
                let b = zs.partition_point(|&z| z <= z1);
                for &(_, i) in &by_z[a..b] {
                    let p = samples.positions[i as usize];
                    // the nodes within the reach along each axis
                    let q = (p - origin) / h;
                    let lo = |c: f64| (c - span).ceil() as i64;
                    let hi = |c: f64| (c + span).floor() as i64;
                    let kk0 = lo(q.z).max(k0 as i64);
                    let kk1 = hi(q.z).min(k1 as i64 - 1);
                    for k in kk0..=kk1 {
                        let dz = origin.z + k as f64 * h - p.z;
                        for j in lo(q.y).max(0)..=hi(q.y).min(ny as i64 - 1) {
                            let dy = origin.y + j as f64 * h - p.y;
                            let row = ((k as usize - k0) * ny + j as usize) * nx;
                            for ii in lo(q.x).max(0)..=hi(q.x).min(nx as i64 - 1) {
                                let dx = origin.x + ii as f64 * h - p.x;
                                let d2 = dx * dx + dy * dy + dz * dz;
                                if d2 <= reach * reach {
                                    let d = d2.sqrt() as f32;
                                    let slot = &mut slab[row + ii as usize];
                                    if d < *slot {
                                        *slot = d;
                                    }
                                }
                            }
                        }
                    }
                }
            });
    }

    fn fill_outside(&mut self) {
        let [nx, ny, nz] = self.dims;
        let mut stack: Vec<usize> = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let border =
                        i == 0 || j == 0 || k == 0 || i == nx - 1 || j == ny - 1 || k == nz - 1;
                    let n = self.index(i, j, k);
                    if border && self.free(n) && !self.outside[n] {
                        self.outside[n] = true;
                        stack.push(n);
                    }
                }
            }
        }
        let (sx, sy) = (1, nx);
        let sz = nx * ny;
        let r = self.r;
        let dist = &self.dist;
        let outside = &mut self.outside;
        while let Some(n) = stack.pop() {
            let i = n % nx;
            let j = (n / nx) % ny;
            let k = n / sz;
            let neighbours = [
                (i > 0).then(|| n - sx),
                (i + 1 < nx).then(|| n + sx),
                (j > 0).then(|| n - sy),
                (j + 1 < ny).then(|| n + sy),
                (k > 0).then(|| n - sz),
                (k + 1 < nz).then(|| n + sz),
            ];
            for m in neighbours.into_iter().flatten() {
                if !outside[m] && f64::from(dist[m]) >= r {
                    outside[m] = true;
                    stack.push(m);
                }
            }
        }
    }
}
