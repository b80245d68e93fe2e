//! Synthetic meshes generated in code, for tests, benchmarks and the demo: an icosphere, a torus,
//! a flat grid, a height field, a sphere with smooth protrusions whose tips are known, and a
//! double cone whose apices have any valence (a pathological input).

use std::collections::HashMap;

use crate::{Mesh, Point3, Vector3, VertexId};

/// An icosphere of the given radius centred at the origin: an icosahedron whose faces are split
/// in four `subdivisions` times, new vertices pushed to the sphere. It has `10·4^k + 2` vertices
/// (k = 6 gives 40,962) and nearly uniform edge lengths.
pub fn icosphere(subdivisions: u32, radius: f64) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut pos: Vec<Vector3<f64>> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vector3::new(p[0], p[1], p[2]).normalize())
    .collect();
    let mut faces: Vec<[VertexId; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid: HashMap<(VertexId, VertexId), VertexId> = HashMap::new();
        let mut midpoint = |a: VertexId, b: VertexId, pos: &mut Vec<Vector3<f64>>| {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                pos.push(((pos[a as usize] + pos[b as usize]) * 0.5).normalize());
                (pos.len() - 1) as VertexId
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for &[a, b, c] in &faces {
            let ab = midpoint(a, b, &mut pos);
            let bc = midpoint(b, c, &mut pos);
            let ca = midpoint(c, a, &mut pos);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    Mesh {
        positions: pos.iter().map(|p| Point3::from(p * radius)).collect(),
        faces,
    }
}

/// A torus around the z axis: major radius `major`, tube radius `minor`, `nu` segments around the
/// axis and `nv` around the tube (both ≥ 3).
pub fn torus(major: f64, minor: f64, nu: usize, nv: usize) -> Mesh {
    let (nu, nv) = (nu.max(3), nv.max(3));
    let mut positions = Vec::with_capacity(nu * nv);
    for i in 0..nu {
        let u = i as f64 / nu as f64 * std::f64::consts::TAU;
        for j in 0..nv {
            let v = j as f64 / nv as f64 * std::f64::consts::TAU;
            let r = major + minor * v.cos();
            positions.push(Point3::new(r * u.cos(), r * u.sin(), minor * v.sin()));
        }
    }
    let id = |i: usize, j: usize| ((i % nu) * nv + (j % nv)) as VertexId;
    let mut faces = Vec::with_capacity(2 * nu * nv);
    for i in 0..nu {
        for j in 0..nv {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    Mesh { positions, faces }
}

/// A closed double cone: `n` (at least 3) vertices on the unit circle in the z = 0 plane, then
/// the apices (0, 0, 1) and (0, 0, −1), which have valence `n`. A pathological mesh for
/// testing that no stage's work grows with the square of a vertex's valence; 2n faces,
/// outward-oriented.
pub fn bicone(n: usize) -> Mesh {
    let n = n.max(3);
    let mut positions: Vec<Point3<f64>> = (0..n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            Point3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    positions.push(Point3::new(0.0, 0.0, 1.0));
    positions.push(Point3::new(0.0, 0.0, -1.0));
    let (top, bottom) = (n as VertexId, n as VertexId + 1);
    let mut faces = Vec::with_capacity(2 * n);
    for i in 0..n {
        let (a, b) = (i as VertexId, ((i + 1) % n) as VertexId);
        faces.push([a, b, top]);
        faces.push([b, a, bottom]);
    }
    Mesh { positions, faces }
}

/// A closed axis-aligned box from corner `origin` with side lengths `extent`: 8 vertices, 12
/// outward-oriented triangles.
pub fn cuboid(origin: [f64; 3], extent: [f64; 3]) -> Mesh {
    let p = |x: f64, y: f64, z: f64| {
        Point3::new(
            origin[0] + x * extent[0],
            origin[1] + y * extent[1],
            origin[2] + z * extent[2],
        )
    };
    Mesh {
        positions: vec![
            p(0.0, 0.0, 0.0),
            p(1.0, 0.0, 0.0),
            p(1.0, 1.0, 0.0),
            p(0.0, 1.0, 0.0),
            p(0.0, 0.0, 1.0),
            p(1.0, 0.0, 1.0),
            p(1.0, 1.0, 1.0),
            p(0.0, 1.0, 1.0),
        ],
        faces: vec![
            [0, 2, 1],
            [0, 3, 2],
            [4, 5, 6],
            [4, 6, 7],
            [0, 1, 5],
            [0, 5, 4],
            [1, 2, 6],
            [1, 6, 5],
            [2, 3, 7],
            [2, 7, 6],
            [3, 0, 4],
            [3, 4, 7],
        ],
    }
}

/// A flat `nx × ny` grid of square cells of side `cell` in the z = 0 plane (laid out as
/// [`height_field`]); each cell split into two triangles. It has an open boundary.
pub fn grid(nx: usize, ny: usize, cell: f64) -> Mesh {
    height_field(nx, ny, cell, |_, _| 0.0)
}

/// A height field z = f(x, y) over an `nx × ny` grid of cells of side `cell`, centred on the
/// origin when `nx`, `ny` are even (x, y run from `-nx·cell/2` to `nx·cell/2`). Vertex
/// `j·(nx+1) + i` is at grid column i, row j.
pub fn height_field(nx: usize, ny: usize, cell: f64, f: impl Fn(f64, f64) -> f64) -> Mesh {
    let (nx, ny) = (nx.max(1), ny.max(1));
    let (x0, y0) = (-(nx as f64) * cell / 2.0, -(ny as f64) * cell / 2.0);
    let mut positions = Vec::with_capacity((nx + 1) * (ny + 1));
    for j in 0..=ny {
        for i in 0..=nx {
            let (x, y) = (x0 + i as f64 * cell, y0 + j as f64 * cell);
            positions.push(Point3::new(x, y, f(x, y)));
        }
    }
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as VertexId;
    let mut faces = Vec::with_capacity(2 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            // alternate the diagonal so the triangulation has no preferred direction
            if (i + j) % 2 == 0 {
                faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            } else {
                faces.push([id(i, j), id(i + 1, j), id(i, j + 1)]);
                faces.push([id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    Mesh { positions, faces }
}

/// Directions of the protrusions of [`protrusion_sphere`]: six unit vectors spread unevenly over
/// the sphere (not a symmetric set, so every tip is distinct).
pub fn protrusion_directions() -> Vec<Vector3<f64>> {
    [
        [0.0, 0.0, 1.0],
        [0.9, 0.1, -0.42],
        [-0.5, 0.8, -0.3],
        [-0.45, -0.8, -0.2],
        [0.2, -0.3, -0.93],
        [-0.95, 0.05, 0.55],
    ]
    .iter()
    .map(|d| Vector3::new(d[0], d[1], d[2]).normalize())
    .collect()
}

/// A unit icosphere with a smooth bump of height `height` (radius units) around each of the
/// [`protrusion_directions`]: radius `1 + height · exp(−(θ/width)²)` where θ is the angle (in
/// radians) to the nearest direction. With `height` ≈ 0.8 and `width` ≈ 0.25 these are finger-like
/// protrusions whose tips are the vertices closest to the directions (see
/// [`protrusion_tips`]).
pub fn protrusion_sphere(subdivisions: u32, height: f64, width: f64) -> Mesh {
    let mut m = icosphere(subdivisions, 1.0);
    let dirs = protrusion_directions();
    for p in &mut m.positions {
        let u = p.coords.normalize();
        let bump: f64 = dirs
            .iter()
            .map(|d| {
                let theta = u.dot(d).clamp(-1.0, 1.0).acos();
                height * (-(theta / width).powi(2)).exp()
            })
            .sum();
        *p = Point3::from(u * (1.0 + bump));
    }
    m
}

/// A [`protrusion_sphere`] (height 0.8, width 0.35) whose protrusions carry a fine ripple
/// `0.03 · w · sin(60x)·sin(60y)·sin(60z)` (w = the protrusion's bump weight, 1 at a tip, ≈0 on
/// the body): many small curvature extrema concentrated on the protrusions and none on the
/// smooth body, the situation key-components are made for (Sipiran & Bustos 2013, Fig. 1).
/// With `subdivisions = 6` (40,962 vertices) the paper's KC-1 finds one key-component per
/// protrusion.
pub fn textured_protrusion_sphere(subdivisions: u32) -> Mesh {
    const WIDTH: f64 = 0.35;
    let mut m = protrusion_sphere(subdivisions, 0.8, WIDTH);
    let dirs = protrusion_directions();
    for p in &mut m.positions {
        let u = p.coords.normalize();
        let w: f64 = dirs
            .iter()
            .map(|d| (-(u.dot(d).clamp(-1.0, 1.0).acos() / WIDTH).powi(2)).exp())
            .sum();
        let ripple = (60.0 * u.x).sin() * (60.0 * u.y).sin() * (60.0 * u.z).sin();
        *p = Point3::from(u * (p.coords.norm() + 0.03 * w * ripple));
    }
    m
}

/// The vertex of a [`protrusion_sphere`] closest to each protrusion direction (the tips).
pub fn protrusion_tips(mesh: &Mesh) -> Vec<VertexId> {
    protrusion_directions()
        .iter()
        .map(|d| {
            let mut best = (f64::NEG_INFINITY, 0);
            for (i, p) in mesh.positions.iter().enumerate() {
                let c = p.coords.normalize().dot(d);
                if c > best.0 {
                    best = (c, i as VertexId);
                }
            }
            best.1
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Topology;
    use crate::geometry::total_area;

    #[test]
    fn icosphere_counts_and_area() {
        for k in 0..4 {
            let m = icosphere(k, 1.0);
            assert_eq!(m.num_vertices(), 10 * 4usize.pow(k) + 2);
            assert_eq!(m.num_faces(), 20 * 4usize.pow(k));
            let (m2, rep) = Mesh::from_raw(m.positions.clone(), m.faces.clone()).expect("valid");
            assert_eq!(rep, Default::default());
            assert!(Topology::new(&m2).boundary_vertices().is_empty());
        }
        let a = total_area(&icosphere(5, 1.0));
        assert!(
            (a - 4.0 * std::f64::consts::PI).abs() / a < 2e-3,
            "area {a}"
        );
    }

    #[test]
    fn torus_is_closed_and_has_the_right_area() {
        let m = torus(2.0, 0.5, 120, 60);
        assert!(Topology::new(&m).boundary_vertices().is_empty());
        let exact = 4.0 * std::f64::consts::PI.powi(2) * 2.0 * 0.5;
        assert!((total_area(&m) - exact).abs() / exact < 2e-3);
    }

    #[test]
    fn protrusion_tips_stick_out() {
        let m = protrusion_sphere(4, 0.8, 0.25);
        for t in protrusion_tips(&m) {
            assert!(m.positions[t as usize].coords.norm() > 1.7);
        }
    }
}
