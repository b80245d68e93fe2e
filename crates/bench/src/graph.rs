//! Shared mesh-graph helpers: multi-source Dijkstra over Euclidean edge lengths (a graph
//! approximation of geodesic distance, exact along edges and at most ~15 % long on regular
//! triangulations) and a uniform hash grid for Euclidean range queries.
//!
//! Dijkstra is O((|V| + |E|) log |V|); a grid query with cell size h and radius r visits
//! ⌈2r/h + 1⌉³ cells.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

use keycomp_mesh::{Point3, Topology, VertexId};

/// A heap entry ordered so that `BinaryHeap` pops the smallest (distance, label, vertex).
#[derive(Clone, Copy)]
struct Entry {
    dist: f64,
    label: u32,
    vertex: VertexId,
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .dist
            .total_cmp(&self.dist)
            .then(other.label.cmp(&self.label))
            .then(other.vertex.cmp(&self.vertex))
    }
}

/// Multi-source Dijkstra over mesh edges weighted by Euclidean length. `sources` are
/// `(vertex, label)` pairs at distance 0. Every settled vertex is reported once, in increasing
/// (distance, label, vertex) order, as `visit(vertex, distance, label)`; the label is the one of
/// the nearest source, ties going to the smaller label. The search stops when `visit` returns
/// `false` or the next distance exceeds `radius`. A source keeps its own label even when another
/// source coincides with it (zero-length edge).
pub(crate) fn dijkstra(
    positions: &[Point3<f64>],
    topo: &Topology,
    sources: &[(VertexId, u32)],
    radius: f64,
    mut visit: impl FnMut(VertexId, f64, u32) -> bool,
) {
    let n = positions.len();
    let mut dist = vec![f64::INFINITY; n];
    let mut label = vec![u32::MAX; n];
    let mut done = vec![false; n];
    let mut source = vec![false; n];
    let mut heap = BinaryHeap::new();
    for &(v, l) in sources {
        let vi = v as usize;
        if vi < n && (0.0, l) < (dist[vi], label[vi]) {
            source[vi] = true;
            dist[vi] = 0.0;
            label[vi] = l;
            heap.push(Entry {
                dist: 0.0,
                label: l,
                vertex: v,
            });
        }
    }
    while let Some(e) = heap.pop() {
        let vi = e.vertex as usize;
        if done[vi] || e.dist != dist[vi] || e.label != label[vi] {
            continue;
        }
        if e.dist > radius {
            break;
        }
        done[vi] = true;
        if !visit(e.vertex, e.dist, e.label) {
            break;
        }
        let p = positions[vi];
        for &w in topo.neighbors(e.vertex) {
            let wi = w as usize;
            if done[wi] || source[wi] {
                continue;
            }
            let nd = e.dist + (positions[wi] - p).norm();
            if nd < dist[wi] || (nd == dist[wi] && e.label < label[wi]) {
                dist[wi] = nd;
                label[wi] = e.label;
                heap.push(Entry {
                    dist: nd,
                    label: e.label,
                    vertex: w,
                });
            }
        }
    }
}

/// A uniform hash grid over a set of points for "all points within r" queries.
pub(crate) struct Grid {
    cell: f64,
    cells: HashMap<(i64, i64, i64), Vec<VertexId>>,
}

impl Grid {
    /// Bins the points `ids` (indices into `positions`) into cubes of side `cell` (> 0).
    pub(crate) fn new(positions: &[Point3<f64>], ids: &[VertexId], cell: f64) -> Grid {
        let mut cells: HashMap<(i64, i64, i64), Vec<VertexId>> = HashMap::new();
        for &v in ids {
            cells
                .entry(key(&positions[v as usize], cell))
                .or_default()
                .push(v);
        }
        Grid { cell, cells }
    }

    /// Calls `f(v)` for every binned point within distance `r` of `p` (in no particular order).
    pub(crate) fn within(
        &self,
        positions: &[Point3<f64>],
        p: &Point3<f64>,
        r: f64,
        mut f: impl FnMut(VertexId),
    ) {
        let lo = key(&(p - nalgebra::Vector3::repeat(r)), self.cell);
        let hi = key(&(p + nalgebra::Vector3::repeat(r)), self.cell);
        let r2 = r * r;
        for x in lo.0..=hi.0 {
            for y in lo.1..=hi.1 {
                for z in lo.2..=hi.2 {
                    if let Some(list) = self.cells.get(&(x, y, z)) {
                        for &v in list {
                            if (positions[v as usize] - p).norm_squared() <= r2 {
                                f(v);
                            }
                        }
                    }
                }
            }
        }
    }
}

fn key(p: &Point3<f64>, cell: f64) -> (i64, i64, i64) {
    (
        (p.x / cell).floor() as i64,
        (p.y / cell).floor() as i64,
        (p.z / cell).floor() as i64,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;

    #[test]
    fn dijkstra_on_a_grid_matches_manhattan_along_axes_and_labels_nearest_source() {
        let m = synth::grid(10, 1, 1.0); // 11 × 2 vertices, row 0 ids 0..=10
        let t = Topology::new(&m);
        let mut got = vec![(f64::NAN, u32::MAX); m.num_vertices()];
        dijkstra(
            &m.positions,
            &t,
            &[(0, 7), (10, 3)],
            f64::INFINITY,
            |v, d, l| {
                got[v as usize] = (d, l);
                true
            },
        );
        assert_eq!(got[0], (0.0, 7));
        assert_eq!(got[10], (0.0, 3));
        assert!((got[3].0 - 3.0).abs() < 1e-12 && got[3].1 == 7);
        assert!((got[8].0 - 2.0).abs() < 1e-12 && got[8].1 == 3);
        // vertex 5 is equidistant: the smaller label wins
        assert_eq!(got[5].1, 3);
    }

    #[test]
    fn distances_match_the_edge_path_oracle() {
        // a bumpy sphere, so that edges differ in length and paths in shape
        let mut m = synth::icosphere(3, 1.0);
        for (i, p) in m.positions.iter_mut().enumerate() {
            *p *= 1.0 + 0.2 * (1.7 * i as f64).sin();
        }
        let t = Topology::new(&m);
        let sources = [(5, 0), (300, 1), (611, 2)];
        let mut got = vec![f64::NAN; m.num_vertices()];
        dijkstra(&m.positions, &t, &sources, f64::INFINITY, |v, d, _| {
            got[v as usize] = d;
            true
        });
        let ids: Vec<u32> = sources.iter().map(|s| s.0).collect();
        let oracle = keycomp_test_support::edge_path_distances(&m.positions, &m.faces, &ids);
        for (v, (a, b)) in got.iter().zip(&oracle).enumerate() {
            assert!(
                (a - b).abs() <= 1e-12 * b.max(1.0),
                "vertex {v}: {a} vs {b}"
            );
        }
    }

    #[test]
    fn coincident_sources_keep_their_labels() {
        let mut m = synth::grid(2, 1, 1.0);
        m.positions[1] = m.positions[0];
        let t = Topology::new(&m);
        let mut got = vec![u32::MAX; m.num_vertices()];
        dijkstra(
            &m.positions,
            &t,
            &[(0, 9), (1, 4)],
            f64::INFINITY,
            |v, _, l| {
                got[v as usize] = l;
                true
            },
        );
        assert_eq!((got[0], got[1]), (9, 4));
    }

    #[test]
    fn grid_query_matches_a_linear_scan() {
        let m = synth::icosphere(3, 1.0);
        let ids: Vec<u32> = (0..m.num_vertices() as u32).collect();
        let g = Grid::new(&m.positions, &ids, 0.13);
        for (q, r) in [(0usize, 0.3), (17, 0.05), (200, 1.1)] {
            let p = m.positions[q];
            let mut a = Vec::new();
            g.within(&m.positions, &p, r, |v| a.push(v));
            a.sort_unstable();
            let b: Vec<u32> = ids
                .iter()
                .copied()
                .filter(|&v| (m.positions[v as usize] - p).norm() <= r)
                .collect();
            assert_eq!(a, b);
        }
    }
}
