//! The edge-path oracle: shortest paths along a triangle mesh's edges, each edge weighted by
//! its Euclidean length (Dijkstra, "A note on two problems in connexion with graphs",
//! Numerische Mathematik 1, 1959).
//!
//! On a surface this is an upper bound on the geodesic distance, exact along edges and a few
//! per cent long on regular triangulations: fast marching must never exceed it and should beat
//! it, and the mesh-graph code of the library can be compared against it.
//!
//! 1. The edges of every triangle, both ways, make the adjacency lists (repeats and a
//!    degenerate triangle's self-loops are harmless).
//! 2. Every source starts at 0; a binary heap pops the nearest unsettled vertex and relaxes
//!    its neighbours, d(w) = min(d(w), d(v) + |p(w) − p(v)|).
//!
//! O((|V| + |E|) log |V|) time, O(|V| + |E|) memory.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Shortest edge-path length from every vertex to the nearest of `sources`, on the mesh of
/// `positions` and `triangles`: 0 at a source, `f64::INFINITY` where no path reaches (another
/// piece, an unreferenced vertex).
///
/// Plain data in, so that no keycomp type is needed: a position is anything that converts to
/// `[f64; 3]` (an array, a `nalgebra::Point3<f64>`), a vertex id anything that converts to
/// `usize` (`u32`, `usize`).
///
/// ```
/// use keycomp_test_support::edge_path_distances;
///
/// // a unit square cut along its diagonal 0-2
/// let square = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
/// let d = edge_path_distances(&square, &[[0u32, 1, 2], [0, 2, 3]], &[0]);
/// assert_eq!(d, [0.0, 1.0, 2f64.sqrt(), 1.0]);
/// ```
///
/// # Panics
/// When a triangle or a source names a vertex outside `positions` (a bug in the test).
pub fn edge_path_distances<P, I>(positions: &[P], triangles: &[[I; 3]], sources: &[I]) -> Vec<f64>
where
    P: Copy + Into<[f64; 3]>,
    I: Copy + TryInto<usize>,
{
    let points: Vec<[f64; 3]> = positions.iter().map(|&p| p.into()).collect();
    let n = points.len();
    let id = |v: I| -> usize {
        let v = v.try_into().ok().filter(|&v| v < n);
        v.unwrap_or_else(|| panic!("a vertex id outside the {n} positions"))
    };
    let mut neighbours: Vec<Vec<usize>> = vec![Vec::new(); n];
    for t in triangles {
        let t = t.map(id);
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if a != b {
                neighbours[a].push(b);
                neighbours[b].push(a);
            }
        }
    }
    let mut dist = vec![f64::INFINITY; n];
    let mut heap = BinaryHeap::new();
    for &s in sources {
        let s = id(s);
        dist[s] = 0.0;
        heap.push(Reverse((0u64, s)));
    }
    // the heap is keyed by the distance's bits: non-negative f64 bit patterns order like the
    // values
    while let Some(Reverse((bits, v))) = heap.pop() {
        let d = f64::from_bits(bits);
        if d > dist[v] {
            continue;
        }
        for &w in &neighbours[v] {
            let nd = d + length(points[v], points[w]);
            if nd < dist[w] {
                dist[w] = nd;
                heap.push(Reverse((nd.to_bits(), w)));
            }
        }
    }
    dist
}

fn length(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (x, y, z) = (b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    (x * x + y * y + z * z).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `cols` × `rows` grid of unit squares in the plane z = 0, each cut along the diagonal
    /// from (c, r) to (c + 1, r + 1), with heights `z(c, r)`; vertex id r·(cols + 1) + c.
    fn grid(cols: usize, rows: usize, z: impl Fn(usize, usize) -> f64) -> Mesh {
        let mut positions = Vec::new();
        for r in 0..=rows {
            for c in 0..=cols {
                positions.push([c as f64, r as f64, z(c, r)]);
            }
        }
        let id = |c: usize, r: usize| r * (cols + 1) + c;
        let mut triangles = Vec::new();
        for r in 0..rows {
            for c in 0..cols {
                triangles.push([id(c, r), id(c + 1, r), id(c + 1, r + 1)]);
                triangles.push([id(c, r), id(c + 1, r + 1), id(c, r + 1)]);
            }
        }
        (positions, triangles)
    }

    type Mesh = (Vec<[f64; 3]>, Vec<[usize; 3]>);

    /// All-pairs shortest edge paths by Floyd–Warshall, O(|V|³): the oracle's oracle.
    fn floyd_warshall((positions, triangles): &Mesh) -> Vec<Vec<f64>> {
        let n = positions.len();
        let mut d = vec![vec![f64::INFINITY; n]; n];
        for (i, row) in d.iter_mut().enumerate() {
            row[i] = 0.0;
        }
        for t in triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let l = length(positions[a], positions[b]);
                d[a][b] = d[a][b].min(l);
                d[b][a] = d[b][a].min(l);
            }
        }
        for k in 0..n {
            for i in 0..n {
                for j in 0..n {
                    d[i][j] = d[i][j].min(d[i][k] + d[k][j]);
                }
            }
        }
        d
    }

    #[test]
    fn on_a_flat_grid_axis_paths_have_their_length_and_diagonals_are_shortcuts() {
        let mesh = grid(4, 3, |_, _| 0.0);
        let d = edge_path_distances(&mesh.0, &mesh.1, &[0usize]);
        assert_eq!(d[0], 0.0);
        assert!((d[4] - 4.0).abs() < 1e-12); // (4, 0) along the bottom row
        assert!((d[3 * 5] - 3.0).abs() < 1e-12); // (0, 3) up the first column
        // (3, 3): three diagonals
        assert!((d[3 * 5 + 3] - 3.0 * 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn matches_floyd_warshall_on_a_bumpy_grid() {
        let mesh = grid(6, 5, |c, r| (0.9 * c as f64).sin() * (1.3 * r as f64).cos());
        let all = floyd_warshall(&mesh);
        for s in [0usize, 9, 41] {
            let d = edge_path_distances(&mesh.0, &mesh.1, &[s]);
            for (a, b) in d.iter().zip(&all[s]) {
                assert!(
                    (a - b).abs() <= 1e-12 * b.max(1.0),
                    "source {s}: {a} vs {b}"
                );
            }
        }
    }

    #[test]
    fn several_sources_give_the_distance_to_the_nearest() {
        let mesh = grid(5, 4, |c, r| 0.3 * ((c * r) % 3) as f64);
        let sources = [2usize, 17, 29];
        let each: Vec<Vec<f64>> = sources
            .iter()
            .map(|&s| edge_path_distances(&mesh.0, &mesh.1, &[s]))
            .collect();
        let nearest = edge_path_distances(&mesh.0, &mesh.1, &sources);
        for (v, &d) in nearest.iter().enumerate() {
            let min = each.iter().map(|e| e[v]).fold(f64::INFINITY, f64::min);
            assert_eq!(d, min, "vertex {v}");
        }
    }

    #[test]
    fn unreached_vertices_are_infinitely_far_and_u32_ids_work() {
        // two separate triangles and an unreferenced vertex
        let positions = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [5.0, 0.0, 0.0],
            [6.0, 0.0, 0.0],
            [5.0, 1.0, 0.0],
            [9.0, 9.0, 9.0],
        ];
        let triangles: [[u32; 3]; 2] = [[0, 1, 2], [3, 4, 5]];
        let d = edge_path_distances(&positions, &triangles, &[1u32]);
        assert_eq!(&d[..3], &[1.0, 0.0, 2f64.sqrt()]);
        assert!(d[3..].iter().all(|x| x.is_infinite()));
    }

    #[test]
    #[should_panic(expected = "outside")]
    fn a_triangle_outside_the_positions_is_a_bug() {
        let positions = [[0.0; 3]; 2];
        edge_path_distances(&positions, &[[0usize, 1, 2]], &[0]);
    }
}
