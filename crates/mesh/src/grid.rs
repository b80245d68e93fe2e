//! Triangulates a range image: a grid of scanner samples, some absent, into a triangle mesh.
//!
//! A range scanner measures one point per cell of a `rows x cols` grid (a pixel of its sensor,
//! or a step of its sweep); cells where the beam hit nothing, or was rejected, are absent.
//! Neighbouring cells are neighbouring points on the surface, unless the surface jumps in depth
//! between them (an occluding edge seen from the scanner). Connecting neighbours gives the scan's
//! mesh directly, with no surface reconstruction, and keeps each sample as a vertex.
//!
//! Steps ([`triangulate_grid`]), for a grid of `n = rows x cols` cells:
//! 1. The neighbour spacing: the median length of the grid's horizontal `(r, c)-(r, c+1)` and
//!    vertical `(r, c)-(r+1, c)` edges, over the pairs of present cells.
//! 2. Each 2x2 block of cells `a = (r, c)`, `b = (r, c+1)`, `d = (r+1, c)`, `e = (r+1, c+1)`
//!    gives two triangles when all four cells are present, split along the shorter diagonal
//!    (`b-d`: `(a, b, d)` and `(b, e, d)`; `a-e`: `(a, b, e)` and `(a, e, d)`), one triangle
//!    when exactly three are (the three present corners), none otherwise.
//! 3. A triangle whose longest edge is longer than [`DEPTH_JUMP`] times the neighbour spacing
//!    crosses a depth jump and is dropped: it would join a foreground and a background surface.
//!
//! Winding: every triangle is counter-clockwise when the grid is drawn with columns running to
//! the right and rows running upward, `(r, c) -> (r, c+1) -> (r+1, c)`, so all triangles of a
//! grid are oriented alike. Stanford's range grids (`element range_grid` in PLY) are laid out
//! this way as seen from the scanner (row 0 at the bottom), so their triangles face the scanner;
//! for the Stanford bunny's scans this is the reconstruction's outward side. Images stored with
//! row 0 at the top (PCL's organised clouds) get the opposite winding; their reader flips it.
//!
//! Complexity: O(n) time (the median by selection), O(n) memory.
//!
//! This is the range-image triangulation of G. Turk and M. Levoy, "Zippered polygon meshes from
//! range images", Proceedings of SIGGRAPH 94 (Computer Graphics Proceedings, Annual Conference
//! Series), ACM, 1994, pp. 311-318: each grid square becomes two triangles (one when a corner is
//! missing), split along the shorter diagonal, and triangles with an edge longer than a multiple
//! of the sample spacing are discarded as crossing a depth discontinuity. The Stanford 3D
//! Scanning Repository distributes its raw scans as such grids.

use crate::{Point3, VertexId};

/// A triangle is dropped as crossing a depth jump when its longest edge is longer than this many
/// times the median spacing of the grid's neighbouring samples. Raising it keeps more of the
/// steep, grazing parts of a scan but starts bridging occluding edges (joining a surface to what
/// lies behind it); lowering it cuts holes in steep slopes. Turk and Levoy discard edges longer
/// than a small multiple of the sample spacing; 4 keeps surfaces seen at up to about 75 degrees
/// from the beam.
pub const DEPTH_JUMP: f64 = 4.0;

/// Triangulates a range grid (see the module documentation for the rule and the winding).
///
/// `cells` holds `rows * cols` entries in row-major order (cell `(r, c)` is `cells[r * cols +
/// c]`), each the vertex measured there or `None` when the cell is absent; vertex ids index
/// `positions`. Nothing here panics: cells past the end of `cells` are absent, extra ones are
/// ignored, and a cell whose id is not in `positions` or whose position is not finite counts as
/// absent. Triangles can still be degenerate (coincident samples); [`crate::Mesh::from_raw`]
/// drops and counts them.
pub fn triangulate_grid(
    positions: &[Point3<f64>],
    rows: usize,
    cols: usize,
    cells: &[Option<VertexId>],
) -> Vec<[VertexId; 3]> {
    let grid = Grid::new(positions, rows, cols, cells);
    let Some(spacing2) = grid.median_neighbour_edge2() else {
        return Vec::new(); // no two neighbouring cells: no triangle either
    };
    let limit2 = DEPTH_JUMP * DEPTH_JUMP * spacing2;
    let mut faces = Vec::new();
    let mut keep = |t: [VertexId; 3]| {
        let [p, q, s] = t.map(|v| positions[v as usize]);
        let longest2 = (q - p)
            .norm_squared()
            .max((s - q).norm_squared())
            .max((p - s).norm_squared());
        if longest2 <= limit2 {
            faces.push(t);
        }
    };
    for r in 0..grid.rows.saturating_sub(1) {
        for c in 0..grid.span.saturating_sub(1) {
            let [a, b, d, e] =
                [(r, c), (r, c + 1), (r + 1, c), (r + 1, c + 1)].map(|(r, c)| grid.vertex(r, c));
            match (a, b, d, e) {
                (Some(a), Some(b), Some(d), Some(e)) => {
                    let pos = |v: VertexId| positions[v as usize];
                    let ae = (pos(e) - pos(a)).norm_squared();
                    let bd = (pos(d) - pos(b)).norm_squared();
                    if ae < bd {
                        keep([a, b, e]);
                        keep([a, e, d]);
                    } else {
                        keep([a, b, d]);
                        keep([b, e, d]);
                    }
                }
                (None, Some(b), Some(d), Some(e)) => keep([b, e, d]),
                (Some(a), None, Some(d), Some(e)) => keep([a, e, d]),
                (Some(a), Some(b), None, Some(e)) => keep([a, b, e]),
                (Some(a), Some(b), Some(d), None) => keep([a, b, d]),
                _ => {}
            }
        }
    }
    faces
}

/// The grid's cells, with out-of-range cells and ids read as absent.
struct Grid<'a> {
    positions: &'a [Point3<f64>],
    /// Rows that hold at least one entry of `cells` (at most `rows`).
    rows: usize,
    cols: usize,
    /// Columns worth visiting: `cols`, or fewer when `cells` does not fill one row.
    span: usize,
    cells: &'a [Option<VertexId>],
}

impl<'a> Grid<'a> {
    /// Clamps the loops to the cells that exist: they visit at most about `2 * cells.len()`
    /// cells, whatever `rows` and `cols` claim.
    fn new(
        positions: &'a [Point3<f64>],
        rows: usize,
        cols: usize,
        cells: &'a [Option<VertexId>],
    ) -> Self {
        let n = cells.len();
        let rows = if cols == 0 {
            0
        } else {
            rows.min(n.div_ceil(cols))
        };
        Grid {
            positions,
            rows,
            cols,
            span: cols.min(n),
            cells,
        }
    }

    /// The vertex at cell `(r, c)`, if present and usable.
    fn vertex(&self, r: usize, c: usize) -> Option<VertexId> {
        if r >= self.rows || c >= self.cols {
            return None;
        }
        let i = r.checked_mul(self.cols)?.checked_add(c)?;
        let v = (*self.cells.get(i)?)?;
        let p = self.positions.get(v as usize)?;
        (p.x.is_finite() && p.y.is_finite() && p.z.is_finite()).then_some(v)
    }

    /// The median squared length of the edges between horizontally or vertically neighbouring
    /// present cells (the upper median for an even count), or `None` when there are none.
    fn median_neighbour_edge2(&self) -> Option<f64> {
        let mut lengths = Vec::new();
        for r in 0..self.rows {
            for c in 0..self.span {
                let Some(a) = self.vertex(r, c) else { continue };
                let pa = self.positions[a as usize];
                for (rr, cc) in [(r, c + 1), (r + 1, c)] {
                    if let Some(b) = self.vertex(rr, cc) {
                        lengths.push((self.positions[b as usize] - pa).norm_squared());
                    }
                }
            }
        }
        if lengths.is_empty() {
            return None;
        }
        let mid = lengths.len() / 2;
        let (_, m, _) = lengths.select_nth_unstable_by(mid, f64::total_cmp);
        Some(*m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vector3;

    /// A `rows x cols` grid of points on the plane z = 0 (x = column, y = row, unit spacing),
    /// every cell present except those in `absent`; vertex ids in row-major order of the
    /// present cells.
    fn plane(rows: usize, cols: usize, absent: &[(usize, usize)]) -> Grid2 {
        let mut positions = Vec::new();
        let mut cells = Vec::new();
        for r in 0..rows {
            for c in 0..cols {
                if absent.contains(&(r, c)) {
                    cells.push(None);
                } else {
                    cells.push(Some(positions.len() as VertexId));
                    positions.push(Point3::new(c as f64, r as f64, 0.0));
                }
            }
        }
        Grid2 {
            positions,
            cells,
            rows,
            cols,
        }
    }

    struct Grid2 {
        positions: Vec<Point3<f64>>,
        cells: Vec<Option<VertexId>>,
        rows: usize,
        cols: usize,
    }

    impl Grid2 {
        fn id(&self, r: usize, c: usize) -> VertexId {
            self.cells[r * self.cols + c].unwrap()
        }
        fn triangulate(&self) -> Vec<[VertexId; 3]> {
            triangulate_grid(&self.positions, self.rows, self.cols, &self.cells)
        }
        fn normal(&self, t: [VertexId; 3]) -> Vector3<f64> {
            let [a, b, c] = t.map(|v| self.positions[v as usize]);
            (b - a).cross(&(c - a))
        }
    }

    /// Sorted rotations: compares triangles as oriented cycles.
    fn canonical(faces: &[[VertexId; 3]]) -> Vec<[VertexId; 3]> {
        let mut v: Vec<[VertexId; 3]> = faces
            .iter()
            .map(|&[a, b, c]| {
                let m = a.min(b).min(c);
                if m == a {
                    [a, b, c]
                } else if m == b {
                    [b, c, a]
                } else {
                    [c, a, b]
                }
            })
            .collect();
        v.sort_unstable();
        v
    }

    #[test]
    fn a_planar_grid_gives_exactly_the_expected_triangles() {
        // 3 x 3 cells, the centre-right (1, 2) absent:
        //   row 2:  6 7 8        (ids of present cells: row-major, skipping the absent one)
        //   row 1:  3 4 .
        //   row 0:  0 1 2
        let g = plane(3, 3, &[(1, 2)]);
        let id = |r, c| g.id(r, c);
        // Square blocks: the diagonals tie, so b-d is used.
        let want = vec![
            // block (0,0): a=0 b=1 d=3 e=4, all present
            [id(0, 0), id(0, 1), id(1, 0)],
            [id(0, 1), id(1, 1), id(1, 0)],
            // block (0,1): a=1 b=2 d=4, e=(1,2) absent: (a, b, d)
            [id(0, 1), id(0, 2), id(1, 1)],
            // block (1,0): all present
            [id(1, 0), id(1, 1), id(2, 0)],
            [id(1, 1), id(2, 1), id(2, 0)],
            // block (1,1): a=4, b=(1,2) absent, d=7, e=8: (a, e, d)
            [id(1, 1), id(2, 2), id(2, 1)],
        ];
        assert_eq!(canonical(&g.triangulate()), canonical(&want));
        // Two absent corners in a block: no triangle there.
        let g = plane(2, 2, &[(0, 0), (1, 1)]);
        assert!(g.triangulate().is_empty());
        let g = plane(2, 2, &[]);
        assert_eq!(g.triangulate().len(), 2);
    }

    #[test]
    fn blocks_split_along_the_shorter_diagonal() {
        // A block sheared as the interlaced rows of a Cyberware scan: b-d short, a-e long.
        let positions = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.8, 1.0, 0.0),
            Point3::new(1.8, 1.0, 0.0),
        ];
        let cells = [Some(0), Some(1), Some(2), Some(3)];
        let f = triangulate_grid(&positions, 2, 2, &cells);
        assert_eq!(canonical(&f), canonical(&[[0, 1, 2], [1, 3, 2]]));
        // Sheared the other way: a-e short.
        let positions = vec![
            Point3::new(0.8, 0.0, 0.0),
            Point3::new(1.8, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(1.0, 1.0, 0.0),
        ];
        let f = triangulate_grid(&positions, 2, 2, &cells);
        assert_eq!(canonical(&f), canonical(&[[0, 1, 3], [0, 3, 2]]));
    }

    #[test]
    fn all_triangles_of_a_flat_grid_face_the_same_way() {
        let absent: Vec<(usize, usize)> = (0..40).map(|k| ((k * 7) % 9, (k * 5) % 11)).collect();
        let g = plane(9, 11, &absent);
        let faces = g.triangulate();
        assert!(faces.len() > 60, "{}", faces.len());
        for &t in &faces {
            let n = g.normal(t);
            // Counter-clockwise with columns to the right (+x) and rows upward (+y): +z.
            assert!(n.z > 0.0 && n.x == 0.0 && n.y == 0.0, "{t:?} {n:?}");
        }
    }

    #[test]
    fn a_depth_jump_drops_exactly_the_triangles_across_it() {
        // 4 x 6 cells; columns 3.. are 10 units further away: the jump lies between columns 2
        // and 3, and only the blocks (r, 2) cross it.
        let mut g = plane(4, 6, &[]);
        for r in 0..4 {
            for c in 3..6 {
                let v = g.id(r, c) as usize;
                g.positions[v].z = 10.0;
            }
        }
        let faces = g.triangulate();
        let crossing = |t: &[VertexId; 3]| {
            let z: Vec<f64> = t.iter().map(|&v| g.positions[v as usize].z).collect();
            z.contains(&0.0) && z.contains(&10.0)
        };
        assert!(!faces.iter().any(crossing));
        // 3 rows of blocks x 5 columns of blocks x 2, less the 3 x 2 across the jump.
        assert_eq!(faces.len(), 3 * 5 * 2 - 3 * 2);
        // A smaller step (3 spacings, below DEPTH_JUMP) is kept: the steep part stays.
        for r in 0..4 {
            for c in 3..6 {
                let v = g.id(r, c) as usize;
                g.positions[v].z = 3.0;
            }
        }
        assert_eq!(g.triangulate().len(), 3 * 5 * 2);
    }

    #[test]
    fn inconsistent_input_does_not_panic() {
        let g = plane(3, 4, &[]);
        // cells shorter or longer than rows x cols, ids out of range, huge sizes
        let _ = triangulate_grid(&g.positions, 3, 4, &g.cells[..5]);
        let _ = triangulate_grid(&g.positions, 2, 4, &g.cells);
        let _ = triangulate_grid(&g.positions[..3], 3, 4, &g.cells);
        let _ = triangulate_grid(&g.positions, usize::MAX, usize::MAX, &g.cells);
        let _ = triangulate_grid(&g.positions, 0, 0, &[]);
        let mut p = g.positions.clone();
        p[5].x = f64::NAN;
        let f = triangulate_grid(&p, 3, 4, &g.cells);
        assert!(f.iter().all(|t| !t.contains(&5)));
        assert!(triangulate_grid(&[], 1, 1, &[None]).is_empty());
    }
}
