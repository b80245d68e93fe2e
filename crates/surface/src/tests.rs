//! Tests of the canonical surface against shapes whose answer is known.

use super::*;
use keycomp_mesh::{Topology, synth};

fn params(vertices: usize) -> SurfaceParams {
    SurfaceParams {
        vertices,
        ..SurfaceParams::default()
    }
}

fn boundary_edges(m: &Mesh) -> usize {
    let topo = Topology::new(m);
    (0..m.num_vertices() as u32)
        .map(|v| {
            topo.neighbors(v)
                .iter()
                .zip(topo.edge_face_counts(v))
                .filter(|&(&w, &c)| w > v && c == 1)
                .count()
        })
        .sum()
}

/// A sphere at two resolutions: the same closed surface of about the asked vertex count, on
/// the sphere's facets.
#[test]
fn sphere_at_any_resolution() {
    let mut made = Vec::new();
    for sub in [2, 5] {
        let m = synth::icosphere(sub, 1.0);
        let s = canonical(Input::Mesh(&m), &params(3000)).expect("surface");
        let n = s.mesh.num_vertices();
        assert!(
            (2200..=3800).contains(&n),
            "subdivision {sub}: {n} vertices"
        );
        assert_eq!(boundary_edges(&s.mesh), 0, "closed");
        // an icosphere's facets lie between 0.94 (subdivision 2) and 1 from its centre; the
        // few vertices whose projection would flatten a face stay at most r outside
        let mut on = 0;
        for p in &s.mesh.positions {
            let d = p.coords.norm();
            assert!((0.93..=1.0 + s.offset).contains(&d), "{d}");
            on += usize::from(d <= 1.0 + 1e-9);
        }
        assert!(on as f64 >= 0.98 * n as f64, "{on} of {n} on the sphere");
        made.push(geometry::total_area(&s.mesh));
    }
    assert!((made[0] / made[1] - 1.0).abs() < 0.05, "{made:?}");
}

/// A sphere wound inward is the same solid: nothing is trimmed.
#[test]
fn closed_solids_lose_nothing_whatever_their_winding() {
    let mut m = synth::icosphere(3, 1.0);
    for t in &mut m.faces {
        t.swap(1, 2);
    }
    let s = canonical(Input::Mesh(&m), &params(2000)).expect("surface");
    assert_eq!(s.trimmed_faces, 0);
    assert_eq!(boundary_edges(&s.mesh), 0);
}

/// An open sheet, a clean mesh, is remeshed on itself: one side, its boundary, its area,
/// every vertex on it.
#[test]
fn open_sheets_keep_one_side() {
    let m = synth::height_field(40, 40, 0.05, |x, y| 0.3 * (-(x * x + y * y) / 0.5).exp());
    let area = geometry::total_area(&m);
    let s = canonical(Input::Mesh(&m), &params(3000)).expect("surface");
    assert!(!s.reconstructed);
    assert!(boundary_edges(&s.mesh) > 0);
    let a = geometry::total_area(&s.mesh);
    assert!((a / area - 1.0).abs() < 0.01, "{a} vs {area}");
    let on = crate::closest::ClosestPoint::new(&m);
    for p in &s.mesh.positions {
        assert!(on.nearest(p).expect("faces").distance < 1e-6);
    }
    // the input faces +z: so must the surface, and it lies above the sheet
    let up = (0..s.mesh.num_faces())
        .filter(|&f| {
            let [a, b, c] = s.mesh.triangle(f);
            (b - a).cross(&(c - a)).z > 0.0
        })
        .count();
    assert!(up as f64 > 0.9 * s.mesh.num_faces() as f64, "{up}");
    // reversed winding keeps the other side
    let mut flipped = m.clone();
    for t in &mut flipped.faces {
        t.swap(1, 2);
    }
    let s2 = canonical(Input::Mesh(&flipped), &params(3000)).expect("surface");
    let down = (0..s2.mesh.num_faces())
        .filter(|&f| {
            let [a, b, c] = s2.mesh.triangle(f);
            (b - a).cross(&(c - a)).z < 0.0
        })
        .count();
    assert!(down as f64 > 0.9 * s2.mesh.num_faces() as f64, "{down}");
}

/// Two overlapping cubes given as separate pieces become one closed surface without the faces
/// hidden inside their union.
#[test]
fn a_soup_becomes_one_solid() {
    let mut soup = cube([0.0, 0.0, 0.0], 1.0);
    let other = cube([0.5, 0.3, 0.2], 1.0);
    let off = soup.positions.len() as u32;
    soup.positions.extend(other.positions);
    soup.faces
        .extend(other.faces.iter().map(|t| t.map(|v| v + off)));
    let s = canonical(Input::Mesh(&soup), &params(3000)).expect("surface");
    assert!(s.reconstructed);
    assert_eq!(boundary_edges(&s.mesh), 0);
    let (_, pieces) = Topology::new(&s.mesh).connected_components();
    assert_eq!(pieces, 1);
    // the union's area: each cube hides three faces of the 0.5 × 0.7 × 0.8 box they share,
    // 12 − 2 · (0.35 + 0.4 + 0.56) = 9.38; vertices on the sharp edges stay a little outside
    let a = geometry::total_area(&s.mesh);
    assert!((9.3..10.3).contains(&a), "{a}");
}

/// The canonical surface of points without normals, for `vertices`.
fn cloud_surface(points: &[Point3<f64>], vertices: usize) -> Surface {
    canonical(
        Input::Points {
            positions: points,
            normals: None,
        },
        &params(vertices),
    )
    .expect("surface")
}

/// Points on a sphere make a closed surface; one view of a bump an open one facing its viewer.
#[test]
fn point_clouds() {
    let pts = crate::normals::tests_support::fibonacci_sphere(5000, 1.0);
    let s = cloud_surface(&pts, 2000);
    assert_eq!(boundary_edges(&s.mesh), 0);
    let a = geometry::total_area(&s.mesh);
    assert!((a / (4.0 * std::f64::consts::PI) - 1.0).abs() < 0.3, "{a}");
    let mut bump = Vec::new();
    for i in 0..80 {
        for j in 0..80 {
            let (x, y) = (i as f64 / 40.0 - 1.0, j as f64 / 40.0 - 1.0);
            bump.push(Point3::new(x, y, 0.5 * (1.0 - 0.5 * (x * x + y * y))));
        }
    }
    let s = cloud_surface(&bump, 2000);
    assert!(boundary_edges(&s.mesh) > 0);
    let up = (0..s.mesh.num_faces())
        .filter(|&f| {
            let [a, b, c] = s.mesh.triangle(f);
            (b - a).cross(&(c - a)).z > 0.0
        })
        .count();
    assert!(up as f64 > 0.9 * s.mesh.num_faces() as f64);
}

/// Points in lines, as a mesh's rings of vertices or a scanner's rows give them: dense along
/// each line, sparse across. The gaps between lines are bridged: one closed surface.
#[test]
fn points_in_lines_close_across_them() {
    // 30 rings of 200 points on a unit sphere: 0.03 apart along a ring, 0.1 across
    let mut pts = vec![Point3::new(0.0, 0.0, 1.0), Point3::new(0.0, 0.0, -1.0)];
    for i in 1..31 {
        let th = std::f64::consts::PI * i as f64 / 31.0;
        for j in 0..200 {
            let ph = 2.0 * std::f64::consts::PI * j as f64 / 200.0;
            pts.push(Point3::new(
                th.sin() * ph.cos(),
                th.sin() * ph.sin(),
                th.cos(),
            ));
        }
    }
    let s = cloud_surface(&pts, 10_000);
    assert_eq!(boundary_edges(&s.mesh), 0);
    let a = geometry::total_area(&s.mesh);
    assert!((a / (4.0 * std::f64::consts::PI) - 1.0).abs() < 0.3, "{a}");
}

#[test]
fn deterministic() {
    let m = synth::textured_protrusion_sphere(4);
    let a = canonical(Input::Mesh(&m), &params(2000)).expect("a");
    let b = canonical(Input::Mesh(&m), &params(2000)).expect("b");
    assert_eq!(a, b);
}

#[test]
fn degenerate_inputs_are_errors() {
    let flat = Mesh {
        positions: vec![
            Point3::origin(),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(2.0, 0.0, 0.0),
        ],
        faces: vec![[0, 1, 2]],
    };
    assert!(matches!(
        canonical(Input::Mesh(&flat), &SurfaceParams::default()),
        Err(SurfaceError::NoArea)
    ));
    let bad = SurfaceParams {
        vertices: 10,
        ..SurfaceParams::default()
    };
    assert!(canonical(Input::Mesh(&synth::icosphere(1, 1.0)), &bad).is_err());
}

/// A long thin input gets a bounded grid (coarser spacing) instead of a huge allocation.
#[test]
fn extent_far_beyond_the_area_is_bounded() {
    let needle = Mesh {
        positions: vec![
            Point3::origin(),
            Point3::new(1e6, 0.0, 0.0),
            Point3::new(0.0, 1e-3, 1e6),
        ],
        faces: vec![[0, 1, 2]],
    };
    let s = canonical(Input::Mesh(&needle), &params(1000));
    if let Ok(s) = s {
        assert!(s.mesh.num_vertices() > 0);
    }
}

fn cube(o: [f64; 3], e: f64) -> Mesh {
    synth::cuboid(o, [e; 3])
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    fn point() -> impl Strategy<Value = Point3<f64>> {
        (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64).prop_map(|(x, y, z)| Point3::new(x, y, z))
    }

    fn check(s: Result<Surface, SurfaceError>) {
        if let Ok(s) = s {
            let n = s.mesh.num_vertices() as u32;
            assert!(!s.mesh.faces.is_empty());
            assert!(s.mesh.faces.iter().flatten().all(|&v| v < n));
            assert!(
                s.mesh
                    .positions
                    .iter()
                    .all(|p| p.coords.iter().all(|c| c.is_finite()))
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Any soup of random triangles gives a valid surface or an error, never a panic.
        #[test]
        fn random_soups(points in prop::collection::vec(point(), 3..40), seed in 0u64..1000) {
            let n = points.len() as u64;
            let faces = (0..points.len() as u64)
                .map(|i| {
                    let f = |k: u64| ((i * 7 + k * 13 + seed) % n) as u32;
                    [f(0), f(1), f(2)]
                })
                .collect();
            if let Ok((mesh, _)) = Mesh::from_raw(points, faces) {
                check(canonical(Input::Mesh(&mesh), &params(500)));
            }
        }

        /// Any cloud of random points, duplicates included, likewise.
        #[test]
        fn random_clouds(mut points in prop::collection::vec(point(), 1..300)) {
            let copy = points[0];
            points.push(copy);
            check(canonical(Input::Points { positions: &points, normals: None }, &params(500)));
        }
    }
}

/// A scaled and moved copy gets the same surface, scaled and moved, up to rounding: the
/// spacing follows the area, the grid and the samples' thinning are anchored on the input's
/// box, and choices between lengths equal up to rounding (which edge to bisect, which diagonal
/// splits a quad) go the same way.
#[test]
fn a_scaled_and_moved_copy_gets_the_same_surface() {
    let m = synth::textured_protrusion_sphere(4);
    let a = canonical(Input::Mesh(&m), &params(4000)).expect("surface");
    for (k, shift) in [(2.0, 0.0), (0.25, 0.0), (4.0, 8.0), (1.0, -3.7)] {
        let mut c = m.clone();
        for p in &mut c.positions {
            *p = Point3::new(p.x * k + shift, p.y * k + shift, p.z * k + shift);
        }
        let b = canonical(Input::Mesh(&c), &params(4000)).expect("surface");
        assert_eq!(
            a.mesh.num_vertices(),
            b.mesh.num_vertices(),
            "scale {k}, shift {shift}"
        );
        let worst = a
            .mesh
            .positions
            .iter()
            .zip(&b.mesh.positions)
            .map(|(p, q)| (p.coords - (q.coords - Vector3::repeat(shift)) / k).norm())
            .fold(0.0, f64::max);
        assert!(
            worst < 1e-9,
            "scale {k}, shift {shift}: a vertex moved by {worst}"
        );
        assert_eq!(a.mesh.faces, b.mesh.faces, "scale {k}, shift {shift}");
    }
}

/// Two cubes apart are two clean pieces: each remeshed on its own, not joined; a speck is
/// left out; a hole shorter than the threshold is closed, a longer one kept.
#[test]
fn clean_pieces_apart_stay_apart_and_small_holes_close() {
    let mut two = cube([0.0, 0.0, 0.0], 1.0);
    let other = cube([3.0, 0.0, 0.0], 1.0);
    let speck = cube([0.0, 5.0, 0.0], 0.01);
    for extra in [other, speck] {
        let off = two.positions.len() as u32;
        two.positions.extend(extra.positions);
        two.faces
            .extend(extra.faces.iter().map(|t| t.map(|v| v + off)));
    }
    let s = canonical(Input::Mesh(&two), &params(3000)).expect("surface");
    assert!(!s.reconstructed);
    assert_eq!(s.dropped_faces, 12);
    let (_, pieces) = Topology::new(&s.mesh).connected_components();
    assert_eq!(pieces, 2);
    // every vertex lies on a cube; its sharp edges are cut, by a fraction of an edge length
    let a = geometry::total_area(&s.mesh);
    assert!(a < 12.0 && a > 11.5, "{a}");
    // a sphere with one vertex's star removed (a micro-hole) and a cap cut off (a large hole)
    let sphere = synth::icosphere(4, 1.0);
    let top = (0..sphere.num_vertices() as u32)
        .max_by(|&a, &b| {
            sphere.positions[a as usize]
                .z
                .total_cmp(&sphere.positions[b as usize].z)
        })
        .expect("vertices");
    let holed = Mesh {
        positions: sphere.positions.clone(),
        faces: sphere
            .faces
            .iter()
            .copied()
            .filter(|t| {
                !t.contains(&top) && t.iter().any(|&v| sphere.positions[v as usize].z > -0.8)
            })
            .collect(),
    };
    // at 1,000 vertices six edges are longer than the micro-hole's loop
    let s = canonical(Input::Mesh(&holed), &params(1000)).expect("surface");
    assert!(!s.reconstructed);
    // one boundary loop left: the cap's, not the micro-hole's
    let t = Topology::new(&s.mesh);
    let high = t
        .boundary_vertices()
        .iter()
        .filter(|&&v| s.mesh.positions[v as usize].z > 0.9)
        .count();
    let low = t
        .boundary_vertices()
        .iter()
        .filter(|&&v| s.mesh.positions[v as usize].z < -0.7)
        .count();
    assert_eq!(high, 0);
    assert!(low > 10, "{low}");
}
