//! Geodesic distances on triangle meshes by fast marching, and the keypoint-to-keypoint
//! distance matrices of key-component detection (Sipiran & Bustos 2013, Section 3.2).
//!
//! Method: R. Kimmel and J. A. Sethian, "Computing geodesic paths on manifolds", *Proceedings
//! of the National Academy of Sciences* 95(15):8431–8435, 1998 — Sethian's fast marching
//! method (J. A. Sethian, "A fast marching level set method for monotonically advancing
//! fronts", PNAS 93(4):1591–1595, 1996) on triangulated surfaces, with obtuse angles split by
//! unfolding.
//!
//! It computes the distance `d` from a source vertex to every vertex, the viscosity solution of
//! the eikonal equation `|∇d| = 1` on the piecewise-flat surface, first-order accurate in the
//! edge length (on `icosphere(6)`, 0.5 % mean relative error against great circles where
//! Dijkstra on the edges is 7 % off).
//!
//! # Steps
//!
//! 1. **Precompute once per mesh** ([`GeodesicSolver::new`]): for every vertex x its *ring*: the
//!    neighbours p in fan order, each with `|xp|` and the geometry of the face (x, p, next) to the
//!    following neighbour — the dot product at x and `4·area²` (`f32`, 16 bytes an entry, one
//!    contiguous run per vertex). Boundary fans, non-manifold links and flipped faces are
//!    decomposed into paths joined by empty wedges (`area = 0`), so every incident face is one
//!    wedge between two consecutive entries. Obtuse corners are split by unfolding (see *Obtuse
//!    triangles*); the resulting virtual stencils follow the ring in the same run.
//! 2. **Initialise** a front: `d(source) = 0` in an indexed 4-ary heap (decrease-key, one entry
//!    per vertex; bucket queues are options, see *Priority queue*); every other vertex is *far*
//!    (`d = ∞`). Vertices come in three states: far, *trial* (tentative value, in the heap),
//!    *frozen* (final; stored with the sign bit set).
//! 3. **Freeze** the trial vertex x with the smallest tentative value.
//! 4. **Update** the neighbours: for every entry p of x's ring that is not frozen, the candidate
//!    is the smallest of
//!    * the *edge update* `d(x) + |xp|`;
//!    * for each of the two wedges (x, q, p) and (x, p, q) around p whose other vertex q is frozen,
//!      the *two-point update* of p from x and q: the planar wavefront `d(y) = t + n·(y − p)` with
//!      `|n| = 1` through `d(x)` and `d(q)`. With `u = d(q) − d(x)`, `c² = |xq|²` and
//!      `s = t − d(x)`, it is the larger root of
//!      `c² s² − 2 u dot_x s + (u² |xp|² − 4·area²) = 0`, i.e.
//!      `s = (u dot_x + √(4·area² (c² − u²))) / c²`, accepted only if it is *causal*
//!      (`t ≥ d(x)`, `t ≥ d(q)`) and its upwind direction `−n` lies inside the triangle's angle
//!      at p (`−n = λ(x − p) + μ(q − p)` with `λ, μ ≥ 0`, i.e. `|xp|² u ≤ dot_x s` and
//!      `dot_q s + dot_p u ≥ 0`, where `dot_p = |xp|² − dot_x`, `dot_q = c² − dot_x`);
//!
//!    and `d(p) ← min(d(p), candidate)`, inserting p in the heap or lowering its key — at most
//!    one heap operation per neighbour and popped vertex. The virtual stencils of x (step 1) add
//!    two-point updates across the virtual edges.
//! 5. Repeat from 3 until the heap is empty, or — with targets ([`GeodesicSolver::solve_until`])
//!    — until every target is frozen.
//!
//! Every update is the frozen value plus a non-negative amount, so values leave the heap in
//! non-decreasing order and no frozen value ever changes (the front is monotone).
//!
//! # Obtuse triangles
//!
//! An obtuse corner C of (C, A, B) can freeze from an edge update before B is frozen, so the
//! two-point update across AB never happens and C inherits the edge error. Kimmel & Sethian
//! split the angle with a virtual edge to a vertex V found by unfolding the triangles beyond AB
//! into the plane of (C, A, B); we do the same, adding the two virtual triangles (C, A, V) and
//! (C, V, B) as four stencils ("when A freezes and V is frozen, update C", and so on for each
//! owner). Where no such vertex exists within [`GeodesicParams::max_unfold_steps`] triangles
//! (boundaries, non-manifold edges), or the angle is below
//! [`GeodesicParams::min_split_angle_degrees`], the corner keeps the safe fallback — the
//! causality and upwind tests above, which never accept a non-monotone value, and edge updates
//! otherwise. [`GeodesicSolver::obtuse_stats`] counts both. Measured on planar grids against
//! straight-line distances (tests/oracle.rs): a grid sheared to 150° angles, mean relative error
//! 0.38 % with splitting vs 2.3 % with the fallback alone; a randomly jittered grid, 0.98 % vs
//! 1.43 %.
//!
//! Geometry is stored as `f32` (edge lengths, dot products, areas: relative precision 6·10⁻⁸,
//! far below the method's first-order error) to halve memory traffic; distances are `f64`.
//!
//! # Complexity and measured speed
//!
//! Building: O(|F| log d) plus O(obtuse corners × steps × degree). One front: O(n log n) time
//! with n the vertices reached (each vertex is frozen once, each ring entry visited once),
//! no allocation once the [`Workspace`] has grown; resetting a workspace costs only what the
//! previous front touched. A K×K [`distance_matrix`] costs K fronts (each stopping once all K
//! keypoints are frozen — in practice after nearly the whole mesh, the farthest keypoint being
//! near the far end), shared among the rayon threads. Key-component detection
//! (`keycomp_components::pipeline`) by default runs these fronts on a proxy of at most 10,000
//! vertices simplified from the mesh with the keypoints kept (`keycomp_mesh::simplify`), which
//! makes the K×K matrix of a 50–60k-vertex mesh several times cheaper (BENCHMARKS.md,
//! section 2).
//!
//! Per front of a K×K matrix (K = 1 % of the vertices, one thread, median of 5 alternated runs,
//! user-space cycles from `perf stat`, one x86 core at about 4 GHz shared with another
//! workload):
//!
//! | mesh | vertices | split corners | Mcycles per front |
//! |---|---|---|---|
//! | `icosphere(6)` | 40,962 | 0 | 12.9 |
//! | `nefertiti.obj` | 49,971 | 44,810 | 32.1 |
//! | `horse.ply` | 48,485 | 17,025 | 30.9 |
//! | KIDS `0001.null.0.off` | 59,727 | 63,013 | 45.0 |
//!
//! Mean relative errors on the oracles of tests/oracle.rs: `icosphere(6)` against great circles
//! 0.494 %, the sheared grid 0.378 %, the jittered grid 0.978 %.
//! On `nefertiti.obj` the virtual stencils cost about a third of a front (20.5 Mcycles with
//! splitting disabled, 24.8 when splitting only corners above 110°); on `icosphere(6)` with
//! vertices jittered by ±0.4 edge lengths and projected back to the sphere, the mean relative
//! error against great circles is 0.98 % without splitting, 0.64 % splitting every obtuse
//! corner, 0.69 % above 110° and 0.74 % above 120° (±0.8: 7.2 %, 4.7 %, 4.9 %, 5.0 %), hence
//! the default of splitting every obtuse corner.
//!
//! # Priority queue
//!
//! Values leave the queue in non-decreasing order and every insertion lies at most one (possibly
//! virtual) edge length above the value just popped, so a circular array of buckets keyed on
//! the distance can replace the heap ([`GeodesicParams::queue`]): the untidy priority queue of
//! L. Yatziv, A. Bartesaghi and G. Sapiro ("O(N) implementation of the fast marching
//! algorithm", *Journal of Computational Physics* 212(2):393–399, 2006; O(1) per operation,
//! lazy decrease-key, no order within a bucket: [`QueueKind::Untidy`]), and an exact variant
//! that keeps the current bucket sorted ([`QueueKind::Buckets`]). Per front of the K×K matrix
//! (K = 1 % of the vertices; median of 9 alternated runs of 100 fronts, one thread, mesh loading
//! and solver building subtracted; user-space Mcycles, Minstructions in parentheses; another
//! workload shared the machine, so cycles vary by ±10 % between runs, instructions do not):
//!
//! | mesh | heap (default) | untidy, width 0.1 | untidy, width 0.2 | exact buckets¹ |
//! |---|---|---|---|---|
//! | `icosphere(6)` | 11.5 (28.1) | 10.2 (24.4) | 10.3 (24.4) | +34 % (31.4) |
//! | `nefertiti.obj` | 31.6² (39.9) | 33.9² (35.1) | 28.9 (35.0) | +22 % (46.2) |
//! | `horse.ply` | 17.9 (35.5) | 17.6 (30.9) | 17.5 (30.9) | +13 % (40.0) |
//! | KIDS `0001.null.0.off` | 28.7 (48.5) | 29.8 (43.0) | 27.9 (42.9) | +21 % (55.1) |
//!
//! ¹ Cycles relative to the heap in a separate run of 7; bucket width 0.02 mean edge lengths
//! (0.005–0.02 within noise of each other, wider is slower). ² The noisiest row: minima 24.4
//! (heap) and 24.7 (untidy 0.1).
//!
//! The exact buckets gave bit-identical distances to the heap on every mesh above and in the
//! tests (ties are broken by vertex id instead of heap position, and never changed a value),
//! but are slower: the trial band of a 50k-vertex front holds only about 600 entries within
//! about one edge length, so the 4-ary heap is shallow, while buckets add a sort per bucket,
//! stale entries (a decrease-key is a new entry: about 2.1 entries per vertex, half the pops
//! stale) and a scan over buckets, all unpredictable branches. The untidy queue saves 11–13 %
//! of the instructions but only 0–10 % of the cycles (the front waits on memory, not on the
//! queue) and changes the results: mean relative errors on the oracles of tests/oracle.rs,
//! heap → untidy 0.1 → 0.2 → 0.5 (in %):
//!
//! | oracle | heap | untidy 0.1 | untidy 0.2 | untidy 0.5 |
//! |---|---|---|---|---|
//! | `icosphere(6)`, great circles | 0.4940 | 0.4940 | 0.4940 | 0.4957 |
//! | sheared grid | 0.3775 | 0.3775 | 0.3775 | 0.3984 |
//! | jittered grid | 0.9778 | 0.9778 | 0.9781 | 1.0122 |
//! | flat grid | 0.5238 | 0.5250 | 0.5403 | 0.7376 |
//!
//! and against the heap's distances on the real meshes (5 full fronts) a mean relative
//! difference of 3·10⁻⁶ (`horse.ply`) to 2·10⁻⁵ (KIDS) at width 0.1 but up to 7 % on single
//! vertices (28 % at width 0.2: an ordering error is below the width, which is large next to
//! the short edges of finely sampled regions). Hence the heap stays the default: the exact
//! buckets are slower, and the untidy queue's few percent do not pay for results that are no
//! longer those of fast marching.
//!
//! # Meshes
//!
//! Boundaries and non-manifold edges need nothing special (a wedge is a face seen from one of its
//! corners). Unreferenced vertices and vertices on other connected pieces are unreached (+∞);
//! [`distance_matrix`] replaces the resulting infinities by a documented finite value and counts
//! them.

mod bucket;
mod error;
mod heap;
pub mod matrix;
mod queue;
mod solver;
mod unfold;

pub use error::GeodesicError;
pub use matrix::{
    DistanceMatrix, LandmarkStats, ShortRadius, distance_matrix, landmark_distance_matrix,
};
pub use solver::{GeodesicParams, GeodesicSolver, QueueKind, Workspace};
pub use unfold::ObtuseStats;
