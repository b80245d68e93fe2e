//! Point clouds as samples: spacing, area, and normals with a consistent side.
//!
//! A scanner's points come without faces; their normals, when the file has none, are fitted
//! and oriented as Hoppe et al. do ("Surface reconstruction from unorganized points",
//! SIGGRAPH 1992):
//!
//! 1. The normal of a point is the direction of least variance of its [`NEIGHBOURS`] nearest
//!    points (PCA of their covariance).
//! 2. The sides are made consistent by a minimum spanning tree over the neighbour graph with
//!    edge cost `1 − |n_i · n_j|`, walked from a seed (Prim's order), each normal turned to
//!    agree with the one it is reached from: orientation travels along smooth stretches first.
//! 3. Each connected part of the graph then faces away from its own centroid on average
//!    (`Σ (p − c)·n > 0`): outward for a closed object, towards the scanner for one view of
//!    an object (the points of a view bulge towards the viewer).
//!
//! Normals given by the file are used as they are (their sign included).
//!
//! The cloud's area is estimated as `n · s²` with s the median distance from a point to its
//! nearest neighbour (each point stands for about s² of surface), which sets the first grid
//! spacing ([`crate::canonical`]).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use keycomp_mesh::geometry::{self, BoundingBox};
use keycomp_mesh::{Point3, Vector3};
use nalgebra::Matrix3;
use rayon::prelude::*;

use crate::error::SurfaceError;
use crate::sample::{Samples, thin};
use crate::trim::{kd_tree, nearest_ids};

/// Points in a normal's PCA neighbourhood (the point itself included).
pub const NEIGHBOURS: usize = 12;

/// The neighbour whose distance measures a cloud's gaps ([`Cloud::samples`]): two neighbours
/// along a line and the two across it come first.
pub const GAP_NEIGHBOUR: usize = 4;

/// Most points whose nearest-neighbour distance is measured for the spacing estimate.
const SPACING_PROBES: usize = 4096;

/// A point cloud prepared for [`crate::canonical`].
#[derive(Debug, Clone)]
pub struct Cloud {
    positions: Vec<Point3<f64>>,
    normals: Option<Vec<Vector3<f64>>>,
    spacing: f64,
}

impl Cloud {
    /// The cloud of `positions` (finite, as readers guarantee) with `normals` if known.
    /// Errors with [`SurfaceError::NoArea`] for fewer than 3 distinct points.
    pub fn new(
        positions: &[Point3<f64>],
        normals: Option<&[Vector3<f64>]>,
    ) -> Result<Cloud, SurfaceError> {
        let finite: Vec<usize> = (0..positions.len())
            .filter(|&i| {
                let p = positions[i];
                p.x.is_finite() && p.y.is_finite() && p.z.is_finite()
            })
            .collect();
        let pts: Vec<Point3<f64>> = finite.iter().map(|&i| positions[i]).collect();
        let normals = normals.filter(|n| n.len() == positions.len()).map(|n| {
            finite
                .iter()
                .map(|&i| {
                    let v = n[i];
                    let l = v.norm();
                    if l.is_finite() && l > 0.0 {
                        v / l
                    } else {
                        Vector3::zeros()
                    }
                })
                .collect()
        });
        if pts.len() < 3 {
            return Err(SurfaceError::NoArea);
        }
        let tree = kd_tree(&pts);
        let step = (pts.len() / SPACING_PROBES).max(1);
        let mut d: Vec<f64> = (0..pts.len())
            .step_by(step)
            .filter_map(|i| {
                let p = pts[i];
                nearest_ids(&tree, &p, 4)
                    .into_iter()
                    .map(|j| (pts[j as usize] - p).norm())
                    .find(|&x| x > 0.0)
            })
            .collect();
        if d.is_empty() {
            return Err(SurfaceError::NoArea);
        }
        d.sort_by(f64::total_cmp);
        let spacing = d[d.len() / 2];
        Ok(Cloud {
            positions: pts,
            normals,
            spacing,
        })
    }

    /// Estimated area of the surface the points sample.
    pub fn area_estimate(&self) -> f64 {
        self.positions.len() as f64 * self.spacing * self.spacing
    }

    /// The points' bounding box.
    pub fn bounding_box(&self) -> BoundingBox {
        geometry::bounding_box_of(self.positions.iter().copied())
    }

    /// The points thinned to one per cube of side `s/2`, with oriented normals (see the module
    /// docs), and the largest gap the offset must bridge: the 98th percentile of the distance
    /// from a kept point to its [`GAP_NEIGHBOUR`]-th nearest kept neighbour. Not the nearest:
    /// points in lines (a scanner's rows, a mesh's rings of vertices) have their nearest
    /// neighbour along the line, and the gap to the next line is the third or fourth.
    pub fn samples(&self, s: f64) -> (Samples, f64) {
        let given = Samples {
            positions: self.positions.clone(),
            normals: self
                .normals
                .clone()
                .unwrap_or_else(|| vec![Vector3::zeros(); self.positions.len()]),
            faces: vec![crate::sample::NO_FACE; self.positions.len()],
        };
        let mut kept = thin(given, 0.5 * s);
        let tree = kd_tree(&kept.positions);
        let neighbours: Vec<Vec<u32>> = kept
            .positions
            .par_iter()
            .map(|p| nearest_ids(&tree, p, NEIGHBOURS))
            .collect();
        let mut gaps: Vec<f64> = kept
            .positions
            .iter()
            .zip(&neighbours)
            .filter_map(|(p, nb)| {
                nb.iter()
                    .map(|&j| (kept.positions[j as usize] - p).norm())
                    .filter(|&d| d > 0.0)
                    .nth(GAP_NEIGHBOUR - 1)
            })
            .collect();
        gaps.sort_by(f64::total_cmp);
        let gap = gaps.get(gaps.len() * 49 / 50).copied().unwrap_or(0.0);
        if self.normals.is_none() {
            kept.normals = fitted_normals(&kept.positions, &neighbours);
        }
        (kept, gap)
    }
}

/// PCA normals of `points` (neighbours of each given), oriented (steps 1–3 of the module docs).
fn fitted_normals(points: &[Point3<f64>], neighbours: &[Vec<u32>]) -> Vec<Vector3<f64>> {
    let n = points.len();
    let mut normals: Vec<Vector3<f64>> = neighbours
        .par_iter()
        .map(|nb| {
            let m = nb.len().max(1) as f64;
            let c = nb
                .iter()
                .fold(Vector3::zeros(), |acc, &j| acc + points[j as usize].coords)
                / m;
            let mut cov = Matrix3::zeros();
            for &j in nb {
                let d = points[j as usize].coords - c;
                cov += d * d.transpose();
            }
            let eig = cov.symmetric_eigen();
            let (mut k, mut least) = (0, f64::INFINITY);
            for (i, &v) in eig.eigenvalues.iter().enumerate() {
                if v < least {
                    least = v;
                    k = i;
                }
            }
            let v: Vector3<f64> = eig.eigenvectors.column(k).into_owned();
            let l = v.norm();
            if l > 0.0 && l.is_finite() {
                v / l
            } else {
                Vector3::zeros()
            }
        })
        .collect();
    // symmetric neighbour graph
    let mut graph: Vec<Vec<u32>> = neighbours.to_vec();
    for (i, nb) in neighbours.iter().enumerate() {
        for &j in nb {
            if j as usize != i {
                graph[j as usize].push(i as u32);
            }
        }
    }
    for g in &mut graph {
        g.sort_unstable();
        g.dedup();
    }
    let mut done = vec![false; n];
    let mut heap = BinaryHeap::new();
    let mut part: Vec<u32> = Vec::new();
    for seed in 0..n {
        if done[seed] {
            continue;
        }
        part.clear();
        heap.push(Edge {
            cost: 0.0,
            to: seed as u32,
            from: seed as u32,
        });
        while let Some(Edge { to, from, .. }) = heap.pop() {
            let t = to as usize;
            if done[t] {
                continue;
            }
            done[t] = true;
            part.push(to);
            if normals[t].dot(&normals[from as usize]) < 0.0 {
                normals[t] = -normals[t];
            }
            for &j in &graph[t] {
                if !done[j as usize] {
                    heap.push(Edge {
                        cost: 1.0 - normals[t].dot(&normals[j as usize]).abs(),
                        to: j,
                        from: to,
                    });
                }
            }
        }
        let c = part
            .iter()
            .fold(Vector3::zeros(), |acc, &i| acc + points[i as usize].coords)
            / part.len().max(1) as f64;
        let outward: f64 = part
            .iter()
            .map(|&i| (points[i as usize].coords - c).dot(&normals[i as usize]))
            .sum();
        if outward < 0.0 {
            for &i in &part {
                normals[i as usize] = -normals[i as usize];
            }
        }
    }
    normals
}

/// An edge of Prim's walk, cheapest first (ties by target, then source: deterministic).
struct Edge {
    cost: f64,
    to: u32,
    from: u32,
}

impl PartialEq for Edge {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Edge {}
impl PartialOrd for Edge {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Edge {
    fn cmp(&self, other: &Self) -> Ordering {
        // BinaryHeap is a max-heap: the cheapest edge must compare greatest
        other
            .cost
            .total_cmp(&self.cost)
            .then(other.to.cmp(&self.to))
            .then(other.from.cmp(&self.from))
    }
}

#[cfg(test)]
mod tests {
    use super::tests_support::fibonacci_sphere;
    use super::*;

    /// Points on a sphere get normals along the radius, pointing out, whatever their order.
    #[test]
    fn sphere_normals_point_outward() {
        let pts = fibonacci_sphere(2000, 1.0);
        let cloud = Cloud::new(&pts, None).expect("cloud");
        let (s, _) = cloud.samples(0.02);
        assert!(s.positions.len() > 1500);
        for (p, n) in s.positions.iter().zip(&s.normals) {
            let radial = p.coords / p.coords.norm();
            assert!(n.dot(&radial) > 0.95, "{p:?} {n:?}");
        }
        // area estimate within 40 % of 4π
        let a = cloud.area_estimate();
        assert!((a / (4.0 * std::f64::consts::PI) - 1.0).abs() < 0.4, "{a}");
    }

    /// One side of a bump seen from above: the normals point up, towards the viewer.
    #[test]
    fn a_view_faces_its_viewer() {
        let mut pts = Vec::new();
        for i in 0..60 {
            for j in 0..60 {
                let (x, y) = (i as f64 / 30.0 - 1.0, j as f64 / 30.0 - 1.0);
                pts.push(Point3::new(x, y, 0.5 * (1.0 - x * x - y * y)));
            }
        }
        let cloud = Cloud::new(&pts, None).expect("cloud");
        let (s, gap) = cloud.samples(0.01);
        assert!(s.normals.iter().all(|n| n.z > 0.5));
        assert!(gap > 0.0 && gap < 0.1, "{gap}");
    }

    #[test]
    fn too_few_points() {
        let p = [
            Point3::origin(),
            Point3::origin(),
            Point3::new(1.0, 0.0, 0.0),
        ];
        assert!(Cloud::new(&p[..2], None).is_err());
        assert!(Cloud::new(&[Point3::origin(); 5], None).is_err());
        assert!(Cloud::new(&p, None).is_ok());
    }
}

/// Shapes shared by the crate's tests.
#[cfg(test)]
pub(crate) mod tests_support {
    use keycomp_mesh::Point3;

    /// `n` points spread evenly on a sphere of radius `r`.
    pub(crate) fn fibonacci_sphere(n: usize, r: f64) -> Vec<Point3<f64>> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let rad = (1.0 - y * y).sqrt();
                let t = golden * i as f64;
                Point3::new(r * rad * t.cos(), r * y, r * rad * t.sin())
            })
            .collect()
    }
}
