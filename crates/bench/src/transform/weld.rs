//! `topology`: weld parts of the shape that are close in space but far apart along the surface
//! by adding handles, the SHREC'10 "topology" transformation. Vertices do not move and the map
//! is the identity; only faces change.
//!
//! Steps, for ε = 0.01·L, 0.02·L, …, 0.16·L (L = √area) until 2·S handles are placed:
//! 1. bin the referenced vertices in a hash grid of cell ε; visit them in a seeded random order;
//!    for a vertex u not near an earlier handle, collect the vertices v within ε that face u
//!    across free space: each lies in front of the other's tangent plane by more than 30°
//!    (n_u·(v − u) > ½|v − u|, n_v·(u − v) > ½|v − u|) and the normals are within 60° of
//!    opposite (n_u·n_v < −½); take the nearest, at distance d;
//! 2. flood-fill the mesh from u through vertices within Euclidean distance 2d of u; if the fill
//!    reaches v, v is on u's own part (a crease or a fold); if not, every surface path from u to
//!    v leaves that ball, so their graph-geodesic distance is at least 3d: weld them;
//! 3. among faces A ∋ u and B ∋ v (B's corners all unreached, no shared vertex, no corner in an
//!    earlier handle) take the pair with the closest centroids whose tube is valid: remove A
//!    and B and add the 6 triangles of the prism side joining A's edges to B's reversed edges
//!    (corners paired to minimise squared distances), each nondegenerate and creating no edge
//!    that already exists; every edge of A and B keeps two faces, so a manifold input stays
//!    manifold (its genus grows by one per handle, or two pieces become one);
//! 4. block the vertices within max(d, 0.01·L) of u and of v for later handles.
//!
//! A convex shape (a sphere) has no such pairs and gives [`BenchError::NothingToWeld`]; shapes
//! with limbs (TOSCA, KIDS, FAUST) have plenty at ε ≤ 0.02·L. The grid queries and flood fills
//! of one ε level are capped at 20·|V| visited vertices in total, so the cost is O(|V|) per
//! level plus the grid: O(|V|) overall.

use keycomp_mesh::{Mesh, Topology, VertexId};
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use super::{Context, Transformed, vertex_normals};
use crate::error::BenchError;
use crate::graph::Grid;

/// Handles per strength step.
const HANDLES_STEP: usize = 2;
/// First weld distance ε, in units of L.
const EPS0: f64 = 0.01;
/// Number of ε doublings tried.
const LEVELS: u32 = 5;
/// Flood-fill work per level, in multiples of the vertex count.
const BUDGET: usize = 20;
/// Vertices within max(|uv|, SPREAD·L) of both ends of a handle are not used again.
const SPREAD: f64 = 0.01;
/// Two vertices face each other when each lies in front of the other's tangent plane at more
/// than asin(0.5) = 30° (cosine between the normal and the joining direction above 0.5).
const FACING: f64 = 0.5;
/// A tube triangle is degenerate when twice its area is below this fraction of its longest
/// squared edge.
const MIN_SHAPE: f64 = 1e-6;

pub(super) fn topology(ctx: &Context, rng: &mut ChaCha8Rng) -> Result<Transformed, BenchError> {
    let null = ctx.null;
    let pos = &null.positions;
    let topo = ctx.topology();
    let n = null.num_vertices();
    let needed = HANDLES_STEP * usize::from(ctx.s);
    let mut order = ctx.referenced();
    order.shuffle(rng);
    let mut face_alive = vec![true; null.num_faces()];
    let mut in_handle = vec![false; n];
    let mut blocked = vec![false; n];
    let mut stamp = vec![0u32; n];
    let mut generation = 0u32;
    let mut tubes: Vec<[VertexId; 3]> = Vec::new();
    let mut found = 0;
    let mut stack = Vec::new();
    let normals = vertex_normals(null);
    for level in 0..LEVELS {
        if found >= needed {
            break;
        }
        let eps = EPS0 * f64::from(1u32 << level) * ctx.unit;
        let grid = Grid::new(pos, &order, eps);
        let mut budget = BUDGET * n;
        for &u in &order {
            if found >= needed || budget == 0 {
                break;
            }
            if blocked[u as usize] {
                continue;
            }
            // 1. the nearest vertex within ε facing u across free space
            let pu = pos[u as usize];
            let nu = normals[u as usize];
            let mut nearest: Option<(f64, VertexId)> = None;
            grid.within(pos, &pu, eps, |v| {
                budget = budget.saturating_sub(1);
                let d = pos[v as usize] - pu;
                let len = d.norm();
                if !blocked[v as usize]
                    && len > 0.0
                    && nu.dot(&d) > FACING * len
                    && normals[v as usize].dot(&d) < -FACING * len
                    && nu.dot(&normals[v as usize]) < -FACING
                    && nearest.is_none_or(|b| (len, v) < b)
                {
                    nearest = Some((len, v));
                }
            });
            let Some((d1, v)) = nearest else { continue };
            // 2. flood fill from u inside the ball of radius 2·|uv|: if it reaches v, v is on u's
            //    own part nearby; if not, every surface path leaves the ball: geodesic ≥ 3·|uv|
            let r2 = (2.0 * d1) * (2.0 * d1);
            generation += 1;
            stamp[u as usize] = generation;
            stack.clear();
            stack.push(u);
            while let Some(x) = stack.pop() {
                budget = budget.saturating_sub(1);
                for &w in topo.neighbors(x) {
                    let wi = w as usize;
                    if stamp[wi] != generation && (pos[wi] - pu).norm_squared() <= r2 {
                        stamp[wi] = generation;
                        stack.push(w);
                    }
                }
            }
            if stamp[v as usize] == generation {
                continue;
            }
            // 3. the handle
            let Some((fa, fb, tube)) = handle(null, &topo, u, v, &face_alive, &in_handle, |x| {
                stamp[x as usize] != generation
            }) else {
                continue;
            };
            face_alive[fa] = false;
            face_alive[fb] = false;
            for &c in null.faces[fa].iter().chain(&null.faces[fb]) {
                in_handle[c as usize] = true;
            }
            tubes.extend_from_slice(&tube);
            found += 1;
            // 4. keep later handles away
            for end in [u, v] {
                grid.within(pos, &pos[end as usize], d1.max(SPREAD * ctx.unit), |w| {
                    blocked[w as usize] = true;
                });
            }
        }
    }
    if found < needed {
        return Err(BenchError::NothingToWeld { needed, found });
    }
    let faces = null
        .faces
        .iter()
        .zip(&face_alive)
        .filter(|(_, alive)| **alive)
        .map(|(f, _)| *f)
        .chain(tubes)
        .collect();
    ctx.rebuilt(pos.clone(), faces)
}

type Tube = [[VertexId; 3]; 6];

/// The best valid handle between a face of `u` and a face of `v`: (face A, face B, tube faces).
fn handle(
    mesh: &Mesh,
    topo: &Topology,
    u: VertexId,
    v: VertexId,
    face_alive: &[bool],
    in_handle: &[bool],
    far: impl Fn(VertexId) -> bool,
) -> Option<(usize, usize, Tube)> {
    let usable = |f: u32| {
        face_alive[f as usize]
            && mesh.faces[f as usize]
                .iter()
                .all(|&c| !in_handle[c as usize])
    };
    let centroid = |f: u32| {
        let [a, b, c] = mesh.triangle(f as usize);
        (a.coords + b.coords + c.coords) / 3.0
    };
    let mut pairs: Vec<(f64, u32, u32)> = Vec::new();
    for &fa in topo.faces_of(u) {
        if !usable(fa) {
            continue;
        }
        let a = mesh.faces[fa as usize];
        for &fb in topo.faces_of(v) {
            let b = mesh.faces[fb as usize];
            if !usable(fb) || !b.iter().all(|&c| far(c)) || b.iter().any(|c| a.contains(c)) {
                continue;
            }
            pairs.push(((centroid(fa) - centroid(fb)).norm_squared(), fa, fb));
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    pairs.into_iter().find_map(|(_, fa, fb)| {
        tube(mesh, topo, mesh.faces[fa as usize], mesh.faces[fb as usize])
            .map(|t| (fa as usize, fb as usize, t))
    })
}

/// The prism side joining triangle `a` to triangle `b` (which faces the other way), or `None`
/// if a triangle would be degenerate or an edge would duplicate an existing one.
fn tube(mesh: &Mesh, topo: &Topology, a: [VertexId; 3], b: [VertexId; 3]) -> Option<Tube> {
    let p = |v: VertexId| mesh.positions[v as usize];
    let rev = [b[0], b[2], b[1]];
    let rotation = |k: usize| [rev[k % 3], rev[(k + 1) % 3], rev[(k + 2) % 3]];
    let cost =
        |bb: &[VertexId; 3]| -> f64 { (0..3).map(|i| (p(a[i]) - p(bb[i])).norm_squared()).sum() };
    let bb = (0..3)
        .map(rotation)
        .min_by(|x, y| cost(x).total_cmp(&cost(y)))?;
    let mut out = [[0; 3]; 6];
    for i in 0..3 {
        let j = (i + 1) % 3;
        out[2 * i] = [a[i], a[j], bb[j]];
        out[2 * i + 1] = [a[i], bb[j], bb[i]];
    }
    for f in &out {
        let [x, y, z] = f.map(p);
        let longest = (y - x)
            .norm_squared()
            .max((z - y).norm_squared())
            .max((x - z).norm_squared());
        if (y - x).cross(&(z - x)).norm() <= MIN_SHAPE * longest {
            return None;
        }
    }
    // the new edges a_i–b_i and a_i–b_{i+1} must not exist already
    for i in 0..3 {
        for bj in [bb[i], bb[(i + 1) % 3]] {
            if topo.neighbors(a[i]).binary_search(&bj).is_ok() {
                return None;
            }
        }
    }
    Some(out)
}
