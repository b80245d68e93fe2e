//! Shared mesh-graph helpers: multi-source Dijkstra over Euclidean edge lengths
//! (`keycomp_mesh::graph::dijkstra`, re-exported) and a uniform hash grid for Euclidean range
//! queries.
//!
//! A grid query with cell size h and radius r visits ⌈2r/h + 1⌉³ cells.

use std::collections::HashMap;

pub(crate) use keycomp_mesh::graph::dijkstra;
use keycomp_mesh::{Point3, VertexId};

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
