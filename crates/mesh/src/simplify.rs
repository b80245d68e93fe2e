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
//! # Cells
//!
//! [`simplify_in_cells`] cuts the work in independent pieces that run in parallel: the
//! referenced vertices are split into `cells` cells by recursive bisection in breadth-first
//! order (the first part of a cell is the vertices fewest edges away from one of its
//! extremities, the last vertex reached from its smallest id), each face goes to the cell of at least two
//! of its vertices (of its second vertex when all three differ), and a vertex whose faces
//! went to more than one cell is a *seam* vertex. Each cell's faces are decimated as above,
//! with the seam vertices frozen (no edge at a seam vertex collapses: a seam vertex's ring is
//! split between cells, so its link condition could not be checked there), towards the
//! cell's share of the target plus its seam vertices. Every collapse in a cell is one that
//! the whole mesh would have allowed in that state, since both ends have all their faces in
//! the cell. A last pass over the joined result, with nothing frozen and the seam vertices'
//! edges as its first candidates (collapses there make the edges around them candidates in
//! turn), takes the seams, still at the input's density, down to the target. The cells are a function of the connectivity
//! alone, so the result does not depend on the number of threads, and the poses of a shape
//! that share its vertex numbering get the same cells (a cut by coordinates would put the
//! seams at different places of the surface in each pose); it differs from [`simplify`]'s,
//! whose single order of collapses spans the whole mesh.
//!
//! Vertices that no face references are never counted, and a vertex left without faces (which
//! happens only on non-manifold input) stops counting; protected vertices are never collapsed
//! but can, in that non-manifold case, lose all their faces, so [`Simplified::proxy_vertex`]
//! returns an `Option`.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

use rayon::prelude::*;

use crate::{Mesh, Point3, Topology, VertexId};

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
    decimate_frozen(mesh, target, protected, &[])
}

/// [`decimate`] where no edge at a vertex of `frozen` collapses (the vertex stays, and so do
/// its edges, though a face of one of its neighbours can still move to it).
fn decimate_frozen(
    mesh: &Mesh,
    target: usize,
    protected: &[VertexId],
    frozen: &[VertexId],
) -> Vec<[VertexId; 3]> {
    let mut d = Decimator::new(mesh, protected, frozen, None);
    d.run(target);
    d.live_faces()
}

/// [`decimate`] in `cells` cells of the connectivity decimated in parallel (rayon), then once
/// more from the seams to take them down to the target (see *Cells* in the module docs).
/// `topo` is `Topology::new(mesh)`. `cells` ≤ 1 is [`decimate`]. The result depends on
/// `cells` but not on the number of threads.
pub fn decimate_in_cells(
    mesh: &Mesh,
    topo: &Topology,
    target: usize,
    protected: &[VertexId],
    cells: usize,
) -> Vec<[VertexId; 3]> {
    let n = mesh.num_vertices();
    let ids: Vec<VertexId> = (0..n as VertexId)
        .filter(|&v| !topo.faces_of(v).is_empty())
        .collect();
    let total = ids.len();
    let cells = cells.min(total / 2).clamp(1, MAX_CELLS);
    if cells == 1 || target >= total {
        return decimate(mesh, target, protected);
    }
    let mut vertex_cell = vec![0u32; n];
    for &v in &ids {
        vertex_cell[v as usize] = cell_tag(0);
    }
    let (mut seen, mut stamp) = (vec![0u32; n], 0);
    bisect(
        topo,
        ids,
        cells as u32,
        0,
        &mut vertex_cell,
        &mut seen,
        &mut stamp,
    );
    let face_cell: Vec<u32> = mesh
        .faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| vertex_cell[v as usize]);
            if a == b || a == c { a } else { b }
        })
        .collect();
    // seam vertices: faces in more than one cell
    const NONE: u32 = u32::MAX;
    const SEAM: u32 = u32::MAX - 1;
    let mut owner = vec![NONE; n];
    for (f, &c) in mesh.faces.iter().zip(&face_cell) {
        for &v in f {
            let o = &mut owner[v as usize];
            if *o == NONE {
                *o = c;
            } else if *o != c {
                *o = SEAM;
            }
        }
    }
    let is_protected = marks(n, protected);
    let mut cell_faces: Vec<Vec<[VertexId; 3]>> = vec![Vec::new(); cells];
    for (f, &c) in mesh.faces.iter().zip(&face_cell) {
        cell_faces[c as usize].push(*f);
    }
    let pieces: Vec<Vec<[VertexId; 3]>> = cell_faces
        .into_par_iter()
        .map(|faces| {
            // the cell's vertices renumbered in increasing order of their ids
            let mut global: Vec<VertexId> = faces.iter().flatten().copied().collect();
            global.sort_unstable();
            global.dedup();
            let local = |v: VertexId| global.binary_search(&v).map_or(0, |i| i as VertexId);
            let sub = Mesh {
                positions: global.iter().map(|&v| mesh.positions[v as usize]).collect(),
                faces: faces.iter().map(|f| f.map(local)).collect(),
            };
            let (mut sub_protected, mut frozen) = (Vec::new(), Vec::new());
            for (i, &v) in global.iter().enumerate() {
                if owner[v as usize] == SEAM {
                    frozen.push(i as VertexId);
                } else if is_protected[v as usize] {
                    sub_protected.push(i as VertexId);
                }
            }
            let inner = global.len() - frozen.len();
            // rounded up, so the cells together keep at least the target
            let share = (target as u128 * inner as u128).div_ceil(total as u128) as usize;
            decimate_frozen(&sub, share + frozen.len(), &sub_protected, &frozen)
                .into_iter()
                .map(|f| f.map(|v| global[v as usize]))
                .collect()
        })
        .collect();
    let joined = Mesh {
        positions: mesh.positions.clone(),
        faces: pieces.concat(),
    };
    let seams: Vec<VertexId> = (0..n as VertexId)
        .filter(|&v| owner[v as usize] == SEAM)
        .collect();
    let mut d = Decimator::new(&joined, protected, &[], Some(&seams));
    d.run(target);
    d.live_faces()
}

/// The tag of the vertices of the cell starting at `first` while it is being split (final cells
/// are numbered below [`MAX_CELLS`], tags from `u32::MAX` down).
fn cell_tag(first: u32) -> u32 {
    u32::MAX - first
}

/// Most cells of [`decimate_in_cells`].
const MAX_CELLS: usize = 1 << 16;

/// Assigns `ids` (increasing, each tagged [`cell_tag`]`(first)` in `vertex_cell`) to cells
/// `first .. first + cells` by recursive bisection in breadth-first order: the first part of a
/// cell is the vertices nearest in edge hops to one of its extremities. The cells follow the
/// connectivity, not the embedding, so the poses of a shape with one vertex numbering get the
/// same cells. `seen` and `stamp` are scratch.
fn bisect(
    topo: &Topology,
    ids: Vec<VertexId>,
    cells: u32,
    first: u32,
    vertex_cell: &mut [u32],
    seen: &mut [u32],
    stamp: &mut u32,
) {
    if cells <= 1 || ids.len() < 2 {
        for &v in &ids {
            vertex_cell[v as usize] = first;
        }
        return;
    }
    let tag = cell_tag(first);
    // an extremity: the last vertex reached from the smallest id; then every vertex of the cell
    // in breadth-first order from it, piece after piece (a cell need not be connected)
    let reached = bfs(topo, ids[0], None, vertex_cell, tag, seen, stamp);
    let extremity = reached.last().copied().unwrap_or(ids[0]);
    let order = bfs(topo, extremity, Some(&ids), vertex_cell, tag, seen, stamp);
    let left = cells / 2;
    let k = (order.len() as u64 * u64::from(left) / u64::from(cells)) as usize;
    let (mut l, mut r) = (order[..k].to_vec(), order[k..].to_vec());
    l.sort_unstable();
    r.sort_unstable();
    for &v in &r {
        vertex_cell[v as usize] = cell_tag(first + left);
    }
    bisect(topo, l, left, first, vertex_cell, seen, stamp);
    bisect(
        topo,
        r,
        cells - left,
        first + left,
        vertex_cell,
        seen,
        stamp,
    );
}

/// Breadth-first order over the vertices tagged `tag`, from `seed`; with `all`, continues from
/// the smallest unreached vertex of `all` until every one is reached.
fn bfs(
    topo: &Topology,
    seed: VertexId,
    all: Option<&[VertexId]>,
    vertex_cell: &[u32],
    tag: u32,
    seen: &mut [u32],
    stamp: &mut u32,
) -> Vec<VertexId> {
    *stamp += 1;
    let s = *stamp;
    let mut order: Vec<VertexId> = Vec::with_capacity(all.map_or(0, <[_]>::len));
    let mut seeds = all.unwrap_or(&[]).iter();
    let mut next = Some(seed);
    while let Some(v) = next {
        seen[v as usize] = s;
        let mut head = order.len();
        order.push(v);
        while head < order.len() {
            let u = order[head];
            head += 1;
            for &w in topo.neighbors(u) {
                if seen[w as usize] != s && vertex_cell[w as usize] == tag {
                    seen[w as usize] = s;
                    order.push(w);
                }
            }
        }
        next = seeds.find(|&&w| seen[w as usize] != s).copied();
    }
    order
}

/// `n` flags, set at the ids of `ids` that are below `n` (others ignored).
fn marks(n: usize, ids: &[VertexId]) -> Vec<bool> {
    let mut m = vec![false; n];
    for &v in ids {
        if let Some(p) = m.get_mut(v as usize) {
            *p = true;
        }
    }
    m
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
    compact(mesh, decimate(mesh, target, protected))
}

/// [`simplify`] by [`decimate_in_cells`]: `cells` cells decimated in parallel, then the seams
/// (see *Cells* in the module docs). `topo` is `Topology::new(mesh)`.
pub fn simplify_in_cells(
    mesh: &Mesh,
    topo: &Topology,
    target: usize,
    protected: &[VertexId],
    cells: usize,
) -> Simplified {
    compact(
        mesh,
        decimate_in_cells(mesh, topo, target, protected, cells),
    )
}

/// The referenced vertices of `faces` renumbered in increasing order, with the map back.
fn compact(mesh: &Mesh, faces: Vec<[VertexId; 3]>) -> Simplified {
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
    /// No edge at a frozen vertex collapses.
    frozen: Vec<bool>,
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
    /// A decimator of `mesh` whose pending edges are, at first, every edge, or with `from`
    /// only the edges at those vertices (later collapses make the edges around them pending,
    /// so the decimation spreads from there).
    fn new(
        mesh: &'a Mesh,
        protected: &[VertexId],
        frozen: &[VertexId],
        from: Option<&[VertexId]>,
    ) -> Decimator<'a> {
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
            protected: marks(n, protected),
            frozen: marks(n, frozen),
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
        match from {
            None => {
                for v in 0..n as VertexId {
                    d.ring(v, &mut ring);
                    edges.extend(ring.iter().filter(|e| v < e.0).map(|e| d.candidate(v, e.0)));
                }
            }
            Some(from) => {
                let from_set = marks(n, from);
                for &v in from.iter().filter(|&&v| (v as usize) < n) {
                    d.ring(v, &mut ring);
                    edges.extend(
                        ring.iter()
                            .filter(|e| v < e.0 || !from_set[e.0 as usize])
                            .map(|e| d.candidate(v, e.0)),
                    );
                }
            }
        }
        edges.sort_unstable();
        edges.dedup();
        d.pending.reserve(edges.len());
        d.pending
            .extend(edges.iter().map(|c: &Candidate| edge_key(c.a, c.b)));
        d.initial = edges;
        d
    }

    /// The faces still alive, in input order.
    fn live_faces(&self) -> Vec<[VertexId; 3]> {
        self.faces
            .iter()
            .zip(&self.face_alive)
            .filter(|(_, a)| **a)
            .map(|(f, _)| *f)
            .collect()
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
            if self.protected[a] && self.protected[b] || self.frozen[a] || self.frozen[b] {
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
