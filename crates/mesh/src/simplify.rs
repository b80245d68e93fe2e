//! Mesh simplification by half-edge collapse: fewer vertices, each survivor at its exact
//! original position, so every vertex of the simplified mesh *is* a vertex of the input.
//!
//! Used for the down-sampling transformation of the benchmark and for the coarse proxy on which
//! key-component detection can run its fast-marching fronts (the keypoints are *protected*, so
//! they stay vertices of the proxy).
//!
//! # Steps
//!
//! 1. Give every vertex the quadric `Q_v = Σ area(f)·(n_f·x + d_f)²` over its faces (M. Garland
//!    and P. S. Heckbert, "Surface simplification using quadric error metrics", SIGGRAPH 1997).
//! 2. Every edge is *pending*. Sort the edges by length (positions never move, so a key never
//!    changes); edges that become pending again later go to a min-heap, and the next edge is
//!    the shorter of the two heads (ties: smaller ids). A set of the pending edges keeps one
//!    entry per pending edge; entries of edges that lost an end are skipped.
//! 3. Pop the shortest edge {a, b} and try both half-edge collapses, the one with the smaller
//!    error `(Q_a + Q_b)(p_target)` first. A collapse u → v (u removed, its faces given to v) is
//!    refused when u is protected; when the edge has more than two faces; when u is on a
//!    boundary (or non-manifold) but the edge is interior; when the link condition fails (the
//!    common neighbours of u and v must be exactly the edge's opposite vertices: T. K. Dey,
//!    H. Edelsbrunner, S. Guha and D. V. Nekhayev, "Topology preserving edge contraction",
//!    1999), which keeps a manifold manifold and forbids fold-overs; when both ends have ≤ 3
//!    neighbours (a tetrahedron); or when a face of u would flip or degenerate (new and old
//!    normals at cosine < 0.2, or twice the new area below 10⁻¹⁰ of its longest squared edge);
//!    or when u or v has more than 256 faces (not in the paper: a bound on the work per
//!    collapse for meshes with vertices of huge valence).
//! 4. After a collapse u → v: `Q_v += Q_u` and every edge of v is pending again (new
//!    neighbours, new quadric); so is every edge of a neighbour of v with a refused edge (its
//!    ring changed, so the refusal may no longer hold).
//! 5. Stop when the referenced-vertex count reaches the target or no edge can be collapsed.
//!
//! Shortest-edge-first keeps the sampling density roughly uniform, as a resampling should; the
//! quadric only decides which endpoint survives. Complexity O(|V| d² log |V|) with d the vertex
//! degree; about 0.1 s for 60k vertices on one core. The process is deterministic (ties in
//! length are broken by vertex ids).
//!
//! Vertices that no face references are never counted, and a vertex left without faces (which
//! happens only on non-manifold input) stops counting; protected vertices are never collapsed
//! but can, in that non-manifold case, lose all their faces, so [`Simplified::proxy_vertex`]
//! returns an `Option`.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

use crate::{Mesh, Point3, VertexId};

/// Most faces a vertex may have and still be an end of a collapse. Not in Garland & Heckbert:
/// it keeps every collapse's work bounded on meshes with vertices of huge valence (the centre
/// of a fan-triangulated polygon of thousands of corners, a cone's apex), where each collapse
/// next to such a vertex would otherwise scan its whole ring, and the decimation would take
/// time quadratic in the valence. Such a *crowded* vertex stays, and its neighbours still
/// collapse among themselves (a face they remove stays in the crowded vertex's face list,
/// marked dead, instead of being searched for there). Ordinary meshes (valence about 6, below
/// 30 after decimation) never reach the bound.
const MAX_COLLAPSE_FACES: usize = 256;

/// Smallest allowed cosine between a face normal before and after a collapse.
const MIN_COS: f64 = 0.2;
/// A face is degenerate when twice its area is below this fraction of its longest squared edge.
const MIN_SHAPE: f64 = 1e-10;

/// The faces left after decimating `mesh` towards `target` referenced vertices (see the module
/// documentation), as triangles of the input's vertex ids. Vertices in `protected` are never
/// removed; ids that are not vertices of `mesh` are ignored. A `target` at or above the
/// referenced-vertex count returns the faces unchanged.
pub fn decimate(mesh: &Mesh, target: usize, protected: &[VertexId]) -> Vec<[VertexId; 3]> {
    let mut d = Decimator::new(mesh, protected);
    d.run(target);
    d.faces
        .iter()
        .zip(&d.face_alive)
        .filter(|(_, a)| **a)
        .map(|(f, _)| *f)
        .collect()
}

/// A simplified mesh and how its vertices map to the input's.
#[derive(Debug, Clone, PartialEq)]
pub struct Simplified {
    /// The simplified mesh: only the surviving referenced vertices, in increasing order of their
    /// input id, at their input positions.
    pub mesh: Mesh,
    /// `original[i]`: the input vertex id of vertex i of `mesh` (strictly increasing).
    pub original: Vec<VertexId>,
}

impl Simplified {
    /// The vertex of the simplified mesh that is input vertex `v`, if `v` survived.
    /// O(log |V|).
    pub fn proxy_vertex(&self, v: VertexId) -> Option<VertexId> {
        self.original.binary_search(&v).ok().map(|i| i as VertexId)
    }
}

/// Decimates `mesh` towards `target` referenced vertices, never removing a vertex of `protected`
/// ([`decimate`]), and compacts the result: the survivors renumbered in order, with the map back
/// to the input's ids.
pub fn simplify(mesh: &Mesh, target: usize, protected: &[VertexId]) -> Simplified {
    let faces = decimate(mesh, target, protected);
    let n = mesh.num_vertices();
    let mut new_id = vec![VertexId::MAX; n];
    for f in &faces {
        for &v in f {
            new_id[v as usize] = 0;
        }
    }
    let mut positions = Vec::new();
    let mut original = Vec::new();
    for (v, id) in new_id.iter_mut().enumerate() {
        if *id == 0 {
            *id = original.len() as VertexId;
            original.push(v as VertexId);
            positions.push(mesh.positions[v]);
        }
    }
    let faces = faces
        .into_iter()
        .map(|f| f.map(|v| new_id[v as usize]))
        .collect();
    Simplified {
        mesh: Mesh { positions, faces },
        original,
    }
}

/// A symmetric 4×4 quadric stored as its upper triangle:
/// [xx, xy, xz, xw, yy, yz, yw, zz, zw, ww].
#[derive(Clone, Copy, Default)]
struct Quadric([f64; 10]);

impl Quadric {
    fn plane(n: [f64; 4], w: f64) -> Quadric {
        let [a, b, c, d] = n;
        Quadric(
            [
                a * a,
                a * b,
                a * c,
                a * d,
                b * b,
                b * c,
                b * d,
                c * c,
                c * d,
                d * d,
            ]
            .map(|x| x * w),
        )
    }

    fn add(&mut self, o: &Quadric) {
        for (x, y) in self.0.iter_mut().zip(&o.0) {
            *x += y;
        }
    }

    fn sum(&self, o: &Quadric) -> Quadric {
        let mut q = *self;
        q.add(o);
        q
    }

    fn eval(&self, p: &Point3<f64>) -> f64 {
        let q = &self.0;
        let (x, y, z) = (p.x, p.y, p.z);
        q[0] * x * x
            + q[4] * y * y
            + q[7] * z * z
            + q[9]
            + 2.0 * (q[1] * x * y + q[2] * x * z + q[3] * x + q[5] * y * z + q[6] * y + q[8] * z)
    }
}

/// A pending edge with its squared length (`a < b`).
#[derive(Clone, Copy)]
struct Candidate {
    len2: f64,
    a: VertexId,
    b: VertexId,
}

/// The key of edge {a, b}, a < b, in the pending set.
fn edge_key(a: VertexId, b: VertexId) -> u64 {
    (u64::from(a) << 32) | u64::from(b)
}

/// A multiplicative hash for the pending set's `u64` edge keys (the std SipHash is several
/// times slower and needs no protection here: the keys come from the mesh, not an adversary).
#[derive(Default, Clone, Copy)]
struct EdgeHasher(u64);

impl Hasher for EdgeHasher {
    fn finish(&self) -> u64 {
        self.0 ^ (self.0 >> 29)
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0 ^ x ^ (x >> 32)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

impl PartialEq for Candidate {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Candidate {
    /// Reversed, so the max-heap pops the shortest edge (ties: smaller ids).
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .len2
            .total_cmp(&self.len2)
            .then(other.a.cmp(&self.a))
            .then(other.b.cmp(&self.b))
    }
}

struct Decimator<'a> {
    pos: &'a [Point3<f64>],
    faces: Vec<[VertexId; 3]>,
    face_alive: Vec<bool>,
    vfaces: Vec<Vec<u32>>,
    quadric: Vec<Quadric>,
    alive: Vec<bool>,
    protected: Vec<bool>,
    alive_count: usize,
    /// Edges with an entry in `initial` or `heap` (one entry each).
    pending: HashSet<u64, BuildHasherDefault<EdgeHasher>>,
    /// The input's edges, shortest last (popped from the end).
    initial: Vec<Candidate>,
    /// Edges pushed again after a collapse.
    heap: BinaryHeap<Candidate>,
    /// Set when a collapse of an edge at this vertex was refused.
    refused: Vec<bool>,
    /// Dead faces left in each vertex's `vfaces` (only crowded vertices have any).
    dead_in_list: Vec<u32>,
    scratch: Vec<(VertexId, u32)>,
    scratch2: Vec<(VertexId, u32)>,
    ring_u: Vec<(VertexId, u32)>,
    ring_v: Vec<(VertexId, u32)>,
}

impl<'a> Decimator<'a> {
    fn new(mesh: &'a Mesh, protected: &[VertexId]) -> Decimator<'a> {
        let n = mesh.num_vertices();
        let mut vfaces = vec![Vec::new(); n];
        let mut quadric = vec![Quadric::default(); n];
        for (fi, f) in mesh.faces.iter().enumerate() {
            let [a, b, c] = mesh.triangle(fi);
            let cr = (b - a).cross(&(c - a));
            let len = cr.norm();
            let q = if len > 0.0 {
                let nrm = cr / len;
                Quadric::plane([nrm.x, nrm.y, nrm.z, -nrm.dot(&a.coords)], 0.5 * len)
            } else {
                Quadric::default()
            };
            for &v in f {
                vfaces[v as usize].push(fi as u32);
                quadric[v as usize].add(&q);
            }
        }
        let alive: Vec<bool> = vfaces.iter().map(|f| !f.is_empty()).collect();
        let alive_count = alive.iter().filter(|a| **a).count();
        let mut is_protected = vec![false; n];
        for &v in protected {
            if let Some(p) = is_protected.get_mut(v as usize) {
                *p = true;
            }
        }
        let mut d = Decimator {
            pos: &mesh.positions,
            faces: mesh.faces.clone(),
            face_alive: vec![true; mesh.num_faces()],
            vfaces,
            quadric,
            alive,
            protected: is_protected,
            alive_count,
            pending: HashSet::default(),
            initial: Vec::new(),
            heap: BinaryHeap::new(),
            refused: vec![false; n],
            dead_in_list: vec![0; n],
            scratch: Vec::new(),
            scratch2: Vec::new(),
            ring_u: Vec::new(),
            ring_v: Vec::new(),
        };
        // every edge once, from its smaller end, sorted once: most pops then read the next entry
        // of this array instead of sifting through a heap of all the edges (the same order as one
        // heap holding everything, the order of candidates being total)
        let mut edges = Vec::with_capacity(3 * mesh.num_faces() / 2 + 16);
        let mut ring = Vec::new();
        for v in 0..n as VertexId {
            d.ring(v, &mut ring);
            for &(x, _) in &ring {
                if v < x {
                    edges.push(d.candidate(v, x));
                }
            }
        }
        edges.sort_unstable();
        d.pending.reserve(edges.len());
        d.pending
            .extend(edges.iter().map(|c: &Candidate| edge_key(c.a, c.b)));
        d.initial = edges;
        d
    }

    /// The shortest pending candidate (the greatest in [`Candidate`]'s reversed order).
    fn pop(&mut self) -> Option<Candidate> {
        match (self.initial.last(), self.heap.peek()) {
            (Some(a), Some(b)) if b > a => self.heap.pop(),
            (Some(_), _) => self.initial.pop(),
            (None, _) => self.heap.pop(),
        }
    }

    fn candidate(&self, a: VertexId, b: VertexId) -> Candidate {
        let (a, b) = (a.min(b), a.max(b));
        Candidate {
            len2: (self.pos[a as usize] - self.pos[b as usize]).norm_squared(),
            a,
            b,
        }
    }

    /// Makes edge {a, b} pending unless it is already.
    fn push(&mut self, a: VertexId, b: VertexId) {
        let c = self.candidate(a, b);
        if self.pending.insert(edge_key(c.a, c.b)) {
            self.heap.push(c);
        }
    }

    /// Neighbours of `v` with the number of live faces on each edge, sorted by id.
    fn ring(&self, v: VertexId, out: &mut Vec<(VertexId, u32)>) {
        // the ids alone sort faster than (id, count) pairs; the counts come from the runs
        let mut ids = [VertexId::MAX; 64];
        let fs = &self.vfaces[v as usize];
        out.clear();
        if 2 * fs.len() > ids.len() {
            // only a crowded vertex's list holds dead faces
            for &f in fs.iter().filter(|&&f| self.face_alive[f as usize]) {
                for &c in &self.faces[f as usize] {
                    if c != v {
                        out.push((c, 1));
                    }
                }
            }
            out.sort_unstable_by_key(|e| e.0);
            out.dedup_by(|later, kept| {
                if later.0 == kept.0 {
                    kept.1 += 1;
                    true
                } else {
                    false
                }
            });
            return;
        }
        let mut m = 0;
        for &f in fs {
            for &c in &self.faces[f as usize] {
                if c != v {
                    ids[m] = c;
                    m += 1;
                }
            }
        }
        let ids = &mut ids[..m];
        ids.sort_unstable();
        for &c in ids.iter() {
            match out.last_mut() {
                Some(last) if last.0 == c => last.1 += 1,
                _ => out.push((c, 1)),
            }
        }
    }

    fn run(&mut self, target: usize) {
        while self.alive_count > target {
            let Some(c) = self.pop() else { break };
            let (a, b) = (c.a as usize, c.b as usize);
            self.pending.remove(&edge_key(c.a, c.b));
            if !self.alive[a] || !self.alive[b] {
                continue;
            }
            if self.protected[a] && self.protected[b] {
                continue; // neither end may go, now or later
            }
            let q = self.quadric[a].sum(&self.quadric[b]);
            let (first, second) = if q.eval(&self.pos[b]) <= q.eval(&self.pos[a]) {
                ((c.a, c.b), (c.b, c.a))
            } else {
                ((c.b, c.a), (c.a, c.b))
            };
            if !self.try_collapse(first.0, first.1) && !self.try_collapse(second.0, second.1) {
                self.refused[a] = true;
                self.refused[b] = true;
            }
        }
    }

    /// Collapses u into v if allowed; returns whether it did.
    fn try_collapse(&mut self, u: VertexId, v: VertexId) -> bool {
        if self.protected[u as usize] || self.crowded(u) || self.crowded(v) {
            return false;
        }
        let mut nu = std::mem::take(&mut self.ring_u);
        let mut nv = std::mem::take(&mut self.ring_v);
        self.ring(u, &mut nu);
        self.ring(v, &mut nv);
        let ok = self.allowed(u, v, &nu, &nv);
        self.ring_u = nu;
        self.ring_v = nv;
        if ok {
            self.collapse(u, v);
        }
        ok
    }

    fn allowed(
        &self,
        u: VertexId,
        v: VertexId,
        nu: &[(VertexId, u32)],
        nv: &[(VertexId, u32)],
    ) -> bool {
        let Some(&(_, on_edge)) = nu.iter().find(|e| e.0 == v) else {
            return false;
        };
        if on_edge > 2 || nu.iter().any(|e| e.1 > 2) {
            return false;
        }
        let u_boundary = nu.iter().any(|e| e.1 != 2);
        if u_boundary && on_edge == 2 {
            return false;
        }
        if nu.len() <= 3 && nv.len() <= 3 {
            return false;
        }
        // link condition: common neighbours = the opposite vertices of the edge's faces
        let (mut i, mut j, mut common) = (0, 0, 0u32);
        while i < nu.len() && j < nv.len() {
            match nu[i].0.cmp(&nv[j].0) {
                Ordering::Less => i += 1,
                Ordering::Greater => j += 1,
                Ordering::Equal => {
                    common += 1;
                    i += 1;
                    j += 1;
                }
            }
        }
        if common != on_edge {
            return false;
        }
        // no face of u may flip or degenerate
        let pv = self.pos[v as usize];
        for &f in &self.vfaces[u as usize] {
            let face = self.faces[f as usize];
            if face.contains(&v) {
                continue;
            }
            let old = face.map(|c| self.pos[c as usize]);
            let new = face.map(|c| if c == u { pv } else { self.pos[c as usize] });
            let n_old = (old[1] - old[0]).cross(&(old[2] - old[0]));
            let n_new = (new[1] - new[0]).cross(&(new[2] - new[0]));
            let longest = (new[1] - new[0])
                .norm_squared()
                .max((new[2] - new[1]).norm_squared())
                .max((new[0] - new[2]).norm_squared());
            let len_new = n_new.norm();
            if len_new <= MIN_SHAPE * longest
                || n_old.dot(&n_new) < MIN_COS * n_old.norm() * len_new
            {
                return false;
            }
        }
        true
    }

    /// Whether `v` has too many faces to take part in a collapse ([`MAX_COLLAPSE_FACES`]).
    fn crowded(&self, v: VertexId) -> bool {
        self.vfaces[v as usize].len() > MAX_COLLAPSE_FACES
    }

    fn collapse(&mut self, u: VertexId, v: VertexId) {
        let faces_u = std::mem::take(&mut self.vfaces[u as usize]);
        for &f in &faces_u {
            let face = self.faces[f as usize];
            if face.contains(&v) {
                self.face_alive[f as usize] = false;
                for c in face {
                    if c == u {
                        continue;
                    }
                    if self.crowded(c) {
                        // searching its long list would cost its valence: count it dead instead
                        self.dead_in_list[c as usize] += 1;
                        continue;
                    }
                    let list = &mut self.vfaces[c as usize];
                    if let Some(k) = list.iter().position(|&g| g == f) {
                        list.swap_remove(k);
                    }
                }
            } else {
                for c in &mut self.faces[f as usize] {
                    if *c == u {
                        *c = v;
                    }
                }
                self.vfaces[v as usize].push(f);
            }
        }
        self.alive[u as usize] = false;
        self.alive_count -= 1;
        let qu = self.quadric[u as usize];
        self.quadric[v as usize].add(&qu);
        // v's edges changed (new neighbours, new quadric): push them again. A neighbour whose
        // collapse was refused before gets all its edges pushed again too, since its ring changed.
        let mut ring = std::mem::take(&mut self.scratch);
        self.ring(v, &mut ring);
        for &(w, _) in &ring {
            // a crowded neighbour's collapses stay refused: its edges are not pushed again
            if self.refused[w as usize] && !self.crowded(w) {
                self.refused[w as usize] = false;
                let mut wring = std::mem::take(&mut self.scratch2);
                self.ring(w, &mut wring);
                for &(x, _) in &wring {
                    if x != v {
                        self.push(w, x);
                    }
                }
                self.scratch2 = wring;
            }
        }
        for &(w, _) in &ring {
            self.push(v, w);
        }
        self.scratch = ring;
        for f in faces_u {
            // a vertex of a removed face can be left without faces only on non-manifold input
            for c in self.faces[f as usize] {
                if self.alive[c as usize]
                    && self.vfaces[c as usize].len() == self.dead_in_list[c as usize] as usize
                {
                    self.alive[c as usize] = false;
                    self.alive_count -= 1;
                }
            }
        }
    }
}

#[cfg(test)]
#[path = "simplify_tests.rs"]
mod tests;
