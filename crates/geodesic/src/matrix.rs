//! Keypoint-to-keypoint geodesic distance matrices: one front per keypoint, in parallel.
//!
//! 1. For each of the K sources, in parallel (rayon, dynamic scheduling), run a front that stops
//!    once all K sources are frozen ([`GeodesicSolver::solve_until`]) and read row i:
//!    `r_ij = d_i(s_j)`. Each pool thread reuses one [`Workspace`] for all its fronts (indexed
//!    by `rayon::current_thread_index`; the lock around it is never contended), so only one
//!    O(n) allocation happens per thread — `map_init` would build one per rayon split, about
//!    10 for 500 sources on 2 threads and 50 on 4 — and every later front resets only what the
//!    previous one touched.
//! 2. Symmetrise: `D_ij = (r_ij + r_ji) / 2`, `D_ii = 0`. Fast marching is not exactly
//!    symmetric (the discretisation error depends on the direction of the front); averaging
//!    removes the asymmetry without favouring either source.
//! 3. Pairs on different connected pieces have `r_ij = ∞`. Infinity or NaN must not reach the
//!    embedding (SMACOF/MDS), so they get a finite *fill* value: **twice the largest finite
//!    entry** of the matrix (or twice the mesh's bounding-box diagonal when no pair is
//!    connected). Twice the largest distance places separate pieces farther from each other
//!    than any two points of one piece, as they should be, while staying on the same scale as the
//!    real distances so that the embedding's stress is not dominated by the artificial pairs
//!    (a huge value would squash every piece to a point). Those pairs are counted and can be
//!    queried ([`DistanceMatrix::is_disconnected`]).
//!
//! Rows are computed independently and written in source order, so the result does not depend
//! on the number of threads or their scheduling. Cost: K fronts of at most O(n log n) each,
//! divided among the threads, plus O(K²).

use std::sync::{Mutex, PoisonError};

use keycomp_mesh::VertexId;
use rayon::prelude::*;

use crate::{GeodesicError, GeodesicSolver, Workspace};

/// A symmetric K×K matrix of geodesic distances between keypoints, row-major, every entry
/// finite and ≥ 0 with a zero diagonal.
#[derive(Debug, Clone, PartialEq)]
pub struct DistanceMatrix {
    n: usize,
    data: Vec<f64>,
    disconnected: Vec<bool>,
    disconnected_pairs: usize,
    fill: f64,
}

impl DistanceMatrix {
    /// Number of keypoints K (rows and columns).
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether the matrix has no keypoints.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Distance between keypoints i and j (indices into the `sources` slice), in mesh units.
    ///
    /// # Panics
    /// If i or j is not below [`DistanceMatrix::len`].
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        assert!(
            i < self.n && j < self.n,
            "index ({i}, {j}) out of a {0}×{0} matrix",
            self.n
        );
        self.data[i * self.n + j]
    }

    /// Row i.
    pub fn row(&self, i: usize) -> &[f64] {
        &self.data[i * self.n..(i + 1) * self.n]
    }

    /// All entries, row-major (`K·K` values).
    pub fn as_slice(&self) -> &[f64] {
        &self.data
    }

    /// The entries, row-major.
    pub fn into_vec(self) -> Vec<f64> {
        self.data
    }

    /// Whether keypoints i and j lie on different connected pieces (their entry is then the
    /// [`DistanceMatrix::fill_value`]).
    pub fn is_disconnected(&self, i: usize, j: usize) -> bool {
        i < self.n && j < self.n && self.disconnected[i * self.n + j]
    }

    /// Number of unordered pairs {i, j}, i < j, on different connected pieces.
    pub fn disconnected_pairs(&self) -> usize {
        self.disconnected_pairs
    }

    /// The value given to disconnected pairs: twice the largest finite distance (twice the mesh's
    /// bounding-box diagonal if no pair is connected). Meaningful only when
    /// [`DistanceMatrix::disconnected_pairs`] > 0.
    pub fn fill_value(&self) -> f64 {
        self.fill
    }
}

/// Geodesic distances between every pair of `sources` (see the module documentation): K fronts
/// in parallel on the current rayon pool, symmetrised, disconnected pairs filled with a finite
/// value and counted.
///
/// Errors: a source id out of range.
pub fn distance_matrix(
    solver: &GeodesicSolver,
    sources: &[VertexId],
) -> Result<DistanceMatrix, GeodesicError> {
    let k = sources.len();
    // one workspace per thread of the current pool (a caller outside any pool runs on the
    // global pool's threads; index 0 is only a fallback, and the lock keeps it correct)
    let workspaces: Vec<Mutex<Workspace>> = (0..rayon::current_num_threads().min(k.max(1)))
        .map(|_| Mutex::new(Workspace::new()))
        .collect();
    let rows: Vec<Vec<f64>> = sources
        .par_iter()
        .map(|&s| {
            let slot = rayon::current_thread_index().unwrap_or(0) % workspaces.len();
            let mut ws = workspaces[slot]
                .lock()
                .unwrap_or_else(PoisonError::into_inner);
            solver.solve_until(s, sources, &mut ws)?;
            Ok(sources.iter().map(|&t| ws.distance(t)).collect())
        })
        .collect::<Result<_, GeodesicError>>()?;

    let mut data = vec![0.0; k * k];
    let mut disconnected = vec![false; k * k];
    let mut largest = 0.0f64;
    let mut pairs = 0;
    for i in 0..k {
        for j in i + 1..k {
            let (a, b) = (rows[i][j], rows[j][i]);
            let d = if a.is_finite() && b.is_finite() {
                0.5 * (a + b)
            } else if a.is_finite() || b.is_finite() {
                // cannot happen with exact arithmetic (reachability is symmetric); keep the
                // finite value rather than inventing one
                a.min(b)
            } else {
                pairs += 1;
                disconnected[i * k + j] = true;
                disconnected[j * k + i] = true;
                continue;
            };
            largest = largest.max(d);
            data[i * k + j] = d;
            data[j * k + i] = d;
        }
    }
    let scale = if largest > 0.0 {
        largest
    } else if solver.diagonal() > 0.0 {
        solver.diagonal()
    } else {
        1.0 // only degenerate meshes get here
    };
    let fill = 2.0 * scale;
    if pairs > 0 {
        for (d, &off) in data.iter_mut().zip(&disconnected) {
            if off {
                *d = fill;
            }
        }
    }
    Ok(DistanceMatrix {
        n: k,
        data,
        disconnected,
        disconnected_pairs: pairs,
        fill,
    })
}
