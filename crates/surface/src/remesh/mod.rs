//! Isotropic remeshing with projection onto the input: a surface of nearly equilateral
//! triangles of one edge length whose vertices lie on the input's own geometry (M. Botsch and
//! L. Kobbelt, "A remeshing approach to multiresolution modeling", Symposium on Geometry
//! Processing 2004; M. Botsch, L. Kobbelt, M. Pauly, P. Alliez, B. Lévy, *Polygon Mesh
//! Processing*, AK Peters 2010, §6.5.3).
//!
//! From a clean manifold mesh (the input, its small holes closed) and a target edge length L,
//! each of [`RemeshParams::iterations`] rounds does, in order:
//! 1. **Split** every edge longer than 4/3·L at its midpoint (in the first round, until none is
//!    left), the new vertex put on the input.
//! 2. **Collapse** every edge shorter than 4/5·L into its midpoint (onto the boundary vertex
//!    when one end is on a boundary and the other is not; never an inner edge between two
//!    boundary vertices), unless the link condition fails, an edge of the result would be
//!    longer than 4/3·L, or a face would turn over.
//! 3. **Flip** every inner edge whose flip brings the valences of its four vertices closer to 6
//!    (4 on a boundary), unless a face would turn over.
//! 4. **Relax** every vertex tangentially towards the centroid of its neighbours: p ← p + (I −
//!    n nᵀ)(c − p), n the vertex normal; a boundary vertex towards the middle of its two
//!    boundary neighbours.
//! 5. **Project** every vertex onto the input (a [`ClosestPoint`]): the nearest point of its faces (a
//!    boundary vertex onto the nearest boundary edge).
//!
//! The 4/5 and 4/3 thresholds make the split and collapse steps converge to edges of length
//! near L; flips and relaxation make the triangles nearly equilateral and the sampling even. So
//! two tessellations of one shape remeshed at one L are two samplings of the same density of
//! the same geometry, whatever their own triangles were.
//!
//! Every step visits edges and vertices in index order and the parallel steps (relaxation,
//! projection) write disjoint slots, so the result is deterministic. Cost per round O(V·d) for
//! V vertices of degree d, plus a projection query O(log F) per vertex.

pub(crate) mod halfedge;

use keycomp_mesh::{Mesh, Point3, Vector3};
use rayon::prelude::*;

use crate::closest::ClosestPoint;
pub(crate) use halfedge::HalfEdges;
use halfedge::NONE;

/// Parameters of the remeshing (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RemeshParams {
    /// Target edge length L, in the input's units (> 0).
    pub edge: f64,
    /// Rounds of split, collapse, flip, relax and project.
    pub iterations: usize,
    /// No edge is split once the mesh has this many faces (a bound on the work and memory
    /// whatever the input: slivers of an input far longer than L would otherwise multiply).
    pub max_faces: usize,
}

/// The nearest point of `target` to `p`: of its boundary edges when `boundary` (and it has
/// any), else of its faces; `p` itself if there is none or it is not finite.
fn project(target: &ClosestPoint, p: &Point3<f64>, boundary: bool) -> Point3<f64> {
    let hit = if boundary {
        target.on_boundary(p).or_else(|| target.nearest(p))
    } else {
        target.nearest(p)
    };
    match hit.map(|h| h.point) {
        Some(q) if q.iter().all(|c| c.is_finite()) => q,
        _ => *p,
    }
}

/// Remeshes the mesh of `he` (built from an edge- and vertex-manifold, consistently oriented
/// mesh) isotropically at `params.edge`, projected onto `target`, boundary vertices onto its
/// boundary edges (see the [module docs](self)).
pub(crate) fn remesh(mut he: HalfEdges, params: &RemeshParams, target: &ClosestPoint) -> Mesh {
    let l = params.edge;
    let (hi2, lo2) = ((4.0 / 3.0 * l).powi(2), (4.0 / 5.0 * l).powi(2));
    let mut scratch = Vec::new();
    for round in 0..params.iterations {
        // 1. split, in the first round until no edge is too long
        for _ in 0..if round == 0 { 32 } else { 1 } {
            let mut any = false;
            for h in he.live_edges() {
                if he.face_dead.len() >= params.max_faces {
                    break;
                }
                if he.length2(h) > hi2 {
                    let (a, b) = (he.from(h), he.to[h as usize]);
                    let boundary = he.is_boundary_edge(h);
                    let mid =
                        Point3::from((he.pos[a as usize].coords + he.pos[b as usize].coords) * 0.5);
                    let p = project(target, &mid, boundary);
                    he.split(h, p);
                    any = true;
                }
            }
            if !any {
                break;
            }
        }
        // 2. collapse
        for h in he.live_edges() {
            if he.edge_dead[h as usize] || he.length2(h) >= lo2 {
                continue;
            }
            let t = he.twin[h as usize];
            let (a, b) = (he.from(h), he.to[h as usize]);
            // 0 inside, 1 on a boundary, 2 at a corner of a boundary: the higher survives
            let (ra, rb) = (rank(&he, a), rank(&he, b));
            if ra > 0 && rb > 0 && !he.is_boundary_edge(h) || ra == 2 && rb == 2 {
                continue;
            }
            // (half-edge to collapse, where the survivor goes)
            let (x, p) = if ra > rb {
                (t, he.pos[a as usize])
            } else if rb > ra {
                (h, he.pos[b as usize])
            } else {
                (
                    h,
                    Point3::from((he.pos[a as usize].coords + he.pos[b as usize].coords) * 0.5),
                )
            };
            if he.can_collapse(x, &mut scratch) && collapse_is_good(&he, x, &p, hi2, &mut scratch) {
                he.collapse(x, p);
            }
        }
        // 3. flip towards valence 6 (4 on a boundary)
        // valences kept up to date by each flip: the cheap test first, the link's last
        let mut valence = vec![0u32; he.pos.len()];
        for v in he.live_vertices() {
            valence[v as usize] = he.valence(v) as u32;
        }
        for h in he.live_edges() {
            if he.edge_dead[h as usize]
                || he.is_boundary_edge(h)
                || !flip_is_good(&he, h, &valence)
                || !he.can_flip(h)
            {
                continue;
            }
            let [a, b, c, d] = flip_quad(&he, h);
            he.flip(h);
            valence[a as usize] -= 1;
            valence[b as usize] -= 1;
            valence[c as usize] += 1;
            valence[d as usize] += 1;
        }
        // 4. relax and 5. project, every vertex from the same state
        let live: Vec<u32> = he.live_vertices().collect();
        let normals: Vec<Vector3<f64>> = (0..he.face_he.len() as u32)
            .into_par_iter()
            .map(|f| {
                if he.face_dead[f as usize] {
                    Vector3::zeros()
                } else {
                    he.face_normal(f)
                }
            })
            .collect();
        let moved: Vec<(u32, Point3<f64>)> = live
            .par_iter()
            .map_init(Vec::new, |ring, &v| {
                let boundary = he.is_boundary_vertex(v);
                let p = he.pos[v as usize];
                let relaxed = relaxed(&he, v, boundary, ring, &normals);
                let q = project(target, &relaxed, boundary);
                (
                    v,
                    if q.iter().all(|c| c.is_finite()) {
                        q
                    } else {
                        p
                    },
                )
            })
            .collect();
        for (v, p) in moved {
            he.pos[v as usize] = p;
        }
    }
    he.to_mesh()
}

/// Where relaxation moves `v`: towards the centroid of its neighbours in its tangent plane (the
/// sum of its faces' `normals`, per face, area-weighted), or for a boundary vertex towards the
/// middle of its two boundary neighbours.
fn relaxed(
    he: &HalfEdges,
    v: u32,
    boundary: bool,
    ring: &mut Vec<u32>,
    normals: &[Vector3<f64>],
) -> Point3<f64> {
    let p = he.pos[v as usize];
    if boundary {
        let [prev, next] = boundary_neighbours(he, v);
        if is_corner(he, v) {
            return p;
        }
        let mid = (he.pos[next as usize].coords + he.pos[prev as usize].coords) * 0.5;
        return Point3::from(mid);
    }
    he.neighbours(v, ring);
    if ring.is_empty() {
        return p;
    }
    let c = ring
        .iter()
        .fold(Vector3::zeros(), |s, &w| s + he.pos[w as usize].coords)
        / ring.len() as f64;
    let mut n = Vector3::zeros();
    he.around(v, |h| {
        let f = he.face[h as usize];
        if f != NONE {
            n += normals[f as usize];
        }
    });
    let n = n.try_normalize(0.0);
    let d = c - p.coords;
    match n {
        Some(n) => p + (d - n * n.dot(&d)),
        None => p,
    }
}

/// The boundary neighbours of boundary vertex `v`: the tail of the boundary half-edge entering
/// it and the head of the one leaving it.
fn boundary_neighbours(he: &HalfEdges, v: u32) -> [u32; 2] {
    let out = he.out[v as usize];
    [he.from(he.prev[out as usize]), he.to[out as usize]]
}

/// A boundary turns by more than this at a corner (radians; 45 degrees), which remeshing
/// keeps: never relaxed, never collapsed into a neighbour.
const CORNER: f64 = std::f64::consts::FRAC_PI_4;

/// Whether boundary vertex `v` is a corner ([`CORNER`]).
fn is_corner(he: &HalfEdges, v: u32) -> bool {
    let [prev, next] = boundary_neighbours(he, v);
    let p = he.pos[v as usize];
    let (a, b) = (p - he.pos[prev as usize], he.pos[next as usize] - p);
    let cos = a.dot(&b) / (a.norm() * b.norm());
    // a NaN (a zero-length edge) counts as a corner
    !matches!(
        cos.partial_cmp(&CORNER.cos()),
        Some(std::cmp::Ordering::Greater | std::cmp::Ordering::Equal)
    )
}

/// 0 for an inner vertex, 1 on a boundary, 2 at a corner: the survivor of a collapse is the
/// end of higher rank.
fn rank(he: &HalfEdges, v: u32) -> u8 {
    if !he.is_boundary_vertex(v) {
        0
    } else if is_corner(he, v) {
        2
    } else {
        1
    }
}

/// Whether collapsing `x` with the survivor at `p` keeps every edge of the survivor shorter
/// than the split threshold (`hi2`, squared) and turns no face over.
fn collapse_is_good(
    he: &HalfEdges,
    x: u32,
    p: &Point3<f64>,
    hi2: f64,
    ring: &mut Vec<u32>,
) -> bool {
    let (a, b) = (he.from(x), he.to[x as usize]);
    for v in [a, b] {
        he.neighbours(v, ring);
        if ring
            .iter()
            .any(|&w| w != a && w != b && (he.pos[w as usize] - p).norm_squared() > hi2)
        {
            return false;
        }
    }
    // faces of a and b that survive: their normal must not turn by more than 90 degrees
    let doomed = [he.face[x as usize], he.face[he.twin[x as usize] as usize]];
    let mut ok = true;
    for v in [a, b] {
        he.around(v, |h| {
            let f = he.face[h as usize];
            if !ok || f == NONE || doomed.contains(&f) {
                return;
            }
            let before = he.face_normal(f);
            let corners = [
                he.from(h),
                he.to[h as usize],
                he.to[he.next[h as usize] as usize],
            ];
            let q = corners.map(|c| {
                if c == a || c == b {
                    *p
                } else {
                    he.pos[c as usize]
                }
            });
            let after = (q[1] - q[0]).cross(&(q[2] - q[0]));
            if after.dot(&before) <= 0.0 || after.norm_squared() <= 1e-20 * before.norm_squared() {
                ok = false;
            }
        });
    }
    ok
}

/// The vertices of inner edge `h` and of its two faces: its tail a, its head b, the third
/// corner c of its face and d of its twin's.
fn flip_quad(he: &HalfEdges, h: u32) -> [u32; 4] {
    let t = he.twin[h as usize];
    [
        he.from(h),
        he.to[h as usize],
        he.to[he.next[h as usize] as usize],
        he.to[he.next[t as usize] as usize],
    ]
}

/// Whether flipping inner edge `h` brings the valences of its four vertices (`valence`, per
/// vertex) closer to their ideal (6 inside, 4 on a boundary) and turns neither face over.
fn flip_is_good(he: &HalfEdges, h: u32, valence: &[u32]) -> bool {
    let [a, b, c, d] = flip_quad(he, h);
    let ideal = |v: u32| if he.is_boundary_vertex(v) { 4 } else { 6 };
    let dev = |v: u32, delta: i64| {
        let x = valence[v as usize] as i64 + delta - ideal(v);
        x * x
    };
    let before = dev(a, 0) + dev(b, 0) + dev(c, 0) + dev(d, 0);
    let after = dev(a, -1) + dev(b, -1) + dev(c, 1) + dev(d, 1);
    if after >= before {
        return false;
    }
    // the new faces (a, d, c) and (b, c, d) must face the way the old ones did
    let [pa, pb, pc, pd] = [a, b, c, d].map(|v| he.pos[v as usize]);
    let n_old = (pb - pa).cross(&(pc - pa)) + (pa - pb).cross(&(pd - pb));
    let n1 = (pd - pa).cross(&(pc - pa));
    let n2 = (pc - pb).cross(&(pd - pb));
    n1.dot(&n_old) > 0.0 && n2.dot(&n_old) > 0.0 && n1.dot(&n2) > 0.0
}

#[cfg(test)]
mod tests;
