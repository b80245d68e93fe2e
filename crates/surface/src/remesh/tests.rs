use super::*;
use halfedge::NotManifold;
use keycomp_mesh::{Topology, geometry, synth};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn euler(m: &Mesh) -> i64 {
    let t = Topology::new(m);
    let edges: usize = (0..m.num_vertices() as u32)
        .map(|v| t.neighbors(v).len())
        .sum::<usize>()
        / 2;
    m.num_vertices() as i64 - edges as i64 + m.faces.len() as i64
}

/// `steps` random splits, flips and collapses on `mesh` (seeded), checking every half-edge
/// invariant and the Euler characteristic `chi` after each; how many of each were done.
fn random_operations(mesh: &Mesh, seed: u64, steps: usize, chi: i64) -> (usize, usize, usize) {
    let mut he = HalfEdges::new(mesh).expect("manifold");
    he.check().expect("built");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut scratch = Vec::new();
    let (mut splits, mut flips, mut collapses) = (0, 0, 0);
    for _ in 0..steps {
        let edges = he.live_edges();
        let h = edges[rng.random_range(0..edges.len())];
        match rng.random_range(0..3) {
            0 => {
                let (a, b) = (he.from(h), he.to[h as usize]);
                let mid =
                    Point3::from((he.pos[a as usize].coords + he.pos[b as usize].coords) / 2.0);
                he.split(h, mid);
                splits += 1;
            }
            1 if he.can_flip(h) => {
                he.flip(h);
                flips += 1;
            }
            2 if he.can_collapse(h, &mut scratch) => {
                let b = he.to[h as usize];
                he.collapse(h, he.pos[b as usize]);
                collapses += 1;
            }
            _ => continue,
        }
        he.check().expect("after an operation");
        assert_eq!(euler(&he.to_mesh()), chi);
    }
    (splits, flips, collapses)
}

/// Random splits, flips and collapses keep every half-edge invariant and the sphere a sphere
/// (Euler characteristic 2).
#[test]
fn local_operations_keep_the_mesh_a_manifold() {
    let (splits, flips, collapses) = random_operations(&synth::icosphere(2, 1.0), 3, 600, 2);
    assert!(
        splits > 50 && flips > 50 && collapses > 50,
        "{splits} {flips} {collapses}"
    );
}

/// The same on an open grid: boundary loops stay loops, and the disc stays a disc (χ = 1).
#[test]
fn operations_on_an_open_mesh() {
    random_operations(&synth::grid(8, 8, 0.125), 5, 400, 1);
}

#[test]
fn non_manifold_meshes_are_refused() {
    let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
    // two faces running along an edge the same way
    let flipped = Mesh {
        positions: vec![p(0., 0., 0.), p(1., 0., 0.), p(0., 1., 0.), p(1., 1., 0.)],
        faces: vec![[0, 1, 2], [0, 1, 3]],
    };
    assert_eq!(HalfEdges::new(&flipped).err(), Some(NotManifold::Edge));
    // three faces on one edge
    let fin = Mesh {
        positions: vec![
            p(0., 0., 0.),
            p(1., 0., 0.),
            p(0., 1., 0.),
            p(0., -1., 0.),
            p(0., 0., 1.),
        ],
        faces: vec![[0, 1, 2], [1, 0, 3], [1, 0, 4]],
    };
    assert!(HalfEdges::new(&fin).is_err());
    // two fans meeting at a vertex (a bow tie)
    let bowtie = Mesh {
        positions: vec![
            p(0., 0., 0.),
            p(1., 0., 0.),
            p(1., 1., 0.),
            p(-1., 0., 0.),
            p(-1., -1., 0.),
        ],
        faces: vec![[0, 1, 2], [0, 3, 4]],
    };
    assert_eq!(HalfEdges::new(&bowtie).err(), Some(NotManifold::Vertex));
}

fn edge_lengths(m: &Mesh) -> Vec<f64> {
    let mut out: Vec<f64> = m
        .faces
        .iter()
        .flat_map(|t| {
            [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]
                .map(|(a, b)| (m.positions[a as usize] - m.positions[b as usize]).norm())
        })
        .collect();
    out.sort_by(f64::total_cmp);
    out
}

/// A coarse sphere remeshed at a length: every vertex on the sphere it was made from (its
/// faces, within their sagitta of the sphere), edges near the length, closed, nearly
/// equilateral; a fine one remeshed coarser the same. Deterministic.
#[test]
fn a_sphere_at_any_tessellation_becomes_the_same_density() {
    let l = 0.1;
    let mut counts = Vec::new();
    for level in [2, 5] {
        let start = synth::icosphere(level, 1.0);
        let cp = ClosestPoint::new(&start);
        let params = RemeshParams {
            edge: l,
            iterations: 8,
            max_faces: 1_000_000,
        };
        let m = remesh(HalfEdges::new(&start).expect("manifold"), &params, &cp);
        assert_eq!(
            m,
            remesh(HalfEdges::new(&start).expect("again"), &params, &cp)
        );
        for p in &m.positions {
            let d = cp.nearest(p).expect("faces").distance;
            assert!(d < 1e-9, "off the input by {d}");
        }
        assert!(Topology::new(&m).boundary_vertices().is_empty());
        assert_eq!(euler(&m), 2);
        let e = edge_lengths(&m);
        let q = |f: f64| e[((e.len() - 1) as f64 * f) as usize];
        assert!(
            q(0.05) > 0.6 * l && q(0.95) < 1.45 * l,
            "{} {}",
            q(0.05),
            q(0.95)
        );
        counts.push(m.num_vertices() as f64);
    }
    // the same density from 162 and 10,242 starting vertices
    assert!((counts[0] / counts[1] - 1.0).abs() < 0.1, "{counts:?}");
    // about 2A / (√3 L²) vertices
    let expected = 2.0 * 4.0 * std::f64::consts::PI / (3f64.sqrt() * l * l);
    assert!(
        (counts[1] / expected - 1.0).abs() < 0.25,
        "{} vs {expected}",
        counts[1]
    );
}

/// An open square keeps its boundary on the square's sides and its area.
#[test]
fn an_open_mesh_keeps_its_boundary() {
    let start = synth::grid(3, 3, 1.0 / 3.0);
    let cp = ClosestPoint::new(&start);
    let params = RemeshParams {
        edge: 0.05,
        iterations: 8,
        max_faces: 1_000_000,
    };
    let m = remesh(HalfEdges::new(&start).expect("manifold"), &params, &cp);
    assert!((geometry::total_area(&m) - 1.0).abs() < 1e-9);
    let t = Topology::new(&m);
    for v in t.boundary_vertices() {
        let p = m.positions[v as usize];
        let on_side = [0.5 + p.x, 0.5 + p.y, 0.5 - p.x, 0.5 - p.y]
            .iter()
            .any(|d| d.abs() < 1e-9);
        assert!(on_side, "boundary vertex {p:?} off the square's sides");
    }
    assert_eq!(euler(&m), 1);
    assert!(m.num_vertices() > 300);
}
