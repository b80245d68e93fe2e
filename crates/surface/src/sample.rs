//! Oriented samples of the input: the points the offset volume is measured from.
//!
//! A mesh is sampled at the centroids of its faces split by longest-edge bisection until no
//! edge is longer than the spacing s (a fat face gets about 4·area/s² samples, a sliver about
//! its length over s, never more than its area warrants squared), each sample carrying the
//! unit normal of its face as [`crate::orient`] wound it. Samples are then thinned to one per
//! cube of side s/2 (the first in input order), so that a finely tessellated input costs no
//! more than a coarse one beyond reading it.

use std::collections::HashSet;

use keycomp_mesh::{Mesh, Point3, Vector3};

use crate::error::SurfaceError;

/// Points with unit normals (zero where the side is unknown).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Samples {
    /// Sample positions.
    pub positions: Vec<Point3<f64>>,
    /// Unit normals, or zero.
    pub normals: Vec<Vector3<f64>>,
    /// The input face each sample lies on ([`NO_FACE`] for a point of a cloud).
    pub faces: Vec<u32>,
}

/// [`Samples::faces`] of a sample that lies on no face.
pub const NO_FACE: u32 = u32::MAX;

/// Most samples made from one mesh before thinning (a bound on memory whatever the input).
pub const MAX_RAW_SAMPLES: usize = 40_000_000;

/// Samples of `mesh` at spacing `s`, faces wound as `flip` says (see the module docs).
pub fn lattice(mesh: &Mesh, flip: &[bool], s: f64) -> Result<Samples, SurfaceError> {
    let mut out = Samples::default();
    let mut stack = Vec::new();
    let mut points = Vec::new();
    for (f, _) in mesh.faces.iter().enumerate() {
        let [a, b, c] = mesh.triangle(f);
        let n = (b - a).cross(&(c - a));
        let len = n.norm();
        if !(len > 0.0 && len.is_finite()) {
            continue;
        }
        let n = if flip.get(f).copied().unwrap_or(false) {
            -n / len
        } else {
            n / len
        };
        points.clear();
        bisected([a, b, c], s, &mut stack, &mut points);
        for &p in &points {
            out.positions.push(p);
            out.normals.push(n);
            out.faces.push(f as u32);
        }
        if out.positions.len() > MAX_RAW_SAMPLES {
            return Err(SurfaceError::Params(format!(
                "the input needs more than {MAX_RAW_SAMPLES} samples at spacing {s:e}"
            )));
        }
    }
    Ok(thin(out, 0.5 * s))
}

/// Appends to `points` the centroids of triangle `t` split by longest-edge bisection until no
/// edge is longer than `s` (the module docs), in a fixed order; `stack` is scratch space.
/// Stops early once `points` holds more than [`MAX_RAW_SAMPLES`].
pub fn bisected(
    t: [Point3<f64>; 3],
    s: f64,
    stack: &mut Vec<[Point3<f64>; 3]>,
    points: &mut Vec<Point3<f64>>,
) {
    let s2 = s * s;
    stack.clear();
    stack.push(t);
    while let Some([a, b, c]) = stack.pop() {
        let (ab, bc, ca) = (
            (b - a).norm_squared(),
            (c - b).norm_squared(),
            (a - c).norm_squared(),
        );
        let longest = ab.max(bc).max(ca);
        // a NaN never compares: such a triangle gives its centroid
        if longest <= s2 || longest.is_nan() {
            points.push(Point3::from((a.coords + b.coords + c.coords) / 3.0));
            if points.len() > MAX_RAW_SAMPLES {
                return;
            }
            continue;
        }
        // bisect the longest edge; both halves keep the winding. Edges equal up to
        // rounding count as equal, the first in the order ab, bc, ca taken, so that a
        // moved or scaled copy is sampled alike.
        let tie = longest * (1.0 - TIE);
        if ab >= tie {
            let m = Point3::from((a.coords + b.coords) / 2.0);
            stack.push([a, m, c]);
            stack.push([m, b, c]);
        } else if bc >= tie {
            let m = Point3::from((b.coords + c.coords) / 2.0);
            stack.push([a, b, m]);
            stack.push([a, m, c]);
        } else {
            let m = Point3::from((c.coords + a.coords) / 2.0);
            stack.push([a, b, m]);
            stack.push([m, b, c]);
        }
    }
}

/// Relative difference below which two squared edge lengths count as equal.
const TIE: f64 = 1e-9;

/// Keeps the first sample (in order) of each cube of side `cell`, the cubes anchored at the
/// samples' lowest corner (so that a moved copy keeps the same samples).
pub fn thin(samples: Samples, cell: f64) -> Samples {
    if samples.positions.is_empty() || cell.is_nan() || cell <= 0.0 {
        return samples;
    }
    let min = samples.positions.iter().fold(
        Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY),
        |m, p| m.inf(p),
    );
    let key = |p: &Point3<f64>| {
        [
            ((p.x - min.x) / cell).floor() as i64,
            ((p.y - min.y) / cell).floor() as i64,
            ((p.z - min.z) / cell).floor() as i64,
        ]
    };
    // the first sample of each cube, in one pass: O(n) expected
    let mut seen: HashSet<[i64; 3]> = HashSet::with_capacity(samples.positions.len() / 4);
    let keep: Vec<u32> = (0..samples.positions.len() as u32)
        .filter(|&i| seen.insert(key(&samples.positions[i as usize])))
        .collect();
    Samples {
        positions: keep
            .iter()
            .map(|&i| samples.positions[i as usize])
            .collect(),
        normals: keep.iter().map(|&i| samples.normals[i as usize]).collect(),
        faces: keep.iter().map(|&i| samples.faces[i as usize]).collect(),
    }
}
