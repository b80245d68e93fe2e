//! Surface nets on the offset volume (S. F. Gibson, "Constrained elastic surface nets:
//! generating smooth surfaces from binary segmented data", MICCAI 1998; the "naive" variant
//! with vertices at the mean of the edge crossings).
//!
//! 1. Every grid cell whose eight corners are not all on the same side (outside or not,
//!    [`Volume::outside`]) gets one vertex: the mean of the points where the field
//!    [`Volume::value`] crosses zero on the cell's edges, by linear interpolation.
//! 2. Every grid edge joining an outside node to another node gets one quad, joining the
//!    vertices of the four cells around the edge, wound so that its normal points to the
//!    outside node, and split into two triangles along its shorter diagonal.
//!
//! The result is the boundary of the outside: closed (every edge in two faces) except where a
//! cell holds two sheets of surface, which the offset radius of at least 0.75 h makes rare.
//!
//! Cost: O(nodes) to find the cells, O(V) for the rest.

use std::collections::HashMap;

use keycomp_mesh::Point3;

use crate::volume::Volume;

/// Corner offsets of a cell, bit 0 = x, bit 1 = y, bit 2 = z.
const CORNERS: [[usize; 3]; 8] = [
    [0, 0, 0],
    [1, 0, 0],
    [0, 1, 0],
    [1, 1, 0],
    [0, 0, 1],
    [1, 0, 1],
    [0, 1, 1],
    [1, 1, 1],
];

/// The 12 edges of a cell as pairs of corner numbers.
const EDGES: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

/// Vertices and triangles of the boundary of `vol`'s outside (see the module docs).
pub fn surface_nets(vol: &Volume) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
    let [nx, ny, nz] = vol.dims;
    let mut cell_vertex: HashMap<usize, u32> = HashMap::new();
    let mut positions: Vec<Point3<f64>> = Vec::new();
    if nx < 2 || ny < 2 || nz < 2 {
        return (positions, Vec::new());
    }
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let base = vol.index(i, j, k);
                let corner = |c: usize| {
                    let [a, b, d] = CORNERS[c];
                    base + a + nx * (b + ny * d)
                };
                let first = vol.outside[base];
                if (1..8).all(|c| vol.outside[corner(c)] == first) {
                    continue;
                }
                let mut sum = nalgebra::Vector3::zeros();
                let mut count = 0.0;
                for (a, b) in EDGES {
                    let (na, nb) = (corner(a), corner(b));
                    if vol.outside[na] == vol.outside[nb] {
                        continue;
                    }
                    let (fa, fb) = (vol.value(na), vol.value(nb));
                    let t = if fa != fb { fa / (fa - fb) } else { 0.5 };
                    let t = t.clamp(0.0, 1.0);
                    let pa = offset(CORNERS[a]);
                    let pb = offset(CORNERS[b]);
                    sum += pa + (pb - pa) * t;
                    count += 1.0;
                }
                let local = sum / count;
                let p = vol.position(i, j, k) + local * vol.h;
                cell_vertex.insert(base, positions.len() as u32);
                positions.push(p);
            }
        }
    }
    let mut faces: Vec<[u32; 3]> = Vec::with_capacity(2 * positions.len());
    let strides = [1, nx, nx * ny];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let n = vol.index(i, j, k);
                let ijk = [i, j, k];
                for axis in 0..3 {
                    if ijk[axis] + 1 >= vol.dims[axis] {
                        continue;
                    }
                    let m = n + strides[axis];
                    if vol.outside[n] == vol.outside[m] {
                        continue;
                    }
                    let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
                    if ijk[b] == 0 || ijk[c] == 0 {
                        continue;
                    }
                    let (sb, sc) = (strides[b], strides[c]);
                    let cells = [n - sb - sc, n - sc, n, n - sb];
                    let Some(q) = cells
                        .iter()
                        .map(|cell| cell_vertex.get(cell).copied())
                        .collect::<Option<Vec<u32>>>()
                    else {
                        continue;
                    };
                    // normal along +axis when the outside is at m
                    let q = if vol.outside[m] {
                        [q[0], q[1], q[2], q[3]]
                    } else {
                        [q[3], q[2], q[1], q[0]]
                    };
                    let d02 = (positions[q[0] as usize] - positions[q[2] as usize]).norm_squared();
                    let d13 = (positions[q[1] as usize] - positions[q[3] as usize]).norm_squared();
                    // diagonals equal up to rounding (a symmetric cell) take the first, so
                    // that a moved or scaled copy of the input is split alike
                    if d02 <= d13 * (1.0 + TIE) {
                        faces.push([q[0], q[1], q[2]]);
                        faces.push([q[0], q[2], q[3]]);
                    } else {
                        faces.push([q[0], q[1], q[3]]);
                        faces.push([q[1], q[2], q[3]]);
                    }
                }
            }
        }
    }
    (positions, faces)
}

/// Relative difference below which a quad's diagonals count as equal.
const TIE: f64 = 1e-9;

fn offset(c: [usize; 3]) -> nalgebra::Vector3<f64> {
    nalgebra::Vector3::new(c[0] as f64, c[1] as f64, c[2] as f64)
}
