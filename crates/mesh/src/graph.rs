//! Multi-source Dijkstra over a mesh's edges weighted by their Euclidean length: a graph
//! approximation of geodesic distance (exact along edges, at most ~15 % long on regular
//! triangulations), with the label of each vertex's nearest source. Used where a vertex must be
//! given to its nearest seed along the surface (the benchmark's ground-truth carry, holes and
//! local scaling; the describe crate's proxy, which gives each input vertex to a survivor).
//!
//! O((|V| + |E|) log |V|).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::{Point3, Topology, VertexId};

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
pub fn dijkstra(
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth;

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
}
