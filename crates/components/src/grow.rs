//! Key-component extraction on the mesh: the geodesic centre of a cluster (the paper's Eq. 2)
//! and region growing inside a scaled enclosing sphere (Algorithm 2), Sipiran & Bustos,
//! Section 3.3.
//!
//! **Geodesic centre** (Eq. 2): `ĉ = s_j` with `j = argmin_{j ∈ cluster} ‖p_j − centroid‖`,
//! where `p_j` is keypoint `j`'s 2-D image and `centroid` the mean of the cluster's images.
//! O(|cluster|).
//!
//! **Region growing** (Algorithm 2), from the centre vertex `ĉ` with the cluster's keypoints
//! `S` and their smallest enclosing sphere `(o, r)` (see [`crate::sphere`]):
//! 1. Put `ĉ` in a FIFO queue; `waiting ← S`.
//! 2. While `waiting ≠ ∅` and the queue is not empty: take `v` from the queue; if `v` is not
//!    marked: mark it, add it to `V_R`, remove it from `waiting`, enqueue every unmarked
//!    neighbour `w` with `‖w − o‖ < σ·r` (strict, Euclidean), and add all faces incident to `v`
//!    to `F_R` (line 20, `F_R ← F_R ∪ v.adjacentFaces()`: a face counts as soon as **one** of
//!    its corners is visited, so the faces reach one ring beyond `V_R`).
//! 3. Unmark the visited vertices; return `V_R` (sorted), `F_R` (sorted, unique) and the
//!    keypoints never reached (`waiting`), which the paper assumes empty for σ = 1.5 but which
//!    can remain on real meshes (a keypoint outside `σ·r`, or reachable only through vertices
//!    outside it, or on another connected piece).
//!
//! Implementation notes. The paper marks a vertex when it is dequeued, so a vertex can sit in
//! the queue several times; here a vertex is flagged when first enqueued and never enqueued
//! again. Both visit the vertices in the same breadth-first order and stop after the same
//! vertex, so `V_R` is identical, but the queue holds each vertex at most once. The queue is a
//! `Vec` with a read cursor: the dequeued prefix is `V_R`. The seed `ĉ` is enqueued whatever its
//! distance to `o` (line 5 has no test). Flags live in a buffer of one byte per vertex owned by
//! [`RegionGrower`], reset after each call by clearing only the touched vertices, so a call
//! costs O(|V_R| + |F_R| log |F_R| + |S|), not O(|V|).
//!
//! Reference: I. Sipiran and B. Bustos, "Key-components: detection of salient regions on 3D
//! meshes", *The Visual Computer* 29(12), 1319–1332, 2013.

use keycomp_mesh::{Mesh, Topology, VertexId};

use crate::error::ComponentsError;
use crate::sphere::Sphere;

/// The geodesic centre of a cluster (Eq. 2): the member of `cluster` (indices into `points2d`)
/// whose 2-D image is closest to the mean of the cluster's images; ties go to the lowest index.
///
/// Errors: `cluster` is empty, or an index is out of range of `points2d`.
pub fn geodesic_center(cluster: &[usize], points2d: &[[f64; 2]]) -> Result<usize, ComponentsError> {
    if cluster.is_empty() {
        return Err(ComponentsError::Empty { what: "cluster" });
    }
    if let Some(&index) = cluster.iter().find(|&&i| i >= points2d.len()) {
        return Err(ComponentsError::IndexOutOfRange {
            what: "keypoint",
            index,
            len: points2d.len(),
        });
    }
    let mut c = [0.0, 0.0];
    for &i in cluster {
        c[0] += points2d[i][0];
        c[1] += points2d[i][1];
    }
    let n = cluster.len() as f64;
    let c = [c[0] / n, c[1] / n];
    let mut best = (f64::INFINITY, usize::MAX);
    for &i in cluster {
        let d = (points2d[i][0] - c[0]).powi(2) + (points2d[i][1] - c[1]).powi(2);
        if d < best.0 || (d == best.0 && i < best.1) {
            best = (d, i);
        }
    }
    Ok(best.1)
}

/// A key-component extracted by [`RegionGrower::grow`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Component {
    /// The seed: the cluster's geodesic centre vertex.
    pub center: VertexId,
    /// Visited vertices (`V_R`), increasing.
    pub vertices: Vec<VertexId>,
    /// Faces with at least one visited corner (`F_R`), increasing, unique.
    pub faces: Vec<u32>,
    /// Keypoints of the cluster the growth never reached, increasing (empty when it reached
    /// them all, as the paper expects).
    pub missed_keypoints: Vec<VertexId>,
}

impl Component {
    /// Whether every keypoint of the cluster was reached.
    pub fn reached_all(&self) -> bool {
        self.missed_keypoints.is_empty()
    }
}

const ENQUEUED: u8 = 1;
const WAITING: u8 = 2;

/// Region growing (Algorithm 2) on one mesh, with buffers reused across calls. Build one per
/// mesh (or per thread) and call [`RegionGrower::grow`] once per cluster.
#[derive(Debug, Clone)]
pub struct RegionGrower<'m> {
    mesh: &'m Mesh,
    topology: &'m Topology,
    flags: Vec<u8>,
    queue: Vec<VertexId>,
}

impl<'m> RegionGrower<'m> {
    /// Prepares region growing on `mesh` with its adjacency `topology` (O(|V|) memory, once).
    ///
    /// Errors: `topology` was built for a mesh with another number of vertices.
    pub fn new(mesh: &'m Mesh, topology: &'m Topology) -> Result<Self, ComponentsError> {
        if topology.num_vertices() != mesh.num_vertices() {
            return Err(ComponentsError::IndexOutOfRange {
                what: "topology vertex count",
                index: topology.num_vertices(),
                len: mesh.num_vertices(),
            });
        }
        Ok(RegionGrower {
            mesh,
            topology,
            flags: vec![0; mesh.num_vertices()],
            queue: Vec::new(),
        })
    }

    /// Grows the component of a cluster: breadth-first from `center`, through vertices strictly
    /// inside the sphere of radius `sigma · sphere.radius` around `sphere.center`, until every
    /// vertex of `keypoints` has been visited or no vertex is left (module docs, Algorithm 2).
    ///
    /// `keypoints` are vertex ids (duplicates are fine); `center` need not be one of them,
    /// though in the pipeline it is. Errors: a vertex id out of range, or `sigma` not a
    /// positive finite number.
    pub fn grow(
        &mut self,
        center: VertexId,
        keypoints: &[VertexId],
        sphere: &Sphere,
        sigma: f64,
    ) -> Result<Component, ComponentsError> {
        let nv = self.mesh.num_vertices();
        if !(sigma.is_finite() && sigma > 0.0) {
            return Err(ComponentsError::param(
                "sigma",
                sigma,
                "must be a finite number > 0 (the paper uses 1.5, from (1, 2])",
            ));
        }
        if let Some(&v) = std::iter::once(&center)
            .chain(keypoints)
            .find(|&&v| v as usize >= nv)
        {
            return Err(ComponentsError::IndexOutOfRange {
                what: "vertex",
                index: v as usize,
                len: nv,
            });
        }
        let limit = sigma * sphere.radius;
        let o = sphere.center;
        let flags = &mut self.flags;
        let queue = &mut self.queue;
        let mut waiting = 0usize;
        for &k in keypoints {
            if flags[k as usize] & WAITING == 0 {
                flags[k as usize] |= WAITING;
                waiting += 1;
            }
        }
        queue.clear();
        queue.push(center);
        flags[center as usize] |= ENQUEUED;
        let mut head = 0;
        while waiting > 0 && head < queue.len() {
            let v = queue[head];
            head += 1;
            if flags[v as usize] & WAITING != 0 {
                flags[v as usize] &= !WAITING;
                waiting -= 1;
            }
            for &w in self.topology.neighbors(v) {
                if flags[w as usize] & ENQUEUED == 0
                    && (self.mesh.positions[w as usize] - o).norm() < limit
                {
                    flags[w as usize] |= ENQUEUED;
                    queue.push(w);
                }
            }
        }
        // reset: every enqueued vertex, and keypoints never dequeued
        let mut missed = Vec::new();
        for &k in keypoints {
            if flags[k as usize] & WAITING != 0 {
                flags[k as usize] &= !WAITING;
                missed.push(k);
            }
        }
        for &v in queue.iter() {
            flags[v as usize] = 0;
        }
        missed.sort_unstable();
        let mut vertices = queue[..head].to_vec();
        let faces = self.topology.faces_touching(&vertices);
        vertices.sort_unstable();
        Ok(Component {
            center,
            vertices,
            faces,
            missed_keypoints: missed,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sphere::min_enclosing_sphere;
    use keycomp_mesh::{Point3, synth};
    use proptest::prelude::*;

    fn sphere_of(mesh: &Mesh, kps: &[VertexId]) -> Sphere {
        let pts: Vec<Point3<f64>> = kps.iter().map(|&k| mesh.positions[k as usize]).collect();
        min_enclosing_sphere(&pts).unwrap()
    }

    /// Number of connected pieces of the subgraph induced by `vs` (sorted).
    fn pieces(topo: &Topology, vs: &[VertexId]) -> usize {
        let inside = |v: VertexId| vs.binary_search(&v).is_ok();
        let mut seen = std::collections::HashSet::new();
        let mut count = 0;
        for &s in vs {
            if !seen.insert(s) {
                continue;
            }
            count += 1;
            let mut stack = vec![s];
            while let Some(v) = stack.pop() {
                for &w in topo.neighbors(v) {
                    if inside(w) && seen.insert(w) {
                        stack.push(w);
                    }
                }
            }
        }
        count
    }

    /// Vertices of `mesh` closest to the given directions from the origin.
    fn nearest_to(mesh: &Mesh, dirs: &[[f64; 3]]) -> Vec<VertexId> {
        dirs.iter()
            .map(|d| {
                let d = nalgebra::Vector3::new(d[0], d[1], d[2]).normalize();
                (0..mesh.num_vertices())
                    .max_by(|&a, &b| {
                        let ca = mesh.positions[a].coords.normalize().dot(&d);
                        let cb = mesh.positions[b].coords.normalize().dot(&d);
                        ca.total_cmp(&cb)
                    })
                    .unwrap() as VertexId
            })
            .collect()
    }

    fn check_component(mesh: &Mesh, topo: &Topology, c: &Component, kps: &[VertexId], s: &Sphere) {
        assert!(c.reached_all(), "missed {:?}", c.missed_keypoints);
        for k in kps {
            assert!(
                c.vertices.binary_search(k).is_ok(),
                "keypoint {k} not in component"
            );
        }
        assert_eq!(pieces(topo, &c.vertices), 1);
        for &v in &c.vertices {
            if v != c.center {
                assert!((mesh.positions[v as usize] - s.center).norm() < 1.5 * s.radius);
            }
        }
        // faces: exactly those with a visited corner
        let want: Vec<u32> = (0..mesh.num_faces() as u32)
            .filter(|&f| {
                mesh.faces[f as usize]
                    .iter()
                    .any(|v| c.vertices.binary_search(v).is_ok())
            })
            .collect();
        assert_eq!(c.faces, want);
    }

    #[test]
    fn icosphere_cluster_is_one_connected_piece_containing_its_keypoints() {
        let mesh = synth::icosphere(4, 1.0);
        let topo = Topology::new(&mesh);
        let kps = nearest_to(
            &mesh,
            &[
                [1.0, 0.0, 0.0],
                [1.0, 0.3, 0.0],
                [1.0, 0.0, 0.25],
                [1.0, -0.2, -0.2],
                [1.0, 0.1, 0.1],
            ],
        );
        let s = sphere_of(&mesh, &kps);
        let mut g = RegionGrower::new(&mesh, &topo).unwrap();
        let c = g.grow(kps[4], &kps, &s, 1.5).unwrap();
        check_component(&mesh, &topo, &c, &kps, &s);
        // buffers come back clean: a second call gives the same answer
        let again = g.grow(kps[4], &kps, &s, 1.5).unwrap();
        assert_eq!(c, again);
        assert!(g.flags.iter().all(|&f| f == 0));
    }

    #[test]
    fn grid_cluster() {
        let mesh = synth::grid(30, 30, 0.1);
        let topo = Topology::new(&mesh);
        let id = |i: u32, j: u32| j * 31 + i;
        let kps = vec![id(5, 5), id(9, 6), id(7, 10), id(4, 8), id(7, 7)];
        let s = sphere_of(&mesh, &kps);
        let mut g = RegionGrower::new(&mesh, &topo).unwrap();
        let c = g.grow(id(7, 7), &kps, &s, 1.5).unwrap();
        check_component(&mesh, &topo, &c, &kps, &s);
        // growth stops as soon as the last keypoint is reached: strictly fewer vertices than
        // the whole sphere of radius 1.5 r holds
        let in_ball = mesh
            .positions
            .iter()
            .filter(|p| (*p - s.center).norm() < 1.5 * s.radius)
            .count();
        assert!(c.vertices.len() < in_ball);
    }

    #[test]
    fn keypoint_on_another_piece_is_missed() {
        // two grids side by side without shared vertices: the queue empties on the first
        let mut mesh = synth::grid(10, 10, 0.1);
        let other = synth::grid(10, 10, 0.1);
        let off = mesh.num_vertices() as u32;
        mesh.positions.extend(
            other
                .positions
                .iter()
                .map(|p| p + nalgebra::Vector3::new(1.05, 0.0, 0.0)),
        );
        mesh.faces
            .extend(other.faces.iter().map(|f| f.map(|v| v + off)));
        let topo = Topology::new(&mesh);
        let a = 5 * 11 + 9; // near the right edge of the first grid
        let b = off + 5 * 11 + 1; // near the left edge of the second
        let kps = vec![a, b];
        let s = sphere_of(&mesh, &kps);
        let mut g = RegionGrower::new(&mesh, &topo).unwrap();
        let c = g.grow(a, &kps, &s, 1.5).unwrap();
        assert_eq!(c.missed_keypoints, vec![b]);
        assert!(!c.reached_all());
        assert!(c.vertices.iter().all(|&v| v < off));
        assert!(g.flags.iter().all(|&f| f == 0));
    }

    #[test]
    fn keypoint_outside_a_shrunk_sphere_is_missed() {
        // σ < 1: the farthest keypoints lie outside σ·r and can never be enqueued
        let mesh = synth::grid(20, 20, 0.1);
        let topo = Topology::new(&mesh);
        let id = |i: u32, j: u32| j * 21 + i;
        let kps = vec![id(4, 10), id(16, 10), id(10, 10)];
        let s = sphere_of(&mesh, &kps);
        let mut g = RegionGrower::new(&mesh, &topo).unwrap();
        let c = g.grow(id(10, 10), &kps, &s, 0.8).unwrap();
        assert_eq!(c.missed_keypoints, vec![id(4, 10), id(16, 10)]);
        assert!(c.vertices.contains(&id(10, 10)));
    }

    #[test]
    fn geodesic_center_picks_the_member_nearest_the_centroid() {
        let pts = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.4, 0.3], [9.0, 9.0]];
        assert_eq!(geodesic_center(&[0, 1, 2, 3], &pts).unwrap(), 3);
        // ties → lowest index (two members symmetric about the centroid)
        assert_eq!(geodesic_center(&[1, 2], &pts).unwrap(), 1);
        assert_eq!(geodesic_center(&[2, 1], &pts).unwrap(), 1);
        assert!(geodesic_center(&[], &pts).is_err());
        assert!(geodesic_center(&[7], &pts).is_err());
    }

    #[test]
    fn errors() {
        let mesh = synth::grid(2, 2, 1.0);
        let topo = Topology::new(&mesh);
        let mut g = RegionGrower::new(&mesh, &topo).unwrap();
        let s = Sphere {
            center: Point3::origin(),
            radius: 1.0,
        };
        assert!(g.grow(100, &[0], &s, 1.5).is_err());
        assert!(g.grow(0, &[100], &s, 1.5).is_err());
        assert!(g.grow(0, &[1], &s, 0.0).is_err());
        assert!(g.grow(0, &[1], &s, f64::NAN).is_err());
        let other = synth::grid(3, 3, 1.0);
        assert!(RegionGrower::new(&other, &topo).is_err());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]
        /// On a sphere, clusters of nearby vertices (a cap) give one connected component that
        /// contains all keypoints.
        #[test]
        fn components_contain_their_keypoints(
            theta in 0.0f64..std::f64::consts::PI,
            phi in 0.0f64..std::f64::consts::TAU,
            offsets in prop::collection::vec((-0.3f64..0.3, -0.3f64..0.3, -0.3f64..0.3), 2..12),
        ) {
            let mesh = synth::icosphere(3, 1.0);
            let topo = Topology::new(&mesh);
            // a unit base direction plus offsets of length < 0.52: never the zero vector
            let base = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
            let dirs: Vec<[f64; 3]> = offsets
                .iter()
                .map(|o| [base[0] + o.0, base[1] + o.1, base[2] + o.2])
                .collect();
            let mut kps = nearest_to(&mesh, &dirs);
            kps.sort_unstable();
            kps.dedup();
            let s = sphere_of(&mesh, &kps);
            let mut g = RegionGrower::new(&mesh, &topo).unwrap();
            let c = g.grow(kps[0], &kps, &s, 1.5).unwrap();
            prop_assert!(c.reached_all());
            prop_assert!(kps.iter().all(|k| c.vertices.binary_search(k).is_ok()));
            prop_assert_eq!(pieces(&topo, &c.vertices), 1);
        }
    }
}
