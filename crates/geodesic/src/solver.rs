//! The fast-marching solver: per-mesh precomputation ([`GeodesicSolver::new`]) and per-source
//! fronts ([`GeodesicSolver::solve`]) that reuse a [`Workspace`].
//!
//! See the crate documentation for the algorithm; this module holds the data layout:
//!
//! * every vertex x owns a contiguous run of *wedges*, one per incident face (x, p, q), each
//!   carrying the ids p, q, the edge lengths |xp|, |xq|, the three corner dot products and
//!   4·area² of the face, stored as `f32` (32 bytes a wedge, so a vertex's run is read in a few
//!   cache lines and a 50k-vertex mesh needs about 9 MB);
//! * every vertex also owns a (usually empty) run of *virtual stencils* produced by unfolding
//!   obtuse triangles (see [`crate::unfold`]);
//! * the [`Workspace`] holds the distance array, whose sign bit marks frozen vertices while a
//!   front runs, the list of touched vertices (so a reset costs only what the last front
//!   touched), an indexed 4-ary heap and the target marks for early termination.

use keycomp_mesh::{Mesh, Topology, VertexId};

use crate::GeodesicError;
use crate::heap::IndexedHeap;
use crate::unfold::{self, Stencil};

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
    /// of being split. Default 90 (split every obtuse corner). Barely obtuse corners gain
    /// little from splitting, while every split adds four virtual stencils to visit per front;
    /// raising it trades a little accuracy on slightly obtuse triangles for speed.
    pub min_split_angle_degrees: f64,
}

impl Default for GeodesicParams {
    fn default() -> Self {
        GeodesicParams {
            max_unfold_steps: 8,
            min_split_angle_degrees: 90.0,
        }
    }
}

/// How the solver dealt with the mesh's obtuse triangles, counted when it was built.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ObtuseStats {
    /// Face corners with an angle above 90°.
    pub obtuse_corners: usize,
    /// Obtuse corners split by an unfolded vertex (virtual edge added).
    pub split: usize,
    /// Obtuse corners left to the safe fallback (no splitting vertex within
    /// [`GeodesicParams::max_unfold_steps`], or the unfolding hit a boundary or a non-manifold
    /// edge).
    pub unsplit: usize,
}

/// One incident face (x, p, q) of a vertex x, seen from x.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Wedge {
    p: u32,
    q: u32,
    /// |x − p|.
    l_xp: f32,
    /// |x − q|.
    l_xq: f32,
    /// (p − x)·(q − x).
    dot_x: f32,
    /// (x − p)·(q − p).
    dot_p: f32,
    /// (x − q)·(p − q).
    dot_q: f32,
    /// 4·area² = |(p − x) × (q − x)|²; 0 for a degenerate face (edge updates only).
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
    wedge_offsets: Vec<u32>,
    wedges: Vec<Wedge>,
    stencil_offsets: Vec<u32>,
    stencils: Vec<Stencil>,
    obtuse: ObtuseStats,
    diagonal: f64,
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

    fn prepare(&mut self, n: usize) {
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
        self.heap.reset(n);
    }
}

/// Planar-front update of a target t from two frozen vertices x (distance `dx`) and o (`d_o`)
/// of one triangle, given the corner dot products and 4·area². Returns `dx + s` with s the
/// larger root of `c2 s² − 2 u dot_x s + (u² (dot_x + dot_t) − det) = 0` (u = d_o − dx,
/// c2 = |xo|²), or `None` when the front cannot reach t through the edge xo: no real root,
/// a non-causal value (below dx or d_o), or an upwind direction outside the triangle.
#[inline(always)]
pub(crate) fn two_point_update(
    dx: f64,
    d_o: f64,
    dot_x: f64,
    dot_t: f64,
    dot_o: f64,
    det: f64,
) -> Option<f64> {
    let u = d_o - dx;
    let c2 = dot_x + dot_o;
    let disc = c2 - u * u;
    if !(disc > 0.0 && det > 0.0) {
        return None;
    }
    let s = (u * dot_x + (det * disc).sqrt()) / c2;
    let aa = dot_x + dot_t;
    // causality: t >= dx, t >= d_o; upwind direction -n = λ(x - t) + μ(o - t), λ, μ >= 0.
    // A characteristic exactly along an edge may fail by rounding; the edge update the caller
    // falls back to is then exact. (`&` rather than `&&`: one branch instead of four.)
    let valid = (s >= 0.0) & (s >= u) & (aa * u <= dot_x * s) & (dot_o * s + dot_t * u >= 0.0);
    if !valid {
        return None;
    }
    Some(dx + s)
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

        let mut wedge_offsets = Vec::with_capacity(n + 1);
        wedge_offsets.push(0u32);
        let mut wedges = Vec::with_capacity(3 * mesh.num_faces());
        for v in 0..n as VertexId {
            for &f in topo.faces_of(v) {
                let f = f as usize;
                let face = mesh.faces[f];
                // rotate so that v is corner i, p = i+1, q = i+2 (orientation kept)
                let Some(i) = face.iter().position(|&w| w == v) else {
                    continue;
                };
                let (j, k) = ((i + 1) % 3, (i + 2) % 3);
                let g = &geo.faces[f];
                wedges.push(Wedge {
                    p: face[j],
                    q: face[k],
                    // edge e_i is opposite corner i: |xp| is opposite q (corner k)
                    l_xp: g.len[k] as f32,
                    l_xq: g.len[j] as f32,
                    dot_x: g.dot[i] as f32,
                    dot_p: g.dot[j] as f32,
                    dot_q: g.dot[k] as f32,
                    det: g.det as f32,
                });
            }
            wedge_offsets.push(wedges.len() as u32);
        }

        let (stencil_offsets, stencils, obtuse) = unfold::obtuse_stencils(
            mesh,
            topo,
            &geo,
            params.max_unfold_steps,
            params.min_split_angle_degrees,
        );

        Ok(GeodesicSolver {
            n,
            wedge_offsets,
            wedges,
            stencil_offsets,
            stencils,
            obtuse,
            diagonal: geo.diagonal,
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
        ws.prepare(self.n);
        ws
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
        self.check(source)?;
        for &t in targets {
            self.check(t)?;
        }
        ws.prepare(self.n);
        let mut remaining = 0usize;
        for &t in targets {
            let mark = &mut ws.is_target[t as usize];
            if !*mark {
                *mark = true;
                remaining += 1;
            }
        }
        let early = remaining > 0;
        self.march(source, ws, early, remaining);
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
        Ok(())
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
    fn march(&self, source: VertexId, ws: &mut Workspace, early: bool, mut remaining: usize) {
        let Workspace {
            dist,
            touched,
            heap,
            is_target,
        } = ws;
        dist[source as usize] = 0.0;
        touched.push(source);
        heap.push_or_decrease(0.0, source);

        while let Some((dx, x)) = heap.pop() {
            let xi = x as usize;
            debug_assert_eq!(dist[xi], dx);
            dist[xi] = -dx;
            if early && is_target[xi] {
                remaining -= 1;
                if remaining == 0 {
                    break;
                }
            }
            let (a, b) = (
                self.wedge_offsets[xi] as usize,
                self.wedge_offsets[xi + 1] as usize,
            );
            for w in &self.wedges[a..b] {
                let (pi, qi) = (w.p as usize, w.q as usize);
                let (dp, dq) = (dist[pi], dist[qi]);
                let (p_frozen, q_frozen) = (dp.is_sign_negative(), dq.is_sign_negative());
                if !p_frozen {
                    let edge = dx + w.l_xp as f64;
                    let cand = if q_frozen {
                        two_point_update(
                            dx,
                            -dq,
                            w.dot_x as f64,
                            w.dot_p as f64,
                            w.dot_q as f64,
                            w.det as f64,
                        )
                        .map_or(edge, |t| t.min(edge))
                    } else {
                        edge
                    };
                    if cand < dp {
                        if dp == f64::INFINITY {
                            touched.push(w.p);
                        }
                        dist[pi] = cand;
                        heap.push_or_decrease(cand, w.p);
                    }
                }
                if !q_frozen {
                    let edge = dx + w.l_xq as f64;
                    let cand = if p_frozen {
                        two_point_update(
                            dx,
                            -dp,
                            w.dot_x as f64,
                            w.dot_q as f64,
                            w.dot_p as f64,
                            w.det as f64,
                        )
                        .map_or(edge, |t| t.min(edge))
                    } else {
                        edge
                    };
                    // dist[qi] may have just changed only if p == q, which faces never have
                    if cand < dq {
                        if dq == f64::INFINITY {
                            touched.push(w.q);
                        }
                        dist[qi] = cand;
                        heap.push_or_decrease(cand, w.q);
                    }
                }
            }
            let (a, b) = (
                self.stencil_offsets[xi] as usize,
                self.stencil_offsets[xi + 1] as usize,
            );
            for s in &self.stencils[a..b] {
                let (ti, oi) = (s.target as usize, s.other as usize);
                let (dt, d_o) = (dist[ti], dist[oi]);
                if dt.is_sign_negative() || !d_o.is_sign_negative() {
                    continue;
                }
                if let Some(t) = two_point_update(
                    dx,
                    -d_o,
                    s.dot_x as f64,
                    s.dot_t as f64,
                    s.dot_o as f64,
                    s.det as f64,
                ) && t < dt
                {
                    if dt == f64::INFINITY {
                        touched.push(s.target);
                    }
                    dist[ti] = t;
                    heap.push_or_decrease(t, s.target);
                }
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
        let t = two_point_update(0.0, 0.0, 0.5, 0.5, 0.5, 0.75).expect("valid");
        assert!((t - 0.75f64.sqrt()).abs() < 1e-12);
        // front running along x→o: characteristic grazes the edge, rejected
        assert!(two_point_update(0.0, 1.0, 0.5, 0.5, 0.5, 0.75).is_none());
        // plane wave n = (0.3, √0.91) with x = (0, 0), o = (1, 0), t = (1/2, √3/2)
        let t = two_point_update(0.0, 0.3, 0.5, 0.5, 0.5, 0.75).expect("valid");
        let exact = 0.5 * 0.3 + 0.75f64.sqrt() * 0.91f64.sqrt();
        assert!((t - exact).abs() < 1e-12, "{t} vs {exact}");
    }

    #[test]
    fn degenerate_triangle_is_rejected() {
        assert!(two_point_update(0.0, 0.0, 1.0, 0.0, 0.0, 0.0).is_none());
    }
}
