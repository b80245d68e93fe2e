//! Visibility pass: rasterises every triangle into a buffer holding, per sample, the depth and
//! the id of the nearest face (a "visibility buffer", Burns & Hunt 2013), in parallel over
//! horizontal bands of sample rows.
//!
//! Coverage uses integer edge functions (Pineda 1988) on vertices snapped to 1/256 of a
//! sample, evaluated at sample centres, with the top-left fill rule: a sample exactly on an
//! edge belongs to the triangle for which that edge is a top or left edge, so two triangles
//! sharing an edge cover every sample along it exactly once. Ties in depth go to the smaller
//! face id, so the result does not depend on drawing order or on the number of threads.

use rayon::prelude::*;

/// Sub-sample precision: vertices are snapped to 1/`SUB` of a sample.
pub(crate) const SUB: i64 = 256;
/// Half a sample in fixed point: sample centres are at `i · SUB + HALF`.
const HALF: i64 = SUB / 2;
/// Sample rows per band (the unit of parallel work).
const BAND: usize = 8;
/// Face id of a sample no face covers.
pub(crate) const NONE: u32 = u32::MAX;

/// The depth plane of a face in sample coordinates: `depth = c + a·x + b·y`, clamped to the
/// range of the corner depths (so slivers cannot extrapolate wildly).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Plane {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub zmin: f64,
    pub zmax: f64,
}

impl Plane {
    /// The plane through three points `[x, y, depth]`; `None` when they are collinear in x, y.
    pub fn through(p: [[f64; 3]; 3]) -> Option<Plane> {
        let (e1, e2) = (sub(p[1], p[0]), sub(p[2], p[0]));
        let det = e1[0] * e2[1] - e2[0] * e1[1];
        if det == 0.0 {
            return None;
        }
        let a = (e1[2] * e2[1] - e2[2] * e1[1]) / det;
        let b = (e1[0] * e2[2] - e2[0] * e1[2]) / det;
        Some(Plane {
            a,
            b,
            c: p[0][2] - a * p[0][0] - b * p[0][1],
            zmin: p[0][2].min(p[1][2]).min(p[2][2]),
            zmax: p[0][2].max(p[1][2]).max(p[2][2]),
        })
    }

    /// The unclamped plane at the centre of sample `(i, j)` (for extrapolating beyond the face).
    #[inline]
    pub fn extrapolate(&self, i: usize, j: usize) -> f64 {
        self.c + self.b * (j as f64 + 0.5) + self.a * (i as f64 + 0.5)
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Per-sample nearest depth and face id of a `width × width` sample grid, row-major.
pub(crate) struct VisBuffer {
    pub width: usize,
    pub depth: Vec<f32>,
    pub face: Vec<u32>,
}

/// One edge function `E(p) = dx·(p.y − a.y) − dy·(p.x − a.x)` (+ the fill-rule bias), set up
/// at a starting sample with its steps per sample in x and y.
struct Edge {
    start: i64,
    step_x: i64,
    step_y: i64,
}

impl Edge {
    fn new(a: [i64; 2], b: [i64; 2], px: i64, py: i64) -> Edge {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        // With y down and positive area, an edge going up is a left edge and a horizontal edge
        // going right is a top edge; samples exactly on those count as inside.
        let top_left = dy < 0 || (dy == 0 && dx > 0);
        let bias = if top_left { 0 } else { -1 };
        Edge {
            start: dx * (py - a[1]) - dy * (px - a[0]) + bias,
            step_x: -dy * SUB,
            step_y: dx * SUB,
        }
    }
}

/// Twice the signed area of the triangle in fixed point (positive = clockwise on screen with
/// y down, the orientation the rasteriser uses).
#[inline]
fn area2(a: [i64; 2], b: [i64; 2], c: [i64; 2]) -> i64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

fn floor_div(n: i64, d: i64) -> i64 {
    n.div_euclid(d)
}

fn ceil_div(n: i64, d: i64) -> i64 {
    -(-n).div_euclid(d)
}

/// Range of sample indices `lo..=hi` whose centres lie in `[min, max]` (fixed point), clipped
/// to `0..limit`; empty when `lo > hi`.
fn sample_range(min: i64, max: i64, limit: usize) -> (i64, i64) {
    (
        ceil_div(min - HALF, SUB).max(0),
        floor_div(max - HALF, SUB).min(limit as i64 - 1),
    )
}

/// Rasterises `faces` (vertex ids into `fixed`, the snapped sample coordinates) with their
/// depth `planes` into a `width × width` visibility buffer.
pub(crate) fn rasterize(
    width: usize,
    fixed: &[[i64; 2]],
    faces: &[[u32; 3]],
    planes: &[Option<Plane>],
) -> VisBuffer {
    let bands = width.div_ceil(BAND);
    // Bin faces by the bands their sample rows touch (counting sort into one flat list).
    let ranges: Vec<Option<(usize, usize)>> = faces
        .par_iter()
        .zip(planes)
        .map(|(f, plane)| {
            plane.as_ref()?;
            let ys = f.map(|v| fixed[v as usize][1]);
            let (lo, hi) = sample_range(
                ys[0].min(ys[1]).min(ys[2]),
                ys[0].max(ys[1]).max(ys[2]),
                width,
            );
            (lo <= hi).then_some((lo as usize / BAND, hi as usize / BAND))
        })
        .collect();
    let mut start = vec![0usize; bands + 1];
    for &(b0, b1) in ranges.iter().flatten() {
        for b in b0..=b1 {
            start[b + 1] += 1;
        }
    }
    for b in 0..bands {
        start[b + 1] += start[b];
    }
    let mut fill = start.clone();
    let mut binned = vec![0u32; start[bands]];
    for (f, &(b0, b1)) in ranges
        .iter()
        .enumerate()
        .filter_map(|(f, r)| r.as_ref().map(|r| (f, r)))
    {
        for b in b0..=b1 {
            binned[fill[b]] = f as u32;
            fill[b] += 1;
        }
    }

    let mut depth = vec![f32::INFINITY; width * width];
    let mut face = vec![NONE; width * width];
    depth
        .par_chunks_mut(BAND * width)
        .zip(face.par_chunks_mut(BAND * width))
        .enumerate()
        .for_each(|(band, (depth, ids))| {
            let y0 = band * BAND;
            let rows = depth.len() / width;
            for &f in &binned[start[band]..start[band + 1]] {
                let Some(plane) = &planes[f as usize] else {
                    continue;
                };
                let [p0, mut p1, mut p2] = faces[f as usize].map(|v| fixed[v as usize]);
                let area = area2(p0, p1, p2);
                if area == 0 {
                    continue;
                }
                if area < 0 {
                    std::mem::swap(&mut p1, &mut p2);
                }
                let (x0, x1) = sample_range(
                    p0[0].min(p1[0]).min(p2[0]),
                    p0[0].max(p1[0]).max(p2[0]),
                    width,
                );
                let (ya, yb) = sample_range(
                    p0[1].min(p1[1]).min(p2[1]),
                    p0[1].max(p1[1]).max(p2[1]),
                    width,
                );
                let (ya, yb) = (ya.max(y0 as i64), yb.min((y0 + rows) as i64 - 1));
                if x0 > x1 || ya > yb {
                    continue;
                }
                let (px, py) = (x0 * SUB + HALF, ya * SUB + HALF);
                let e = [
                    Edge::new(p1, p2, px, py),
                    Edge::new(p2, p0, px, py),
                    Edge::new(p0, p1, px, py),
                ];
                let mut row = [e[0].start, e[1].start, e[2].start];
                let (x0, x1) = (x0 as usize, x1 as usize);
                for j in ya as usize..=yb as usize {
                    let mut w = row;
                    let base = (j - y0) * width;
                    let zrow = plane.c + plane.b * (j as f64 + 0.5);
                    for i in x0..=x1 {
                        if (w[0] | w[1] | w[2]) >= 0 {
                            let z = (zrow + plane.a * (i as f64 + 0.5))
                                .clamp(plane.zmin, plane.zmax)
                                as f32;
                            let k = base + i;
                            if z < depth[k] || (z == depth[k] && f < ids[k]) {
                                depth[k] = z;
                                ids[k] = f;
                            }
                        }
                        w[0] += e[0].step_x;
                        w[1] += e[1].step_x;
                        w[2] += e[2].step_x;
                    }
                    row[0] += e[0].step_y;
                    row[1] += e[1].step_y;
                    row[2] += e[2].step_y;
                }
            }
        });
    VisBuffer { width, depth, face }
}
