//! A half-edge triangle mesh with the local operations of isotropic remeshing: edge split,
//! edge collapse and edge flip (M. Botsch, L. Kobbelt, M. Pauly, P. Alliez, B. Lévy, *Polygon
//! Mesh Processing*, AK Peters 2010, §2.2 and §6.5).
//!
//! Every half-edge has a twin, also along a boundary (a boundary half-edge has no face), and
//! `next`/`prev` links around its face or, for boundary half-edges, along the boundary loop.
//! A vertex's `out` half-edge leaves it; for a vertex on a boundary it is the boundary one, so
//! that walking around a vertex from `out` meets every face once. Operations mark what they
//! remove as dead; [`HalfEdges::to_mesh`] compacts.
//!
//! Only an edge-manifold, consistently oriented, vertex-manifold mesh can be built
//! ([`HalfEdges::new`]); the operations keep it so (a collapse checks the link condition, T. K.
//! Dey, H. Edelsbrunner, S. Guha, D. V. Nekhayev, "Topology preserving edge contraction",
//! 1999). Complexity: each operation is O(valence); building is O(F·valence), the edges found
//! by their tail ([`Directed`]).

use keycomp_mesh::{Mesh, Point3, Vector3};

use crate::directed::Directed;

/// No element.
pub(crate) const NONE: u32 = u32::MAX;

/// Why a mesh cannot be built as half-edges.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NotManifold {
    /// An edge with more than two faces, or two faces that run along it the same way.
    Edge,
    /// A vertex whose faces form more than one fan.
    Vertex,
}

/// The half-edge mesh (see the [module docs](self)).
#[derive(Debug, Clone)]
pub(crate) struct HalfEdges {
    pub(crate) pos: Vec<Point3<f64>>,
    /// Per vertex: an outgoing half-edge (the boundary one on a boundary), [`NONE`] when dead
    /// or isolated.
    pub(crate) out: Vec<u32>,
    pub(crate) vertex_dead: Vec<bool>,
    /// Per half-edge: the vertex it points to.
    pub(crate) to: Vec<u32>,
    pub(crate) next: Vec<u32>,
    pub(crate) prev: Vec<u32>,
    pub(crate) twin: Vec<u32>,
    /// Per half-edge: its face, [`NONE`] on a boundary.
    pub(crate) face: Vec<u32>,
    pub(crate) edge_dead: Vec<bool>,
    /// Per face: one of its half-edges.
    pub(crate) face_he: Vec<u32>,
    pub(crate) face_dead: Vec<bool>,
}

impl HalfEdges {
    /// The half-edges of `mesh` (vertices no face uses stay isolated and are dropped by
    /// [`HalfEdges::to_mesh`]). Faces with a repeated vertex must have been removed (as the
    /// readers do).
    pub(crate) fn new(mesh: &Mesh) -> Result<HalfEdges, NotManifold> {
        let nf = mesh.faces.len();
        let mut he = HalfEdges {
            pos: mesh.positions.clone(),
            out: vec![NONE; mesh.positions.len()],
            vertex_dead: vec![false; mesh.positions.len()],
            to: Vec::with_capacity(6 * nf),
            next: Vec::with_capacity(6 * nf),
            prev: Vec::with_capacity(6 * nf),
            twin: Vec::with_capacity(6 * nf),
            face: Vec::with_capacity(6 * nf),
            edge_dead: Vec::with_capacity(3 * nf),
            face_he: Vec::with_capacity(nf),
            face_dead: vec![false; nf],
        };
        // half-edge 3·f + k is the directed edge of the same id
        let directed = Directed::new(mesh);
        for (f, t) in mesh.faces.iter().enumerate() {
            let base = he.to.len() as u32;
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                // a second face running along a→b the same way: not edge-manifold
                if a == b || directed.find(a, b) != Some(base + k as u32) {
                    return Err(NotManifold::Edge);
                }
                he.to.push(b);
                he.next.push(base + ((k + 1) % 3) as u32);
                he.prev.push(base + ((k + 2) % 3) as u32);
                he.twin.push(NONE);
                he.face.push(f as u32);
                he.out[a as usize] = base + k as u32;
            }
            he.face_he.push(base);
        }
        // twins; unmatched half-edges get a boundary twin
        let inner = he.to.len() as u32;
        for h in 0..inner {
            if he.twin[h as usize] != NONE {
                continue;
            }
            let (a, b) = (he.from(h), he.to[h as usize]);
            match directed.find(b, a) {
                Some(t) => {
                    he.twin[h as usize] = t;
                    he.twin[t as usize] = h;
                }
                None => {
                    let t = he.to.len() as u32;
                    he.to.push(a);
                    he.next.push(NONE);
                    he.prev.push(NONE);
                    he.twin.push(h);
                    he.face.push(NONE);
                    he.twin[h as usize] = t;
                }
            }
        }
        // boundary loops: the boundary half-edge b→a is followed by the one leaving a; one
        // boundary half-edge may leave a vertex, else its faces are several fans
        let mut boundary_out = vec![NONE; he.pos.len()];
        for t in inner..he.to.len() as u32 {
            let from = he.from(t) as usize;
            if boundary_out[from] != NONE {
                return Err(NotManifold::Vertex);
            }
            boundary_out[from] = t;
        }
        for t in inner..he.to.len() as u32 {
            let n = boundary_out[he.to[t as usize] as usize];
            he.next[t as usize] = n;
            he.prev[n as usize] = t;
        }
        for (v, &b) in boundary_out.iter().enumerate() {
            if b != NONE {
                he.out[v] = b;
            }
        }
        // every vertex's faces must be one fan: the walk from `out` meets all of them
        let mut faces_of = vec![0u32; he.pos.len()];
        for t in &mesh.faces {
            for &v in t {
                faces_of[v as usize] += 1;
            }
        }
        for v in 0..he.pos.len() as u32 {
            if he.out[v as usize] == NONE {
                continue;
            }
            let mut n = 0;
            let ok = he.around(v, |h| {
                if he.face[h as usize] != NONE {
                    n += 1;
                }
            });
            if !ok || n != faces_of[v as usize] {
                return Err(NotManifold::Vertex);
            }
        }
        he.edge_dead = vec![false; he.to.len()];
        Ok(he)
    }

    /// The vertex `h` leaves.
    pub(crate) fn from(&self, h: u32) -> u32 {
        self.to[self.twin_or_prev(h) as usize]
    }

    /// The twin while twins are being built, else the previous half-edge (whose head is the
    /// tail of `h`).
    fn twin_or_prev(&self, h: u32) -> u32 {
        let t = self.twin[h as usize];
        if t != NONE { t } else { self.prev[h as usize] }
    }

    /// Calls `f` with each half-edge leaving `v`, counter-clockwise from `out[v]`; false when
    /// the walk does not come back within 1,000 steps (a broken fan).
    pub(crate) fn around(&self, v: u32, mut f: impl FnMut(u32)) -> bool {
        let start = self.out[v as usize];
        if start == NONE {
            return true;
        }
        let mut h = start;
        for _ in 0..1000 {
            f(h);
            // the next outgoing half-edge: the twin of the one entering v before h (in h's
            // face, or along the boundary for a boundary h)
            h = self.twin[self.prev[h as usize] as usize];
            if h == start {
                return true;
            }
        }
        false
    }

    /// Whether `v` is on a boundary.
    pub(crate) fn is_boundary_vertex(&self, v: u32) -> bool {
        let o = self.out[v as usize];
        o != NONE && self.face[o as usize] == NONE
    }

    /// Whether the edge of `h` is on a boundary.
    pub(crate) fn is_boundary_edge(&self, h: u32) -> bool {
        self.face[h as usize] == NONE || self.face[self.twin[h as usize] as usize] == NONE
    }

    /// The neighbours of `v`, in the order of [`HalfEdges::around`].
    pub(crate) fn neighbours(&self, v: u32, out: &mut Vec<u32>) {
        out.clear();
        self.around(v, |h| out.push(self.to[h as usize]));
    }

    /// The number of neighbours of `v`.
    pub(crate) fn valence(&self, v: u32) -> usize {
        let mut n = 0;
        self.around(v, |_| n += 1);
        n
    }

    /// The half-edge from `a` to `b`, if there is one.
    pub(crate) fn find(&self, a: u32, b: u32) -> Option<u32> {
        let mut found = None;
        self.around(a, |h| {
            if self.to[h as usize] == b {
                found = Some(h);
            }
        });
        found
    }

    /// The squared length of the edge of `h`.
    pub(crate) fn length2(&self, h: u32) -> f64 {
        (self.pos[self.to[h as usize] as usize] - self.pos[self.from(h) as usize]).norm_squared()
    }

    /// The unnormalised normal (twice the area) of face `f`.
    pub(crate) fn face_normal(&self, f: u32) -> Vector3<f64> {
        let h = self.face_he[f as usize];
        let a = self.pos[self.from(h) as usize];
        let b = self.pos[self.to[h as usize] as usize];
        let c = self.pos[self.to[self.next[h as usize] as usize] as usize];
        (b - a).cross(&(c - a))
    }

    /// Makes `out[v]` the boundary half-edge leaving `v` when there is one.
    fn settle_out(&mut self, v: u32) {
        let mut boundary = NONE;
        self.around(v, |h| {
            if self.face[h as usize] == NONE {
                boundary = h;
            }
        });
        if boundary != NONE {
            self.out[v as usize] = boundary;
        }
    }

    fn new_pair(&mut self) -> (u32, u32) {
        let h = self.to.len() as u32;
        for _ in 0..2 {
            self.to.push(NONE);
            self.next.push(NONE);
            self.prev.push(NONE);
            self.face.push(NONE);
            self.edge_dead.push(false);
        }
        self.twin.push(h + 1);
        self.twin.push(h);
        (h, h + 1)
    }

    fn new_face(&mut self) -> u32 {
        self.face_he.push(NONE);
        self.face_dead.push(false);
        (self.face_he.len() - 1) as u32
    }

    /// Makes `a`, `b`, `c` one face `f`, in that order.
    fn link_face(&mut self, f: u32, [a, b, c]: [u32; 3]) {
        for (x, y) in [(a, b), (b, c), (c, a)] {
            self.next[x as usize] = y;
            self.prev[y as usize] = x;
        }
        for h in [a, b, c] {
            self.face[h as usize] = f;
        }
        self.face_he[f as usize] = a;
    }

    fn link(&mut self, x: u32, y: u32) {
        self.next[x as usize] = y;
        self.prev[y as usize] = x;
    }

    /// Splits the edge of `h` at `p`: its one or two faces become two or four. Returns the
    /// new vertex.
    pub(crate) fn split(&mut self, h: u32, p: Point3<f64>) -> u32 {
        let t = self.twin[h as usize];
        let b = self.to[h as usize];
        let m = self.pos.len() as u32;
        self.pos.push(p);
        self.out.push(NONE);
        self.vertex_dead.push(false);
        // h: a→m, t: m→a; g: m→b, gt: b→m
        let (g, gt) = self.new_pair();
        self.to[g as usize] = b;
        self.to[gt as usize] = m;
        self.to[h as usize] = m;
        if self.face[h as usize] != NONE {
            // face (a, b, c): h, h1: b→c, h2: c→a → (a, m, c) and (m, b, c)
            let f = self.face[h as usize];
            let (h1, h2) = (self.next[h as usize], self.prev[h as usize]);
            let c = self.to[h1 as usize];
            let (k, kt) = self.new_pair();
            self.to[k as usize] = c;
            self.to[kt as usize] = m;
            let f2 = self.new_face();
            self.link_face(f, [h, k, h2]);
            self.link_face(f2, [g, h1, kt]);
        } else {
            let n = self.next[h as usize];
            self.link(h, g);
            self.link(g, n);
        }
        if self.face[t as usize] != NONE {
            // face (b, a, d): t, t1: a→d, t2: d→b → (m, a, d) and (b, m, d)
            let f = self.face[t as usize];
            let (t1, t2) = (self.next[t as usize], self.prev[t as usize]);
            let d = self.to[t1 as usize];
            let (j, jt) = self.new_pair();
            self.to[j as usize] = m;
            self.to[jt as usize] = d;
            let f2 = self.new_face();
            self.link_face(f, [t, t1, j]);
            self.link_face(f2, [gt, jt, t2]);
        } else {
            let p = self.prev[t as usize];
            self.link(p, gt);
            self.link(gt, t);
        }
        if self.out[b as usize] == t {
            self.out[b as usize] = gt;
        }
        self.out[m as usize] = g;
        self.settle_out(m);
        m
    }

    /// Whether flipping the edge of `h` keeps the mesh a manifold: an inner edge whose ends
    /// keep at least three neighbours, and whose opposite vertices are not joined yet.
    pub(crate) fn can_flip(&self, h: u32) -> bool {
        if self.is_boundary_edge(h) {
            return false;
        }
        let t = self.twin[h as usize];
        let (a, b) = (self.from(h), self.to[h as usize]);
        let c = self.to[self.next[h as usize] as usize];
        let d = self.to[self.next[t as usize] as usize];
        c != d && self.valence(a) > 3 && self.valence(b) > 3 && self.find(c, d).is_none()
    }

    /// Flips the edge of `h` (see [`HalfEdges::can_flip`]): faces (a, b, c) and (b, a, d)
    /// become (a, d, c) and (b, c, d).
    pub(crate) fn flip(&mut self, h: u32) {
        let t = self.twin[h as usize];
        let (a, b) = (self.from(h), self.to[h as usize]);
        let (h1, h2) = (self.next[h as usize], self.prev[h as usize]);
        let (t1, t2) = (self.next[t as usize], self.prev[t as usize]);
        let (f, g) = (self.face[h as usize], self.face[t as usize]);
        let c = self.to[h1 as usize];
        let d = self.to[t1 as usize];
        self.to[h as usize] = c;
        self.to[t as usize] = d;
        self.link_face(f, [t1, h, h2]);
        self.link_face(g, [h1, t, t2]);
        if self.out[a as usize] == h {
            self.out[a as usize] = t1;
        }
        if self.out[b as usize] == t {
            self.out[b as usize] = h1;
        }
    }

    /// Whether collapsing `h` (its tail into its head) keeps the mesh a manifold: the link
    /// condition (the common neighbours of the two ends are the edge's opposite vertices), no
    /// inner edge between two boundary vertices, no face left with two boundary edges of
    /// which one disappears (an ear), and more than a tetrahedron.
    pub(crate) fn can_collapse(&self, h: u32, scratch: &mut Vec<u32>) -> bool {
        let t = self.twin[h as usize];
        let (a, b) = (self.from(h), self.to[h as usize]);
        let boundary_edge = self.is_boundary_edge(h);
        if !boundary_edge && self.is_boundary_vertex(a) && self.is_boundary_vertex(b) {
            return false;
        }
        let mut opposite = [NONE; 2];
        for (i, x) in [h, t].into_iter().enumerate() {
            if self.face[x as usize] != NONE {
                let n = self.next[x as usize];
                opposite[i] = self.to[n as usize];
                // both other edges of the face on a boundary: the face would dangle
                let p = self.prev[x as usize];
                if self.face[self.twin[n as usize] as usize] == NONE
                    && self.face[self.twin[p as usize] as usize] == NONE
                {
                    return false;
                }
            }
        }
        self.neighbours(a, scratch);
        let mut common = 0;
        let mut ok = true;
        self.around(b, |g| {
            let w = self.to[g as usize];
            if scratch.contains(&w) {
                common += 1;
                if !opposite.contains(&w) {
                    ok = false;
                }
            }
        });
        let expected = opposite.iter().filter(|&&o| o != NONE).count();
        if !ok || common != expected {
            return false;
        }
        // not a tetrahedron or a lone triangle
        let (va, vb) = (scratch.len(), self.valence(b));
        !(va <= 3 && vb <= 3 || boundary_edge && va <= 2 && vb <= 2)
    }

    /// Collapses `h`: its tail is removed, its head moved to `p` and given the tail's faces
    /// (see [`HalfEdges::can_collapse`]). Returns the head.
    pub(crate) fn collapse(&mut self, h: u32, p: Point3<f64>) -> u32 {
        let t = self.twin[h as usize];
        let (a, b) = (self.from(h), self.to[h as usize]);
        // half-edges leaving a or b: those that survive leave b afterwards
        let mut leaving = Vec::with_capacity(16);
        self.around(a, |g| leaving.push(g));
        self.around(b, |g| leaving.push(g));
        let mut touched = vec![b];
        for x in [h, t] {
            if self.face[x as usize] != NONE {
                // face (tail, head, c): x, x1 = next, x2 = prev; the twins of x1 and x2 join
                let (x1, x2) = (self.next[x as usize], self.prev[x as usize]);
                let (y1, y2) = (self.twin[x1 as usize], self.twin[x2 as usize]);
                let c = self.to[x1 as usize];
                self.twin[y1 as usize] = y2;
                self.twin[y2 as usize] = y1;
                if self.out[c as usize] == x2 {
                    self.out[c as usize] = y1;
                }
                touched.push(c);
                self.face_dead[self.face[x as usize] as usize] = true;
                self.edge_dead[x1 as usize] = true;
                self.edge_dead[x2 as usize] = true;
            } else {
                // a boundary half-edge leaves its loop
                let (p, n) = (self.prev[x as usize], self.next[x as usize]);
                self.link(p, n);
            }
        }
        self.edge_dead[h as usize] = true;
        self.edge_dead[t as usize] = true;
        // half-edges that entered a now enter b (their twins leave b through `from`)
        for &g in &leaving {
            let entering = self.twin[g as usize];
            if !self.edge_dead[g as usize] && self.to[entering as usize] == a {
                self.to[entering as usize] = b;
            }
        }
        self.vertex_dead[a as usize] = true;
        self.out[a as usize] = NONE;
        self.out[b as usize] = leaving
            .iter()
            .copied()
            .find(|&g| !self.edge_dead[g as usize])
            .unwrap_or(NONE);
        self.pos[b as usize] = p;
        for v in touched {
            if self.out[v as usize] != NONE {
                self.settle_out(v);
            }
        }
        b
    }

    /// Live vertices.
    pub(crate) fn live_vertices(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.pos.len() as u32)
            .filter(|&v| !self.vertex_dead[v as usize] && self.out[v as usize] != NONE)
    }

    /// Live edges, one half-edge each (the one with the smaller index).
    pub(crate) fn live_edges(&self) -> Vec<u32> {
        (0..self.to.len() as u32)
            .filter(|&h| !self.edge_dead[h as usize] && h < self.twin[h as usize])
            .collect()
    }

    /// The live faces as a mesh of the live vertices (renumbered in their order).
    pub(crate) fn to_mesh(&self) -> Mesh {
        let mut id = vec![NONE; self.pos.len()];
        let mut positions = Vec::new();
        let mut faces = Vec::new();
        for f in 0..self.face_he.len() {
            if self.face_dead[f] {
                continue;
            }
            let h = self.face_he[f];
            let vs = [
                self.from(h),
                self.to[h as usize],
                self.to[self.next[h as usize] as usize],
            ];
            faces.push(vs);
        }
        for t in &faces {
            for &v in t {
                if id[v as usize] == NONE {
                    id[v as usize] = 0;
                }
            }
        }
        for (v, slot) in id.iter_mut().enumerate() {
            if *slot != NONE {
                *slot = positions.len() as u32;
                positions.push(self.pos[v]);
            }
        }
        let faces = faces
            .into_iter()
            .map(|t| t.map(|v| id[v as usize]))
            .collect();
        Mesh { positions, faces }
    }

    /// Checks every invariant (tests): twins, loops, faces of three, heads and tails, out
    /// half-edges leaving their vertex (the boundary one on a boundary).
    #[cfg(test)]
    pub(crate) fn check(&self) -> Result<(), String> {
        for h in 0..self.to.len() as u32 {
            if self.edge_dead[h as usize] {
                continue;
            }
            let t = self.twin[h as usize];
            if self.edge_dead[t as usize] || self.twin[t as usize] != h {
                return Err(format!("twin of {h}"));
            }
            let (n, p) = (self.next[h as usize], self.prev[h as usize]);
            if self.edge_dead[n as usize] || self.prev[n as usize] != h {
                return Err(format!("next of {h}"));
            }
            if self.edge_dead[p as usize] || self.next[p as usize] != h {
                return Err(format!("prev of {h}"));
            }
            if self.to[p as usize] != self.to[t as usize] {
                return Err(format!("tail of {h}"));
            }
            if self.vertex_dead[self.to[h as usize] as usize] {
                return Err(format!("{h} points to a dead vertex"));
            }
            let f = self.face[h as usize];
            if f != NONE {
                if self.face_dead[f as usize] {
                    return Err(format!("{h} in a dead face"));
                }
                if self.next[self.next[self.next[h as usize] as usize] as usize] != h {
                    return Err(format!("face of {h} is not a triangle"));
                }
                if self.face[n as usize] != f {
                    return Err(format!("face of next of {h}"));
                }
            } else if self.face[n as usize] != NONE {
                return Err(format!("boundary loop of {h}"));
            }
        }
        for v in 0..self.pos.len() as u32 {
            let o = self.out[v as usize];
            if self.vertex_dead[v as usize] || o == NONE {
                continue;
            }
            if self.edge_dead[o as usize] || self.from(o) != v {
                return Err(format!("out of {v}"));
            }
            let mut boundary = 0;
            let ok = self.around(v, |h| {
                if self.face[h as usize] == NONE {
                    boundary += 1;
                }
            });
            if !ok || boundary > 1 {
                return Err(format!("fan of {v}"));
            }
            if boundary == 1 && self.face[o as usize] != NONE {
                return Err(format!("out of boundary vertex {v}"));
            }
        }
        for f in 0..self.face_he.len() {
            if !self.face_dead[f] && self.face[self.face_he[f] as usize] != f as u32 {
                return Err(format!("half-edge of face {f}"));
            }
        }
        Ok(())
    }
}
