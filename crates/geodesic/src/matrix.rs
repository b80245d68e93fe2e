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
//!
//! # Landmark fronts
//!
//! [`landmark_distance_matrix`] spends full fronts on a few sources only (a deviation from the
//! paper, which runs one per keypoint; in the spirit of landmark MDS, V. de Silva and
//! J. B. Tenenbaum, "Sparse multidimensional scaling using landmark points", Stanford
//! technical report, 2004, which also measures every point against a few landmarks only):
//!
//! 1. Each landmark l runs a full front (to every source): its row `d(l, ·)` is measured.
//!    The *covering radius* h is the largest distance from a source to its nearest landmark.
//! 2. Every other source i runs a front stopped at a radius ρ_i
//!    ([`GeodesicSolver::solve_within`]): its distances to the sources within ρ_i are
//!    measured. [`ShortRadius::Covering`]`(f)`: `ρ_i = f · h` for every source.
//!    [`ShortRadius::Local`]`(f)`: `ρ_i = f · max(h_i, h̃)`, with `h_i` the source's own
//!    distance to its nearest landmark and `h̃` the 90th percentile of the `h_i`, so that the
//!    few sources far from every landmark (a hand folded against the body, say) do not
//!    lengthen every front. A source no landmark reaches (a piece without a landmark) runs a full front
//!    instead.
//! 3. A pair measured from both ends gets the average, as above; from one end, that value;
//!    from neither (both non-landmarks, farther apart than both radii), the shortest path
//!    through one landmark, `min_l d(i, l) + d(l, j)`: an upper bound of the geodesic
//!    distance, off by at most `2·min(h_i, h_j)` (the detour through the nearest landmark of
//!    either end), which is small for pairs farther apart than the landmarks' spacing. Either
//!    rule bounds that error by `2/f` of the pair's distance (`2h_i / ρ_i ≤ 2/f`); the local
//!    rule measures fewer pairs where the landmarks are dense.
//!
//! Cost: L full fronts, K − L fronts over the area within their radii, and O(K² L) for the
//! estimates.
//! With L = 100 of the K = 500 keypoints of `nefertiti.obj` on its 20k-vertex proxy and
//! ρ = 2h, the matrix differs from the one of K full fronts by 0.75 % on average
//! (BENCHMARKS.md, section 2, *Landmark fronts and a classical start*, with its cost).

use std::sync::{Mutex, PoisonError};

use keycomp_mesh::VertexId;
use rayon::prelude::*;

use crate::error::GeodesicError;
use crate::solver::{GeodesicSolver, Workspace};

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
    let workspaces = thread_workspaces(k);
    let rows: Vec<Vec<f64>> = sources
        .par_iter()
        .map(|&s| {
            with_workspace(&workspaces, |ws| {
                solver.solve_until(s, sources, ws)?;
                Ok(sources.iter().map(|&t| ws.distance(t)).collect())
            })
        })
        .collect::<Result<_, GeodesicError>>()?;
    let rows = &rows;
    Ok(assemble(solver, k, |i| move |j| (rows[i][j], rows[j][i], false)).0)
}

/// One workspace per thread of the current pool (a caller outside any pool runs on the global
/// pool's threads; index 0 is only a fallback, and the lock keeps it correct).
fn thread_workspaces(fronts: usize) -> Vec<Mutex<Workspace>> {
    (0..rayon::current_num_threads().min(fronts.max(1)))
        .map(|_| Mutex::new(Workspace::new()))
        .collect()
}

/// Runs `f` with the calling thread's workspace.
fn with_workspace<T>(
    workspaces: &[Mutex<Workspace>],
    f: impl FnOnce(&mut Workspace) -> Result<T, GeodesicError>,
) -> Result<T, GeodesicError> {
    let slot = rayon::current_thread_index().unwrap_or(0) % workspaces.len();
    let mut ws = workspaces[slot]
        .lock()
        .unwrap_or_else(PoisonError::into_inner);
    f(&mut ws)
}

/// Symmetrises `(r_ij, r_ji)` for i < j into a [`DistanceMatrix`] and fills the disconnected
/// pairs (steps 2 and 3 of the module docs). `row(i)` gives the pairs of row i, asked for in
/// increasing j, each with whether it was estimated (counted, and returned with the matrix). The upper triangle is filled in parallel over rows (each entry depends on its
/// pair alone, and the largest value and the count of disconnected pairs do not depend on the
/// order they are combined in), then mirrored.
fn assemble<P: FnMut(usize) -> (f64, f64, bool)>(
    solver: &GeodesicSolver,
    k: usize,
    row_pairs: impl Fn(usize) -> P + Sync,
) -> (DistanceMatrix, usize) {
    let mut data = vec![0.0; k * k];
    let mut disconnected = vec![false; k * k];
    let (largest, pairs, estimated) = data
        .par_chunks_mut(k.max(1))
        .zip(disconnected.par_chunks_mut(k.max(1)))
        .enumerate()
        .map(|(i, (row, off))| {
            let (mut largest, mut pairs, mut estimated) = (0.0f64, 0usize, 0usize);
            let mut pair = row_pairs(i);
            for j in i + 1..k {
                let (a, b, guessed) = pair(j);
                estimated += usize::from(guessed);
                let d = if a.is_finite() && b.is_finite() {
                    0.5 * (a + b)
                } else if a.is_finite() || b.is_finite() {
                    // cannot happen with exact arithmetic (reachability is symmetric); keep
                    // the finite value rather than inventing one
                    a.min(b)
                } else {
                    pairs += 1;
                    off[j] = true;
                    continue;
                };
                largest = largest.max(d);
                row[j] = d;
            }
            (largest, pairs, estimated)
        })
        .reduce(|| (0.0, 0, 0), |a, b| (a.0.max(b.0), a.1 + b.1, a.2 + b.2));
    // mirror the upper triangle, in tiles so that both sides stay in cache
    const TILE: usize = 64;
    for bi in (0..k).step_by(TILE) {
        for bj in (bi..k).step_by(TILE) {
            for i in bi..(bi + TILE).min(k) {
                for j in bj.max(i + 1)..(bj + TILE).min(k) {
                    data[j * k + i] = data[i * k + j];
                    disconnected[j * k + i] = disconnected[i * k + j];
                }
            }
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
    (
        DistanceMatrix {
            n: k,
            data,
            disconnected,
            disconnected_pairs: pairs,
            fill,
        },
        estimated,
    )
}

/// Where the short fronts of [`landmark_distance_matrix`] stop (step 2 of *Landmark fronts* in
/// the module docs). The factor must be a positive number; any other value is taken as +∞
/// (every front full).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShortRadius {
    /// `f · h`, h the covering radius, for every source.
    Covering(f64),
    /// `f · max(h_i, h̃)`: `h_i` the source's distance to its nearest landmark, `h̃` the 90th
    /// percentile of the `h_i`.
    Local(f64),
}

/// What [`landmark_distance_matrix`] computed, beside the matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkStats {
    /// Full fronts run: the landmarks, plus the sources no landmark reaches (on a piece without
    /// a landmark).
    pub full_fronts: usize,
    /// Fronts stopped at [`LandmarkStats::radius`].
    pub short_fronts: usize,
    /// The covering radius h: the largest distance from a source to its nearest landmark (over
    /// the sources some landmark reaches), in mesh units.
    pub covering_radius: f64,
    /// The farthest a short front ran: `f · h` under [`ShortRadius::Covering`], in mesh units.
    pub radius: f64,
    /// Unordered pairs {i, j} whose distance is estimated through the landmarks (no front
    /// measured it).
    pub estimated_pairs: usize,
}

/// Keypoint distances from the full fronts of a few *landmark* sources and short fronts of the
/// others (see *Landmark fronts* in the module documentation), in place of
/// [`distance_matrix`]'s K full fronts.
///
/// `landmarks` are positions in `sources`, each at most once; `short` sets where the short
/// fronts stop. With every source a landmark the result is [`distance_matrix`]'s. Errors: a
/// source id out of range, a landmark index out of range or repeated.
pub fn landmark_distance_matrix(
    solver: &GeodesicSolver,
    sources: &[VertexId],
    landmarks: &[usize],
    short: ShortRadius,
) -> Result<(DistanceMatrix, LandmarkStats), GeodesicError> {
    let k = sources.len();
    // slot of each source among the landmarks
    let mut slot = vec![usize::MAX; k];
    for (l, &i) in landmarks.iter().enumerate() {
        if i >= k || slot[i] != usize::MAX {
            return Err(GeodesicError::BadLandmark {
                landmark: i,
                sources: k,
            });
        }
        slot[i] = l;
    }
    let workspaces = thread_workspaces(k);
    let full_row = |s: VertexId| {
        with_workspace(&workspaces, |ws| {
            solver.solve_until(s, sources, ws)?;
            Ok(sources
                .iter()
                .map(|&t| ws.distance(t))
                .collect::<Vec<f64>>())
        })
    };
    // 1. the landmarks' full fronts; `through[j]` holds d(l, j) for every landmark l
    let landmark_rows: Vec<Vec<f64>> = landmarks
        .par_iter()
        .map(|&i| full_row(sources[i]))
        .collect::<Result<_, GeodesicError>>()?;
    let nl = landmarks.len();
    let through: Vec<Vec<f64>> = (0..k)
        .map(|j| landmark_rows.iter().map(|row| row[j]).collect())
        .collect();
    let nearest: Vec<f64> = through
        .iter()
        .map(|d| d.iter().copied().fold(f64::INFINITY, f64::min))
        .collect();
    let covering_radius = nearest
        .iter()
        .copied()
        .filter(|d| d.is_finite())
        .fold(0.0, f64::max);
    // each short front's reach before the factor: the covering radius, or the source's own
    // distance to its nearest landmark, at least the 90th percentile of those distances
    let (factor, floor) = match short {
        ShortRadius::Covering(f) => (f, None),
        ShortRadius::Local(f) => {
            let mut reached: Vec<f64> = nearest.iter().copied().filter(|d| d.is_finite()).collect();
            reached.sort_unstable_by(f64::total_cmp);
            (
                f,
                Some(reached.get(reached.len() * 9 / 10).copied().unwrap_or(0.0)),
            )
        }
    };
    let radius_of = |i: usize| {
        let reach = floor.map_or(covering_radius, |f| nearest[i].max(f));
        // not a positive number: every front runs in full (and ∞ · 0 would be NaN)
        if factor > 0.0 && factor.is_finite() {
            factor * reach
        } else {
            f64::INFINITY
        }
    };
    let radius = (0..k)
        .filter(|&i| slot[i] == usize::MAX && nearest[i].is_finite())
        .map(radius_of)
        .fold(0.0, f64::max);

    // 2. the other sources: a front stopped at its radius, or a full one where no landmark
    //    reaches the source; `Short::complete` = the front covered the source's whole piece.
    //    Only the sources a front reached are kept, by index: a short front reaches a few
    //    tens of them, and K rows of K values would be the stage's largest memory.
    struct Short {
        reached: Vec<(u32, f64)>,
        complete: bool,
    }
    let reached = |ws: &Workspace| -> Vec<(u32, f64)> {
        sources
            .iter()
            .enumerate()
            .filter_map(|(j, &t)| {
                let d = ws.distance(t);
                d.is_finite().then_some((j as u32, d))
            })
            .collect()
    };
    let others: Vec<usize> = (0..k).filter(|&i| slot[i] == usize::MAX).collect();
    let short: Vec<Short> = others
        .par_iter()
        .map(|&i| {
            if nearest[i].is_finite() {
                with_workspace(&workspaces, |ws| {
                    let complete = solver.solve_within(sources[i], radius_of(i), ws)?;
                    Ok(Short {
                        reached: reached(ws),
                        complete,
                    })
                })
            } else {
                let row = full_row(sources[i])?;
                Ok(Short {
                    reached: (0..k as u32)
                        .zip(row)
                        .filter(|(_, d)| d.is_finite())
                        .collect(),
                    complete: true,
                })
            }
        })
        .collect::<Result<_, GeodesicError>>()?;
    let mut row_of = vec![usize::MAX; k];
    for (r, &i) in others.iter().enumerate() {
        row_of[i] = r;
    }
    let full_fronts = nl + others.iter().filter(|&&i| !nearest[i].is_finite()).count();

    // 3. r_ij: measured when i is a landmark or j lies within i's short front (or i's front
    //    covered its piece); otherwise unknown (`None`). Row i reads its own front's sources
    //    and the fronts that reached i (`columns[i]`), both in increasing j, with cursors.
    let mut columns: Vec<Vec<(u32, f64)>> = vec![Vec::new(); k];
    for &j in &others {
        for &(t, d) in &short[row_of[j]].reached {
            columns[t as usize].push((j as u32, d));
        }
    }
    let (short, columns, through) = (&short, &columns, &through);
    let (slot, row_of, landmark_rows) = (&slot, &row_of, &landmark_rows);
    let (matrix, estimated) = assemble(solver, k, |i| {
        let (mut own_at, mut column_at) = (0usize, 0usize);
        move |j: usize| {
            let a = if slot[i] != usize::MAX {
                Some(landmark_rows[slot[i]][j])
            } else {
                let s = &short[row_of[i]];
                while own_at < s.reached.len() && (s.reached[own_at].0 as usize) < j {
                    own_at += 1;
                }
                match s.reached.get(own_at) {
                    Some(&(t, d)) if t as usize == j => Some(d),
                    _ => s.complete.then_some(f64::INFINITY),
                }
            };
            let b = if slot[j] != usize::MAX {
                Some(landmark_rows[slot[j]][i])
            } else {
                let c = &columns[i];
                while column_at < c.len() && (c[column_at].0 as usize) < j {
                    column_at += 1;
                }
                match c.get(column_at) {
                    Some(&(t, d)) if t as usize == j => Some(d),
                    _ => short[row_of[j]].complete.then_some(f64::INFINITY),
                }
            };
            match (a, b) {
                (Some(a), Some(b)) => (a, b, false),
                (Some(a), None) => (a, a, false),
                (None, Some(b)) => (b, b, false),
                (None, None) => {
                    let d = through_landmarks(&through[i], &through[j]);
                    (d, d, true)
                }
            }
        }
    });
    let stats = LandmarkStats {
        full_fronts,
        short_fronts: k - full_fronts,
        covering_radius,
        radius,
        estimated_pairs: estimated,
    };
    Ok((matrix, stats))
}

/// `min_l a_l + b_l`: the shortest path from i to j through one landmark, given both sources'
/// distances to every landmark (+∞ if no landmark reaches both).
fn through_landmarks(a: &[f64], b: &[f64]) -> f64 {
    // four independent minima so the loop vectorises
    let mut m = [f64::INFINITY; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for t in 0..4 {
            let s = x[t] + y[t];
            m[t] = if s < m[t] { s } else { m[t] };
        }
    }
    let mut best = m[0].min(m[1]).min(m[2].min(m[3]));
    for (x, y) in ra.iter().zip(rb) {
        best = best.min(x + y);
    }
    best
}
