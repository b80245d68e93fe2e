//! `sampling`: a real down-sampling by half-edge-collapse decimation, so the surviving vertices
//! keep their null positions and the correspondence is exact.
//!
//! Steps:
//! 1. give every vertex the quadric Q_v = Σ area(f)·(n_f·x + d_f)² over its faces (Garland &
//!    Heckbert, "Surface simplification using quadric error metrics", SIGGRAPH 1997);
//! 2. put every edge in a min-heap keyed by its length (positions never move, so a key never
//!    changes; entries carry per-vertex stamps and are skipped when stale);
//! 3. pop the shortest edge {a, b} and try both half-edge collapses, the one with the smaller
//!    error (Q_a + Q_b)(p_target) first. A collapse u → v (u removed, its faces given to v) is
//!    refused when the edge has more than two faces; when u is on a boundary (or non-manifold)
//!    but the edge is interior; when the link condition fails (the common neighbours of u and v
//!    must be exactly the edge's opposite vertices, Dey et al. 1999), which keeps a manifold
//!    manifold and forbids fold-overs; when both ends have ≤ 3 neighbours (a tetrahedron); or
//!    when a face of u would flip or degenerate (new and old normals at cosine < 0.2);
//! 4. after a collapse u → v: Q_v += Q_u, bump v's stamp and push its edges again; a neighbour
//!    of v with a refused edge gets its stamp bumped and all its edges pushed again (its ring
//!    changed, so the refusal may no longer hold);
//! 5. stop when the referenced-vertex count reaches the target (80, 60, 40, 25, 12 % for
//!    S = 1..5) or no edge can be collapsed.
//!
//! Shortest-edge-first keeps the sampling density roughly uniform, as a resampling should; the
//! quadric only decides which endpoint survives. Complexity O(|V| d² log |V|) with d the
//! vertex degree: about 0.1 s for 60k vertices.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use keycomp_mesh::{Mesh, Point3, VertexId};

use super::{Context, Transformed};
use crate::BenchError;

/// Fraction of the referenced vertices kept per strength 1..=5.
pub(super) const KEEP: [f64; 5] = [0.80, 0.60, 0.40, 0.25, 0.12];
/// Smallest allowed cosine between a face normal before and after a collapse.
const MIN_COS: f64 = 0.2;
/// A face is degenerate when twice its area is below this fraction of its longest squared edge.
const MIN_SHAPE: f64 = 1e-10;

pub(super) fn sampling(ctx: &Context) -> Result<Transformed, BenchError> {
    let referenced = ctx.referenced().len();
    let target = (KEEP[usize::from(ctx.s) - 1] * referenced as f64).round() as usize;
    let faces = decimate(ctx.null, target.max(4));
    ctx.compacted(faces)
}

/// The faces left after decimating `mesh` towards `target` referenced vertices.
pub(super) fn decimate(mesh: &Mesh, target: usize) -> Vec<[VertexId; 3]> {
    let mut d = Decimator::new(mesh);
    d.run(target);
    d.faces
        .iter()
        .zip(&d.face_alive)
        .filter(|(_, a)| **a)
        .map(|(f, _)| *f)
        .collect()
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

/// A heap entry: an edge with its squared length and the stamps of its ends at push time.
#[derive(Clone, Copy)]
struct Candidate {
    len2: f64,
    a: VertexId,
    b: VertexId,
    sa: u32,
    sb: u32,
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
    alive_count: usize,
    stamp: Vec<u32>,
    heap: BinaryHeap<Candidate>,
    /// Set when a collapse of an edge at this vertex was refused.
    refused: Vec<bool>,
    scratch: Vec<(VertexId, u32)>,
    scratch2: Vec<(VertexId, u32)>,
    ring_u: Vec<(VertexId, u32)>,
    ring_v: Vec<(VertexId, u32)>,
}

impl<'a> Decimator<'a> {
    fn new(mesh: &'a Mesh) -> Decimator<'a> {
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
        let mut d = Decimator {
            pos: &mesh.positions,
            faces: mesh.faces.clone(),
            face_alive: vec![true; mesh.num_faces()],
            vfaces,
            quadric,
            alive,
            alive_count,
            stamp: vec![0; n],
            heap: BinaryHeap::new(),
            refused: vec![false; n],
            scratch: Vec::new(),
            scratch2: Vec::new(),
            ring_u: Vec::new(),
            ring_v: Vec::new(),
        };
        let mut ring = Vec::new();
        for v in 0..n as VertexId {
            d.ring(v, &mut ring);
            for &(x, _) in &ring {
                if v < x {
                    d.push(v, x);
                }
            }
        }
        d
    }

    fn push(&mut self, a: VertexId, b: VertexId) {
        let (a, b) = (a.min(b), a.max(b));
        self.heap.push(Candidate {
            len2: (self.pos[a as usize] - self.pos[b as usize]).norm_squared(),
            a,
            b,
            sa: self.stamp[a as usize],
            sb: self.stamp[b as usize],
        });
    }

    /// Neighbours of `v` with the number of live faces on each edge, sorted by id.
    fn ring(&self, v: VertexId, out: &mut Vec<(VertexId, u32)>) {
        out.clear();
        for &f in &self.vfaces[v as usize] {
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
    }

    fn run(&mut self, target: usize) {
        while self.alive_count > target {
            let Some(c) = self.heap.pop() else { break };
            let (a, b) = (c.a as usize, c.b as usize);
            if !self.alive[a] || !self.alive[b] || self.stamp[a] != c.sa || self.stamp[b] != c.sb {
                continue;
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

    fn collapse(&mut self, u: VertexId, v: VertexId) {
        let faces_u = std::mem::take(&mut self.vfaces[u as usize]);
        for &f in &faces_u {
            let face = self.faces[f as usize];
            if face.contains(&v) {
                self.face_alive[f as usize] = false;
                for c in face {
                    if c != u {
                        let list = &mut self.vfaces[c as usize];
                        if let Some(k) = list.iter().position(|&g| g == f) {
                            list.swap_remove(k);
                        }
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
        self.stamp[v as usize] = self.stamp[v as usize].wrapping_add(1);
        for &(w, _) in &ring {
            if self.refused[w as usize] {
                self.refused[w as usize] = false;
                self.stamp[w as usize] = self.stamp[w as usize].wrapping_add(1);
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
                if self.alive[c as usize] && self.vfaces[c as usize].is_empty() {
                    self.alive[c as usize] = false;
                    self.alive_count -= 1;
                }
            }
        }
    }
}
