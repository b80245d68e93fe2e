//! The nearest point of a triangle mesh to a query point, exactly: a bounding-volume hierarchy
//! of axis-aligned boxes over the triangles, searched nearest box first and pruned by the best
//! distance found (C. Ericson, *Real-Time Collision Detection*, Morgan Kaufmann 2005, §6.1 and
//! §5.1.5 for the point–triangle distance).
//!
//! Building is O(F log F) (median splits along the longest axis of the centroids' box, leaves
//! of at most [`LEAF`] triangles); a query near the surface visits O(log F) nodes. Boundary
//! edges (edges of one face) get a tree of their own, for points that must stay on a
//! boundary ([`ClosestPoint::on_boundary`]).

use keycomp_mesh::{Mesh, Point3};

use crate::directed::Directed;
use crate::trim::closest_on_triangle;

/// Most triangles in a leaf.
pub const LEAF: usize = 4;

#[derive(Debug, Clone)]
struct Node {
    min: Point3<f64>,
    max: Point3<f64>,
    /// Leaf: `first..first + count` of the item order; inner: children `first` and
    /// `first + 1`, `count` = 0.
    first: u32,
    count: u32,
}

/// A hierarchy of boxes over items of some shape.
#[derive(Debug, Clone)]
struct Tree {
    nodes: Vec<Node>,
    order: Vec<u32>,
}

impl Tree {
    /// The tree over `n` items whose boxes `bounds(i)` gives.
    fn new(n: usize, bounds: impl Fn(usize) -> (Point3<f64>, Point3<f64>)) -> Tree {
        let boxes: Vec<(Point3<f64>, Point3<f64>)> = (0..n).map(&bounds).collect();
        let centres: Vec<Point3<f64>> = boxes
            .iter()
            .map(|(a, b)| Point3::from((a.coords + b.coords) * 0.5))
            .collect();
        let mut tree = Tree {
            nodes: Vec::with_capacity(2 * n / LEAF + 1),
            order: (0..n as u32).collect(),
        };
        if n > 0 {
            tree.nodes.push(Node {
                min: Point3::origin(),
                max: Point3::origin(),
                first: 0,
                count: 0,
            });
            tree.build(0, 0, n, &boxes, &centres);
        }
        tree
    }

    fn build(
        &mut self,
        node: usize,
        lo: usize,
        hi: usize,
        boxes: &[(Point3<f64>, Point3<f64>)],
        centres: &[Point3<f64>],
    ) {
        let (mut min, mut max) = (
            Point3::from([f64::INFINITY; 3]),
            Point3::from([f64::NEG_INFINITY; 3]),
        );
        let (mut cmin, mut cmax) = (min, max);
        for &i in &self.order[lo..hi] {
            let (a, b) = boxes[i as usize];
            min = min.inf(&a);
            max = max.sup(&b);
            let c = centres[i as usize];
            cmin = cmin.inf(&c);
            cmax = cmax.sup(&c);
        }
        self.nodes[node].min = min;
        self.nodes[node].max = max;
        if hi - lo <= LEAF {
            self.nodes[node].first = lo as u32;
            self.nodes[node].count = (hi - lo) as u32;
            return;
        }
        let ext = cmax - cmin;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = (lo + hi) / 2;
        self.order[lo..hi].select_nth_unstable_by(mid - lo, |&i, &j| {
            centres[i as usize][axis]
                .total_cmp(&centres[j as usize][axis])
                .then(i.cmp(&j))
        });
        let first = self.nodes.len();
        for _ in 0..2 {
            self.nodes.push(Node {
                min,
                max,
                first: 0,
                count: 0,
            });
        }
        self.nodes[node].first = first as u32;
        self.nodes[node].count = 0;
        self.build(first, lo, mid, boxes, centres);
        self.build(first + 1, mid, hi, boxes, centres);
    }

    /// The item nearest `p` by `distance2(item) → (squared distance, point)`, searching only
    /// within squared distance `bound` (infinity for no bound).
    fn nearest(
        &self,
        p: &Point3<f64>,
        bound: f64,
        distance2: impl Fn(u32) -> (f64, Point3<f64>),
    ) -> Option<(u32, Point3<f64>, f64)> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut best: Option<(u32, Point3<f64>, f64)> = None;
        let mut limit = bound;
        // depth-first, at most one pending sibling per level of a tree of depth ≤ 32
        let mut stack = [(0.0, 0u32); 64];
        stack[0] = (box_distance2(&self.nodes[0], p), 0);
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (d, node) = stack[top];
            if d >= limit {
                continue;
            }
            let n = &self.nodes[node as usize];
            if n.count > 0 {
                for &i in &self.order[n.first as usize..(n.first + n.count) as usize] {
                    let (d2, q) = distance2(i);
                    if d2 < limit || (d2 == limit && best.is_none_or(|b| i < b.0)) {
                        limit = d2;
                        best = Some((i, q, d2));
                    }
                }
            } else {
                let (a, b) = (n.first, n.first + 1);
                let (da, db) = (
                    box_distance2(&self.nodes[a as usize], p),
                    box_distance2(&self.nodes[b as usize], p),
                );
                // the nearer child is searched first: pushed last
                let pair = if da <= db {
                    [(db, b), (da, a)]
                } else {
                    [(da, a), (db, b)]
                };
                stack[top..top + 2].copy_from_slice(&pair);
                top += 2;
            }
        }
        best
    }
}

fn box_distance2(n: &Node, p: &Point3<f64>) -> f64 {
    let mut d = 0.0;
    for k in 0..3 {
        let v = if p[k] < n.min[k] {
            n.min[k] - p[k]
        } else if p[k] > n.max[k] {
            p[k] - n.max[k]
        } else {
            0.0
        };
        d += v * v;
    }
    d
}

/// The nearest point of a mesh's faces (and of its boundary edges) to any point.
#[derive(Debug, Clone)]
pub struct ClosestPoint {
    triangles: Vec<[Point3<f64>; 3]>,
    faces: Tree,
    segments: Vec<[Point3<f64>; 2]>,
    boundary: Tree,
}

/// Where a query landed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// The nearest point.
    pub point: Point3<f64>,
    /// The face it lies on (or the boundary segment, for [`ClosestPoint::on_boundary`]).
    pub item: u32,
    /// Its distance from the query.
    pub distance: f64,
}

impl From<(u32, Point3<f64>, f64)> for Hit {
    /// An item, its nearest point and their squared distance.
    fn from((item, point, d2): (u32, Point3<f64>, f64)) -> Hit {
        Hit {
            point,
            item,
            distance: d2.sqrt(),
        }
    }
}

impl ClosestPoint {
    /// The search structures of `mesh`'s faces and boundary edges.
    pub fn new(mesh: &Mesh) -> ClosestPoint {
        let triangles: Vec<[Point3<f64>; 3]> =
            (0..mesh.faces.len()).map(|f| mesh.triangle(f)).collect();
        let faces = Tree::new(triangles.len(), |i| {
            let [a, b, c] = triangles[i];
            (a.inf(&b).inf(&c), a.sup(&b).sup(&c))
        });
        // boundary edges: directed edges whose reverse no face has
        let directed = Directed::new(mesh);
        let segments: Vec<[Point3<f64>; 2]> = mesh
            .faces
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .filter(|&(a, b)| directed.find(b, a).is_none())
            .map(|(a, b)| [mesh.positions[a as usize], mesh.positions[b as usize]])
            .collect();
        let boundary = Tree::new(segments.len(), |i| {
            let [a, b] = segments[i];
            (a.inf(&b), a.sup(&b))
        });
        ClosestPoint {
            triangles,
            faces,
            segments,
            boundary,
        }
    }

    /// The nearest point of the faces to `p` (none for a mesh without faces).
    pub fn nearest(&self, p: &Point3<f64>) -> Option<Hit> {
        self.nearest_among(p, f64::INFINITY, |_| true)
    }

    /// The nearest point to `p` of the faces `keep` accepts, if one lies within `within`.
    pub fn nearest_among(
        &self,
        p: &Point3<f64>,
        within: f64,
        keep: impl Fn(u32) -> bool,
    ) -> Option<Hit> {
        self.faces
            .nearest(p, within * within, |i| {
                if keep(i) {
                    let q = closest_on_triangle(p, &self.triangles[i as usize]);
                    ((q - p).norm_squared(), q)
                } else {
                    (f64::INFINITY, *p)
                }
            })
            .filter(|(_, _, d2)| d2.is_finite())
            .map(Hit::from)
    }

    /// The nearest point of the boundary edges to `p` (none for a closed mesh).
    pub fn on_boundary(&self, p: &Point3<f64>) -> Option<Hit> {
        self.boundary
            .nearest(p, f64::INFINITY, |i| {
                let q = closest_on_segment(p, &self.segments[i as usize]);
                ((q - p).norm_squared(), q)
            })
            .map(Hit::from)
    }

    /// Whether the mesh has boundary edges.
    pub fn has_boundary(&self) -> bool {
        !self.segments.is_empty()
    }
}

/// The point of segment `s` nearest `p`.
pub fn closest_on_segment(p: &Point3<f64>, s: &[Point3<f64>; 2]) -> Point3<f64> {
    let d = s[1] - s[0];
    let l2 = d.norm_squared();
    if l2 == 0.0 {
        return s[0];
    }
    let t = ((p - s[0]).dot(&d) / l2).clamp(0.0, 1.0);
    s[0] + d * t
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The tree's answer is the exact nearest point: the same distance as a scan of every
    /// face, for points near and far.
    #[test]
    fn nearest_matches_a_linear_scan() {
        let mesh = synth::textured_protrusion_sphere(3);
        let cp = ClosestPoint::new(&mesh);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for i in 0..300 {
            let scale = if i % 2 == 0 { 1.1 } else { 3.0 };
            let p = Point3::new(
                rng.random_range(-scale..scale),
                rng.random_range(-scale..scale),
                rng.random_range(-scale..scale),
            );
            let hit = cp.nearest(&p).expect("faces");
            let scan = (0..mesh.faces.len())
                .map(|f| (closest_on_triangle(&p, &mesh.triangle(f)) - p).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(
                (hit.distance - scan).abs() < 1e-12,
                "{} vs {scan}",
                hit.distance
            );
            assert!(((hit.point - p).norm() - hit.distance).abs() < 1e-12);
        }
        assert!(!cp.has_boundary());
        assert!(cp.on_boundary(&Point3::origin()).is_none());
        // restricted to some faces and a radius: the scan of those faces within it
        let p = Point3::new(0.3, 0.2, 1.05);
        let even = |f: u32| f.is_multiple_of(2);
        let hit = cp.nearest_among(&p, 1.0, even).expect("within 1");
        let scan = (0..mesh.faces.len())
            .filter(|&f| even(f as u32))
            .map(|f| (closest_on_triangle(&p, &mesh.triangle(f)) - p).norm())
            .fold(f64::INFINITY, f64::min);
        assert!((hit.distance - scan).abs() < 1e-12 && hit.item.is_multiple_of(2));
        assert!(cp.nearest_among(&p, scan * 0.99, even).is_none());
    }

    /// A grid's boundary is its four sides: a point is brought onto the nearest side.
    #[test]
    fn boundary_points() {
        let mesh = synth::grid(4, 4, 0.25); // the unit square centred on the origin
        let cp = ClosestPoint::new(&mesh);
        assert!(cp.has_boundary());
        let hit = cp
            .on_boundary(&Point3::new(0.3, -0.4, 0.5))
            .expect("boundary");
        assert!((hit.point - Point3::new(0.3, -0.5, 0.0)).norm() < 1e-12);
        let hit = cp
            .on_boundary(&Point3::new(1.7, 2.0, 0.0))
            .expect("boundary");
        assert!((hit.point - Point3::new(0.5, 0.5, 0.0)).norm() < 1e-12);
        let empty = ClosestPoint::new(&Mesh {
            positions: Vec::new(),
            faces: Vec::new(),
        });
        assert!(empty.nearest(&Point3::origin()).is_none());
    }
}
