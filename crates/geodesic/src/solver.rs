//! The fast-marching solver: per-mesh precomputation ([`GeodesicSolver::new`]) and per-source
//! fronts ([`GeodesicSolver::solve`]) that reuse a [`Workspace`].
//!
//! See the crate documentation for the algorithm; this module holds the data layout:
//!
//! * every vertex x owns a contiguous run of 16-byte [`Entry`]s: first its *ring*, the
//!   neighbours in fan order, each with its edge length and the dot product at x and 4·area² of
//!   the face to the next entry (cyclically), then its *virtual stencils* from the unfolding of
//!   obtuse corners, as pairs (target, other). About 6 MB for a 50k-vertex mesh with every
//!   obtuse corner split. One pass over the ring reads each neighbour's distance once and
//!   makes at most one heap operation per neighbour (a layout with one record per incident face
//!   visits every neighbour twice, and decreases its key twice about a quarter of the time);
//! * the [`Workspace`] holds the distance array, whose sign bit marks frozen vertices while a
//!   front runs, the list of touched vertices (so a reset costs only what the last front
//!   touched), the priority queue (an indexed 4-ary heap by default, or a bucket queue, see
//!   [`QueueKind`]; the marching loop is generic over it) and the target marks for early
//!   termination.

use keycomp_mesh::{Mesh, Topology, VertexId};

use crate::bucket::BucketQueue;
use crate::error::GeodesicError;
use crate::heap::IndexedHeap;
use crate::queue::FrontQueue;
use crate::unfold::{self, ObtuseStats};

/// Parameters of [`GeodesicSolver`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeodesicParams {
    /// Largest number of neighbouring triangles unfolded, per obtuse corner, while searching for
    /// a vertex that splits the obtuse angle into two acute ones (Kimmel & Sethian 1998,
    /// Section 4). Unitless, default 8. 0 disables unfolding: obtuse corners then rely on the
    /// safe fallback alone (two-point updates accepted only when the characteristic enters the
    /// triangle, edge updates otherwise), which is measurably less accurate on meshes with many
    /// obtuse triangles. Raising it past 8 rarely finds more splits and costs only build time.
    pub max_unfold_steps: usize,
    /// Obtuse corners whose angle is below this (degrees) are left to the safe fallback instead
    /// of being split. Default 90 (split every obtuse corner). Every split adds four virtual
    /// stencils to visit per front; raising it trades accuracy for speed (measured in the crate
    /// documentation: 110° makes a `nefertiti.obj` front about 20 % faster and raises the error
    /// on a jittered sphere from 0.64 % to 0.69 %).
    pub min_split_angle_degrees: f64,
    /// The priority queue of the front. Default [`QueueKind::Heap`] (exact; the bucket queues
    /// are not faster enough to replace it, see [`QueueKind`] and the crate documentation).
    pub queue: QueueKind,
}

/// The priority queue holding the trial vertices of a front ([`GeodesicParams::queue`]).
/// Measured speed and accuracy of each: crate documentation, *Priority queue*.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum QueueKind {
    /// An indexed 4-ary heap with decrease-key (one entry per vertex). Exact; the default and
    /// the fastest exact queue on our meshes.
    Heap,
    /// Exact monotone bucket queue: buckets 0.02 mean edge lengths wide, the current one kept
    /// sorted. Pops in the heap's order (ties broken by vertex id), and gave bit-identical
    /// distances on every mesh tried, but 13–34 % more cycles per front than the heap.
    Buckets,
    /// Untidy priority queue (Yatziv, Bartesaghi & Sapiro 2006): buckets of `width` mean edge
    /// lengths (unitless, > 0), popped in no order within a bucket. A vertex may then freeze
    /// before another vertex of its bucket with a smaller value, an ordering error below the
    /// width, so the front is no longer exactly monotone. At `width` 0.1: 11–13 % fewer
    /// instructions and 0–10 % fewer cycles per front than the heap; mean relative errors
    /// against the oracles unchanged to four digits except the flat grid (0.5238 → 0.5250 %);
    /// per-vertex differences from the heap's distances of 3·10⁻⁶–2·10⁻⁵ on average, 7 % at
    /// worst (KIDS `0001.null.0.off`). At 0.2 the flat grid reaches 0.5403 % and the worst
    /// difference 28 %; at 0.5 the errors grow past +0.05 percentage points.
    Untidy {
        /// Bucket width in mean edge lengths; 0.1 is a sensible value. The buckets widen when
        /// the longest (virtual) edge exceeds about 16,000 widths, as the array of buckets is
        /// capped at 2¹⁴.
        width: f64,
    },
}

/// Bucket width of [`QueueKind::Buckets`], in mean edge lengths (only the speed depends on it:
/// 0.005–0.02 were within noise of each other, 0.05 and wider slower as buckets hold more
/// entries to sort).
const EXACT_BUCKET_WIDTH: f64 = 0.02;

impl Default for GeodesicParams {
    fn default() -> Self {
        GeodesicParams {
            max_unfold_steps: 8,
            min_split_angle_degrees: 90.0,
            queue: QueueKind::Heap,
        }
    }
}

/// One entry of a vertex x's ring: the neighbour `id` at distance `l = |x − id|`, and the wedge
/// (x, id, next) between it and the next entry of the ring (cyclically): `dot_x = (id − x)·(next −
/// x)` and `det` = 4·area² of that face, `det = 0` where no face joins the two entries (the
/// two-point update is then never used). In the virtual part of a run, entries come in pairs
/// (target, other) describing one virtual stencil. 16 bytes.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Entry {
    id: u32,
    l: f32,
    dot_x: f32,
    det: f32,
}

/// Geodesic distances on one triangle mesh by fast marching, built once and run from many
/// sources (see the crate documentation for the method).
///
/// Building costs O(|F| + obtuse corners × [`GeodesicParams::max_unfold_steps`]); each
/// [`GeodesicSolver::solve`] costs O(n log n) and allocates nothing once its [`Workspace`] has
/// grown. The solver is `Sync`: share it between threads, one workspace per thread.
#[derive(Debug, Clone)]
pub struct GeodesicSolver {
    n: usize,
    /// `runs[x] = [start, virtual_start]`: vertex x's ring is `entries[start..virtual_start]`,
    /// its virtual stencils (pairs of entries) `entries[virtual_start..end]` with
    /// `end = runs[x + 1][0]`.
    runs: Vec<[u32; 2]>,
    entries: Vec<Entry>,
    obtuse: ObtuseStats,
    diagonal: f64,
    queue: QueueKind,
    /// Mean length of the mesh's edges (ring entries), the unit of bucket widths.
    mean_edge: f64,
    /// Largest step a front can take above a frozen value: the longest edge or virtual edge.
    max_step: f64,
}

/// Reusable per-thread scratch memory for [`GeodesicSolver::solve`]; after a solve it holds the
/// distances of that front.
#[derive(Debug, Clone, Default)]
pub struct Workspace {
    /// Distances; while a front runs, a frozen vertex stores −d (sign bit set, −0.0 for the
    /// source). Between solves every entry is ≥ 0 or +∞.
    dist: Vec<f64>,
    touched: Vec<u32>,
    heap: IndexedHeap,
    buckets: BucketQueue,
    /// (bucket width, span, exact) the bucket queue is configured for.
    bucket_config: Option<(f64, f64, bool)>,
    is_target: Vec<bool>,
}

impl Workspace {
    /// An empty workspace; it grows to the mesh size on first use.
    pub fn new() -> Workspace {
        Workspace::default()
    }

    /// Distance of `v` from the last front's source: final for every vertex the front froze,
    /// +∞ for vertices it did not reach (other connected pieces, unreferenced vertices, or
    /// vertices beyond the last target when the front stopped early). Out-of-range ids give +∞.
    #[inline]
    pub fn distance(&self, v: VertexId) -> f64 {
        self.dist.get(v as usize).copied().unwrap_or(f64::INFINITY)
    }

    /// All distances of the last front, indexed by vertex id (see [`Workspace::distance`]).
    pub fn distances(&self) -> &[f64] {
        &self.dist
    }

    /// Vertices the last front touched, in the order it first gave them a tentative value (after
    /// an early stop this includes vertices left unfrozen, which now hold +∞).
    pub fn reached(&self) -> &[VertexId] {
        &self.touched
    }

    fn prepare(&mut self, n: usize, queue: QueueConfig) {
        if self.dist.len() != n {
            self.dist.clear();
            self.dist.resize(n, f64::INFINITY);
            self.is_target.clear();
            self.is_target.resize(n, false);
        } else {
            for &v in &self.touched {
                self.dist[v as usize] = f64::INFINITY;
            }
        }
        self.touched.clear();
        match queue {
            QueueConfig::Heap => self.heap.reset(n),
            QueueConfig::Buckets(config) => {
                if self.bucket_config == Some(config) {
                    self.buckets.reset();
                } else {
                    let (width, span, exact) = config;
                    self.buckets.configure(width, span, exact);
                    self.bucket_config = Some(config);
                }
            }
        }
    }
}

/// The queue a front uses, resolved for one mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
enum QueueConfig {
    Heap,
    /// (bucket width, span, exact) in mesh units.
    Buckets((f64, f64, bool)),
}

/// Planar-front update of a target t from two frozen vertices x (distance `dx`) and o (`d_o`)
/// of one triangle, given `aa = |xt|²`, `c2 = |xo|²`, the dot product `dot_x = (t − x)·(o − x)`
/// and `det` = 4·area². Returns `dx + s` with s the larger root of
/// `c2 s² − 2 u dot_x s + (u² aa − det) = 0` (u = d_o − dx), or +∞ when the front cannot reach
/// t through the edge xo: no real root, a degenerate triangle, a non-causal value (below dx or
/// d_o), or an upwind direction outside the triangle.
///
/// Branch-free (whether the update is valid is close to a coin flip, so a branch on it would be
/// mispredicted about half the time): when `c2 − u² < 0` the square root is NaN and every test
/// below fails.
#[inline(always)]
pub(crate) fn two_point_update(dx: f64, d_o: f64, aa: f64, c2: f64, dot_x: f64, det: f64) -> f64 {
    let u = d_o - dx;
    let disc = c2 - u * u;
    let s = (u * dot_x + (det * disc).sqrt()) / c2;
    // dot products at t and o: (x − t)·(o − t) = aa − dot_x, (x − o)·(t − o) = c2 − dot_x
    let (dot_t, dot_o) = (aa - dot_x, c2 - dot_x);
    // causality: t >= dx, t >= d_o; upwind direction -n = λ(x - t) + μ(o - t), λ, μ >= 0.
    // A characteristic exactly along an edge may fail by rounding; the edge update the caller
    // also makes is then exact. (`&` rather than `&&`: no branch.)
    let valid = (disc > 0.0)
        & (det > 0.0)
        & (s >= 0.0)
        & (s >= u)
        & (aa * u <= dot_x * s)
        & (dot_o * s + dot_t * u >= 0.0);
    if valid { dx + s } else { f64::INFINITY }
}

/// Lowers the tentative distance of `v` to `cand` if that is an improvement (never for a frozen
/// vertex, whose stored value is negative).
#[inline(always)]
fn relax<Q: FrontQueue>(
    v: u32,
    cand: f64,
    dist: &mut [f64],
    touched: &mut Vec<u32>,
    queue: &mut Q,
) {
    let d = dist[v as usize];
    if cand < d {
        if d == f64::INFINITY {
            touched.push(v);
        }
        dist[v as usize] = cand;
        queue.push(cand, v);
    }
}

impl GeodesicSolver {
    /// Builds the solver with default [`GeodesicParams`].
    ///
    /// Errors: `topo` not built from `mesh`, a face index out of range, a non-finite corner.
    pub fn new(mesh: &Mesh, topo: &Topology) -> Result<GeodesicSolver, GeodesicError> {
        GeodesicSolver::with_params(mesh, topo, GeodesicParams::default())
    }

    /// Builds the solver: per-face edge lengths, corner dot products and areas, the per-vertex
    /// wedge runs, and the virtual stencils splitting obtuse corners.
    pub fn with_params(
        mesh: &Mesh,
        topo: &Topology,
        params: GeodesicParams,
    ) -> Result<GeodesicSolver, GeodesicError> {
        let n = mesh.num_vertices();
        if topo.num_vertices() != n {
            return Err(GeodesicError::TopologyMismatch {
                mesh: n,
                topology: topo.num_vertices(),
            });
        }
        let geo = unfold::FaceGeometry::compute(mesh)?;

        let (stencils, obtuse) = unfold::obtuse_stencils(
            mesh,
            topo,
            &geo,
            params.max_unfold_steps,
            params.min_split_angle_degrees,
        );
        let mut stencil_count = vec![0u32; n + 1];
        for st in &stencils {
            stencil_count[st.owner as usize + 1] += 1;
        }
        for i in 0..n {
            stencil_count[i + 1] += stencil_count[i];
        }
        let mut order = vec![0u32; stencils.len()];
        let mut fill = stencil_count.clone();
        for (i, st) in stencils.iter().enumerate() {
            let slot = &mut fill[st.owner as usize];
            order[*slot as usize] = i as u32;
            *slot += 1;
        }

        let mut runs = Vec::with_capacity(n + 1);
        let mut entries = Vec::with_capacity(2 * mesh.num_faces() + 2 * stencils.len());
        let mut link = Link::default();
        for v in 0..n as VertexId {
            let start = entries.len() as u32;
            link.build(mesh, topo, &geo, v, &mut entries);
            runs.push([start, entries.len() as u32]);
            let (a, b) = (
                stencil_count[v as usize] as usize,
                stencil_count[v as usize + 1] as usize,
            );
            for &i in &order[a..b] {
                let st = &stencils[i as usize];
                entries.push(Entry {
                    id: st.target,
                    l: st.l_xt as f32,
                    dot_x: st.dot_x as f32,
                    det: st.det as f32,
                });
                entries.push(Entry {
                    id: st.other,
                    l: st.l_xo as f32,
                    dot_x: 0.0,
                    det: 0.0,
                });
            }
        }
        runs.push([entries.len() as u32; 2]);

        let (mut sum, mut count, mut max_step) = (0.0f64, 0usize, 0.0f64);
        for w in runs.windows(2) {
            for e in &entries[w[0][0] as usize..w[0][1] as usize] {
                if e.l > 0.0 {
                    sum += e.l as f64;
                    count += 1;
                }
            }
            for e in &entries[w[0][0] as usize..w[1][0] as usize] {
                max_step = max_step.max(e.l as f64);
            }
        }
        let mean_edge = if count > 0 { sum / count as f64 } else { 0.0 };

        Ok(GeodesicSolver {
            n,
            runs,
            entries,
            obtuse,
            diagonal: geo.diagonal,
            queue: params.queue,
            mean_edge,
            max_step,
        })
    }

    /// Number of vertices of the mesh.
    pub fn num_vertices(&self) -> usize {
        self.n
    }

    /// How obtuse triangles were handled.
    pub fn obtuse_stats(&self) -> ObtuseStats {
        self.obtuse
    }

    /// Bounding-box diagonal of the vertices faces refer to (a length scale for the mesh).
    pub fn diagonal(&self) -> f64 {
        self.diagonal
    }

    /// A workspace sized for this mesh.
    pub fn workspace(&self) -> Workspace {
        let mut ws = Workspace::new();
        ws.prepare(self.n, self.queue_config());
        ws
    }

    /// The queue of [`GeodesicParams::queue`] in mesh units. The span covers the longest step
    /// with a relative margin far above the `f32` rounding of the geometry (a two-point update
    /// `s` exceeds the edge length by at most a few ulps).
    fn queue_config(&self) -> QueueConfig {
        let span = self.max_step * 1.01;
        match self.queue {
            QueueKind::Heap => QueueConfig::Heap,
            QueueKind::Buckets => {
                QueueConfig::Buckets((EXACT_BUCKET_WIDTH * self.mean_edge, span, true))
            }
            QueueKind::Untidy { width } => {
                QueueConfig::Buckets((width * self.mean_edge, span, false))
            }
        }
    }

    /// Runs a front from `source` over its whole connected piece; the distances are then in
    /// `ws` ([`Workspace::distance`], [`Workspace::distances`]).
    pub fn solve(&self, source: VertexId, ws: &mut Workspace) -> Result<(), GeodesicError> {
        self.solve_until(source, &[], ws)
    }

    /// Runs a front from `source` and stops as soon as every vertex of `targets` is frozen (an
    /// empty `targets` runs the whole connected piece). Targets the front cannot reach make it
    /// run its whole piece. Afterwards every vertex the front froze, the targets among them,
    /// holds its final distance in `ws`; every other vertex holds +∞.
    pub fn solve_until(
        &self,
        source: VertexId,
        targets: &[VertexId],
        ws: &mut Workspace,
    ) -> Result<(), GeodesicError> {
        self.solve_bounded(source, targets, f64::INFINITY, ws)
            .map(|_| ())
    }

    /// Runs a front from `source` and stops before freezing the first vertex farther than
    /// `max_distance`: afterwards every vertex within `max_distance` holds its final distance in
    /// `ws` and every other vertex +∞. Returns whether the front covered its whole connected
    /// piece (nothing was beyond `max_distance`), so that +∞ then means another piece. The
    /// cost is that of the vertices reached, which makes fronts for small neighbourhoods cheap.
    /// A NaN or +∞ `max_distance` runs the whole piece.
    pub fn solve_within(
        &self,
        source: VertexId,
        max_distance: f64,
        ws: &mut Workspace,
    ) -> Result<bool, GeodesicError> {
        self.solve_bounded(source, &[], max_distance, ws)
    }

    /// [`GeodesicSolver::solve_until`] and [`GeodesicSolver::solve_within`] together: stops at
    /// the last target or beyond `limit`, whichever comes first; returns whether the front ran
    /// its whole piece.
    fn solve_bounded(
        &self,
        source: VertexId,
        targets: &[VertexId],
        limit: f64,
        ws: &mut Workspace,
    ) -> Result<bool, GeodesicError> {
        self.check(source)?;
        for &t in targets {
            self.check(t)?;
        }
        let queue = self.queue_config();
        ws.prepare(self.n, queue);
        let mut remaining = 0usize;
        for &t in targets {
            let mark = &mut ws.is_target[t as usize];
            if !*mark {
                *mark = true;
                remaining += 1;
            }
        }
        let early = remaining > 0;
        let Workspace {
            dist,
            touched,
            heap,
            buckets,
            is_target,
            ..
        } = ws;
        let mut front = Front {
            dist,
            touched,
            is_target,
        };
        // one loop per queue type (monomorphised: no dispatch per operation)
        let complete = match queue {
            QueueConfig::Heap => self.march(source, &mut front, heap, early, remaining, limit),
            QueueConfig::Buckets(_) => {
                self.march(source, &mut front, buckets, early, remaining, limit)
            }
        };
        for &t in targets {
            ws.is_target[t as usize] = false;
        }
        // unfreeze (clear the sign bit); vertices left in the heap after an early stop get +∞
        for &v in &ws.touched {
            let d = &mut ws.dist[v as usize];
            *d = if d.is_sign_negative() {
                -*d
            } else {
                f64::INFINITY
            };
        }
        Ok(complete)
    }

    /// Distances from `source` to every vertex (+∞ where unreachable), in a new vector.
    pub fn distance_field(&self, source: VertexId) -> Result<Vec<f64>, GeodesicError> {
        let mut ws = self.workspace();
        self.solve(source, &mut ws)?;
        Ok(ws.dist)
    }

    fn check(&self, v: VertexId) -> Result<(), GeodesicError> {
        if (v as usize) < self.n {
            Ok(())
        } else {
            Err(GeodesicError::VertexOutOfRange {
                vertex: v,
                vertices: self.n,
            })
        }
    }

    /// The fast-marching loop. Frozen vertices carry a negative (sign-bit) distance.
    fn march<Q: FrontQueue>(
        &self,
        source: VertexId,
        front: &mut Front<'_>,
        queue: &mut Q,
        early: bool,
        mut remaining: usize,
        limit: f64,
    ) -> bool {
        let Front {
            dist,
            touched,
            is_target,
        } = front;
        dist[source as usize] = 0.0;
        touched.push(source);
        queue.push(0.0, source);

        while let Some((dx, x)) = queue.pop() {
            let xi = x as usize;
            // a stale entry: the vertex has a lower value since, or is frozen (sign bit set)
            if dist[xi].to_bits() != dx.to_bits() {
                continue;
            }
            if dx > limit {
                return false;
            }
            dist[xi] = -dx;
            if early && is_target[xi] {
                remaining -= 1;
                if remaining == 0 {
                    return false;
                }
            }
            let [a, m] = self.runs[xi];
            let b = self.runs[xi + 1][0];
            let ring = &self.entries[a as usize..m as usize];
            if let Some(last) = ring.last() {
                let mut prev = last;
                let mut d_prev = dist[last.id as usize];
                for (i, cur) in ring.iter().enumerate() {
                    let next = ring.get(i + 1).unwrap_or(&ring[0]);
                    let ci = cur.id as usize;
                    let dc = dist[ci];
                    if !dc.is_sign_negative() {
                        let l = cur.l as f64;
                        let aa = l * l;
                        let mut cand = dx + l;
                        if d_prev.is_sign_negative() {
                            let lo = prev.l as f64;
                            cand = cand.min(two_point_update(
                                dx,
                                -d_prev,
                                aa,
                                lo * lo,
                                prev.dot_x as f64,
                                prev.det as f64,
                            ));
                        }
                        let dn = dist[next.id as usize];
                        if dn.is_sign_negative() {
                            let lo = next.l as f64;
                            cand = cand.min(two_point_update(
                                dx,
                                -dn,
                                aa,
                                lo * lo,
                                cur.dot_x as f64,
                                cur.det as f64,
                            ));
                        }
                        relax(cur.id, cand, dist, touched, queue);
                    }
                    prev = cur;
                    d_prev = dc;
                }
            }
            for pair in self.entries[m as usize..b as usize].chunks_exact(2) {
                let (t, o) = (&pair[0], &pair[1]);
                let (ti, oi) = (t.id as usize, o.id as usize);
                let (dt, d_o) = (dist[ti], dist[oi]);
                if dt.is_sign_negative() || !d_o.is_sign_negative() {
                    continue;
                }
                let (l_xt, l_xo) = (t.l as f64, o.l as f64);
                let cand = two_point_update(
                    dx,
                    -d_o,
                    l_xt * l_xt,
                    l_xo * l_xo,
                    t.dot_x as f64,
                    t.det as f64,
                );
                relax(t.id, cand, dist, touched, queue);
            }
        }
        true
    }
}

/// The per-front arrays of a [`Workspace`] the marching loop works on (the queue is passed
/// separately, as the loop is generic over it).
struct Front<'a> {
    dist: &'a mut [f64],
    touched: &'a mut Vec<u32>,
    is_target: &'a [bool],
}

/// Scratch for decomposing the link of a vertex (the graph whose edges are the opposite edges
/// (a, b) of its incident faces) into paths, laid out as one cyclic ring of [`Entry`].
#[derive(Debug, Default)]
struct Link {
    /// Link edges (a, b, face).
    edges: Vec<(u32, u32, u32)>,
    used: Vec<bool>,
    /// (link vertex, edge index) for both ends of every edge, sorted: the edges at a link vertex
    /// are one run.
    incidences: Vec<(u32, u32)>,
    /// Per run of `incidences` (one per distinct link vertex): its start, and its number of
    /// unused edges.
    runs: Vec<(u32, u32)>,
    path: Vec<(u32, Option<u32>)>,
}

impl Link {
    /// The run of `incidences` of link vertex `w` (an index into `runs`).
    fn run_of(&self, w: u32) -> usize {
        self.runs
            .binary_search_by(|&(start, _)| self.incidences[start as usize].0.cmp(&w))
            .unwrap_or(0)
    }

    /// An unused edge at link vertex `w`, if any.
    fn unused_edge_at(&self, w: u32) -> Option<usize> {
        let r = self.run_of(w);
        let start = self.runs[r].0 as usize;
        let end = self
            .runs
            .get(r + 1)
            .map_or(self.incidences.len(), |&(s, _)| s as usize);
        self.incidences[start..end]
            .iter()
            .map(|&(_, e)| e as usize)
            .find(|&e| !self.used[e])
    }

    /// Marks edge `k` used.
    fn take(&mut self, k: usize) {
        self.used[k] = true;
        let (a, b, _) = self.edges[k];
        for w in [a, b] {
            let r = self.run_of(w);
            self.runs[r].1 -= 1;
        }
    }

    /// Appends the ring of v: every neighbour at least once, and every non-degenerate incident
    /// face (v, a, b) exactly once as the wedge between two consecutive entries a, b. A closed
    /// fan (interior manifold vertex) gives one entry per neighbour; a boundary fan is an open
    /// path closed by a wedge with `det = 0`; other links (non-manifold, several fans) are
    /// concatenated paths joined by such empty wedges, repeating a neighbour where needed.
    /// O(d log d) for d incident faces.
    fn build(
        &mut self,
        mesh: &Mesh,
        topo: &Topology,
        geo: &unfold::FaceGeometry,
        v: VertexId,
        out: &mut Vec<Entry>,
    ) {
        let pos = |w: u32| mesh.positions[w as usize];
        let length = |w: u32| (pos(w) - pos(v)).norm() as f32;
        self.edges.clear();
        let ring_start = out.len();
        for &f in topo.faces_of(v) {
            let face = mesh.faces[f as usize];
            let Some(i) = face.iter().position(|&w| w == v) else {
                continue;
            };
            let (a, b) = (face[(i + 1) % 3], face[(i + 2) % 3]);
            if a == v || b == v || a == b {
                // repeated index: no wedge, but keep edge updates to its other corners
                for w in [a, b] {
                    if w != v {
                        out.push(Entry {
                            id: w,
                            l: length(w),
                            dot_x: 0.0,
                            det: 0.0,
                        });
                    }
                }
                continue;
            }
            self.edges.push((a, b, f));
        }
        self.used.clear();
        self.used.resize(self.edges.len(), false);
        self.incidences.clear();
        for (k, &(a, b, _)) in self.edges.iter().enumerate() {
            self.incidences.push((a, k as u32));
            self.incidences.push((b, k as u32));
        }
        self.incidences.sort_unstable();
        self.runs.clear();
        for (i, &(w, _)) in self.incidences.iter().enumerate() {
            match self.runs.last_mut() {
                Some(last) if self.incidences[last.0 as usize].0 == w => last.1 += 1,
                _ => self.runs.push((i as u32, 1)),
            }
        }
        let mut remaining = self.edges.len();
        while remaining > 0 {
            // start at a link vertex with an odd number of unused edges (a path end) if there is
            // one, so that a boundary fan is one path; otherwise anywhere (a closed fan)
            let odd = self.runs.iter().find(|&&(_, count)| count % 2 == 1);
            let any = self.runs.iter().find(|&&(_, count)| count > 0);
            let Some(&(start, _)) = odd.or(any) else {
                break;
            };
            let mut cur = self.incidences[start as usize].0;
            // walk: path of (vertex, face joining it to the next vertex)
            self.path.clear();
            loop {
                let Some(k) = self.unused_edge_at(cur) else {
                    self.path.push((cur, None));
                    break;
                };
                self.take(k);
                remaining -= 1;
                let (a, b, f) = self.edges[k];
                self.path.push((cur, Some(f)));
                cur = if a == cur { b } else { a };
            }
            // a closed walk that is the whole link becomes a closed ring without repeating its
            // start; otherwise the path's end joins the next path by an empty wedge
            let closed = self.path.len() > 2 && self.path[0].0 == cur;
            if closed && remaining == 0 && out.len() == ring_start {
                self.path.pop();
            }
            for &(w, f) in &self.path {
                let (dot_x, det) = match f {
                    Some(f) => {
                        let face = mesh.faces[f as usize];
                        let i = face.iter().position(|&u| u == v).unwrap_or(0);
                        let g = &geo.faces[f as usize];
                        (g.dot[i] as f32, g.det as f32)
                    }
                    None => (0.0, 0.0),
                };
                out.push(Entry {
                    id: w,
                    l: length(w),
                    dot_x,
                    det,
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_point_update_on_an_equilateral_triangle() {
        // unit equilateral: every corner dot 1/2, 4·area² = 3/4
        let t = two_point_update(0.0, 0.0, 1.0, 1.0, 0.5, 0.75);
        assert!((t - 0.75f64.sqrt()).abs() < 1e-12);
        // front running along x→o: characteristic grazes the edge, rejected
        assert_eq!(
            two_point_update(0.0, 1.0, 1.0, 1.0, 0.5, 0.75),
            f64::INFINITY
        );
        // plane wave n = (0.3, √0.91) with x = (0, 0), o = (1, 0), t = (1/2, √3/2)
        let t = two_point_update(0.0, 0.3, 1.0, 1.0, 0.5, 0.75);
        let exact = 0.5 * 0.3 + 0.75f64.sqrt() * 0.91f64.sqrt();
        assert!((t - exact).abs() < 1e-12, "{t} vs {exact}");
    }

    #[test]
    fn degenerate_triangle_is_rejected() {
        assert_eq!(
            two_point_update(0.0, 0.0, 1.0, 1.0, 1.0, 0.0),
            f64::INFINITY
        );
        // no real root: the other vertex is farther from x than the edge is long
        assert_eq!(
            two_point_update(0.0, 2.0, 1.0, 1.0, 0.5, 0.75),
            f64::INFINITY
        );
    }
}
