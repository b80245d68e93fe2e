//! Metric multidimensional scaling to the plane by SMACOF (Scaling by MAjorizing a COmplicated
//! Function): 2-D points whose Euclidean distances approximate a given distance matrix (the
//! paper's Eq. 1; here the matrix holds geodesic distances between keypoints).
//!
//! For target distances `δ_ij` (K × K, symmetric) and a configuration `X` (K points in ℝ²) with
//! distances `d_ij(X) = ‖x_i − x_j‖`, the raw stress is
//! `σ(X) = ½ Σ_{i≠j} (d_ij(X) − δ_ij)² = Σ_{i<j} (d_ij(X) − δ_ij)²`.
//!
//! Steps, for each of `starts` starts (in parallel; they are independent):
//! 1. Start 0 with `classical_start` (the default): `X⁰` is the classical scaling of the
//!    matrix (see *Classical start*). Every other start: draw `X⁰` uniformly in the square
//!    `[0, L]²`, `L = max δ_ij`, from a ChaCha8 generator seeded with `seed` on stream `s` (the
//!    start's index), so every start has its own stream and the result does not depend on the
//!    number of threads.
//! 2. Guttman transform (unweighted, so `V⁺ = I/K` on centred configurations):
//!    `X ← (1/K)·B(X)·X` with `B_ij = −δ_ij / d_ij(X)` for `i ≠ j` (0 when `d_ij(X) = 0`) and
//!    `B_ii = −Σ_{j≠i} B_ij`, i.e. row `i` of `B·X` is `(Σ_{j≠i} b_ij)·x_i − Σ_{j≠i} b_ij·x_j`
//!    with `b_ij = δ_ij / d_ij`. `B` is never materialised: one sweep over the pairs `i < j`
//!    computes `d_ij` once, accumulates both rows, and also yields `σ(X)`. The sweep is cut
//!    into blocks of consecutive rows of about 32k pairs each, swept in parallel with their own
//!    sums, which are then added in block order: the blocks depend on K only, so the result
//!    is the same on any number of threads.
//! 3. Stop when the relative decrease `(σ_old − σ_new) / σ_old` falls below `rel_tol`, when the
//!    stress is exactly 0, or after `max_iter` transforms. The majorisation guarantees that
//!    `σ` never increases from one iterate to the next (de Leeuw 1977).
//! 4. Keep the start with the lowest final stress (ties: the lowest start index).
//!
//! Complexity: O(K²) time per iteration (one pass over the upper triangle, branch-free and
//! laid out for SIMD, parallel over the blocks), no allocation inside the iteration loop; at
//! most `starts · (max_iter + 1)` passes in total. Memory: the packed upper triangle
//! ([`UpperTriangle`], K²/2 values read in order, shared by the starts; detection packs the
//! square matrix in its own memory, [`UpperTriangle::from_square`]) and O(K) per block. The
//! classical start's products sweep the same blocks, without forming its K×K matrix.
//!
//! The matrix is read from its upper triangle (`i < j`); the lower triangle is only checked to
//! be the mirror image (relative tolerance 1e-9) and the diagonal is ignored.
//!
//! # Classical start (a deviation from the paper, on by default)
//!
//! The paper does not say how SMACOF is started. Random starts land in different local minima
//! of the stress, so the best of several is kept, each costing 100–300 transforms on
//! real keypoint matrices. Classical scaling (Torgerson; the two leading eigenvectors of the
//! double-centred squared distances) is a start close to a good minimum (on a sphere's
//! great-circle distances it ends within 5 % of the best of four random starts' stress, a
//! test below). The default is two starts, the classical one and one random (they run side by
//! side on two threads), instead of four random ones. With the landmark fronts of
//! `keycomp_geodesic::landmark_distance_matrix`, against four random starts and full fronts,
//! the repeatability benchmark's KC-1 average overlap at strength ≤ 5 is 0.848 against
//! 0.844, no row more than 0.015 lower (BENCHMARKS.md, *Repeatability*).
//! `classical_start: false, starts: 4` gives four random starts.
//!
//! # Relaxed transforms (a deviation from the paper, in the robust preset)
//!
//! With `relaxation` ω > 1, every transform after the first steps past the Guttman
//! transform: `X ← X + ω·(Γ(X) − X)` (J. de Leeuw and W. J. Heiser, "Multidimensional scaling
//! with restrictions on the configuration", in *Multivariate Analysis V*, North-Holland,
//! 1980, pp. 501–522). The stress still never increases for ω ≤ 2: the majorising function
//! of step 2 is a quadratic in `X` with its minimum at `Γ(X)` and equal to `σ` at the current
//! configuration, so it takes the same value at `X` and at `2Γ(X) − X` and is lower at every
//! point between them, and it bounds `σ` from above. The first transform stays plain, as it
//! takes a random start most of the way in one step. On the robust preset's keypoint
//! matrices of nefertiti and KIDS, ω = 1.5 stops after 26–30 % fewer transforms at a slightly
//! lower stress (BENCHMARKS.md, Detection, *Time*).
//!
//! References: I. Borg and P. J. F. Groenen, *Modern Multidimensional Scaling: Theory and
//! Applications*, 2nd ed., Springer, 2005 (ch. 8); J. de Leeuw, "Applications of convex analysis
//! to multidimensional scaling", in *Recent Developments in Statistics*, North-Holland, 1977,
//! pp. 133–145.

use keycomp_geodesic::DistanceMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::ComponentsError;

/// Parameters of [`smacof`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SmacofParams {
    /// Number of starts (≥ 1; default 2: the classical start and one random one). More
    /// starts make a poor local minimum less likely at proportional cost; they run in
    /// parallel.
    pub starts: usize,
    /// Maximum number of Guttman transforms per start (≥ 1; default 300). Raising it only
    /// matters when `rel_tol` is not reached first.
    pub max_iter: usize,
    /// Stop when the relative stress decrease of one iteration is below this (unitless, ≥ 0;
    /// default 1e-6). Lowering it iterates longer for a slightly lower stress; 0 runs to
    /// `max_iter` unless the stress stops decreasing.
    pub rel_tol: f64,
    /// Seed of the random starts (default 0). The result is a pure function of the input and
    /// these parameters, whatever the number of threads.
    pub seed: u64,
    /// Start 0 from the classical (Torgerson) scaling of the matrix instead of a random
    /// configuration (see *Classical start* in the module docs); the other starts stay random.
    /// Default `true`.
    /// A recorded parameter set without the field reads as `false` (every start
    /// random).
    #[serde(default)]
    pub classical_start: bool,
    /// Over-relaxation ω of every transform after the first: `X ← X + ω·(Γ(X) − X)`, `Γ` the
    /// Guttman transform (see *Relaxed transforms* in the module docs). In `[1, 2)`; 1 (the
    /// default, and what a recorded parameter set without the field reads as) is the plain
    /// transform.
    #[serde(default = "plain_relaxation")]
    pub relaxation: f64,
}

fn plain_relaxation() -> f64 {
    1.0
}

impl Default for SmacofParams {
    fn default() -> Self {
        SmacofParams {
            starts: 2,
            max_iter: 300,
            rel_tol: 1e-6,
            seed: 0,
            classical_start: true,
            relaxation: 1.0,
        }
    }
}

impl SmacofParams {
    /// Checks that every field is in range.
    pub fn validate(&self) -> Result<(), ComponentsError> {
        if self.starts == 0 {
            return Err(ComponentsError::param(
                "smacof.starts",
                self.starts,
                "use at least 1 random start",
            ));
        }
        if self.max_iter == 0 {
            return Err(ComponentsError::param(
                "smacof.max_iter",
                self.max_iter,
                "use at least 1 iteration (300 is the default)",
            ));
        }
        if !(1.0..2.0).contains(&self.relaxation) {
            return Err(ComponentsError::param(
                "smacof.relaxation",
                self.relaxation,
                "must be at least 1 and below 2 (1 is the plain Guttman transform)",
            ));
        }
        if !(self.rel_tol.is_finite() && self.rel_tol >= 0.0) {
            return Err(ComponentsError::param(
                "smacof.rel_tol",
                self.rel_tol,
                "must be a finite number ≥ 0 (1e-6 is the default)",
            ));
        }
        Ok(())
    }
}

/// A 2-D embedding computed by [`smacof`].
#[derive(Debug, Clone, PartialEq)]
pub struct Embedding {
    /// One point per row of the distance matrix, in the same order.
    pub points: Vec<[f64; 2]>,
    /// Raw stress `Σ_{i<j} (d_ij − δ_ij)²` of `points` (squared distance units).
    pub stress: f64,
    /// Number of Guttman transforms that produced `points` in the winning start.
    pub iterations: usize,
}

/// Embeds `k` points in the plane so that their distances approximate `distances`, a `k × k`
/// symmetric row-major matrix of finite non-negative values (see the module docs).
///
/// `k = 0` gives no points; `k = 1` the origin; `k = 2` the exact solution
/// `(−δ/2, 0), (δ/2, 0)`. Errors: the slice is not `k × k`, a value is NaN, infinite or
/// negative, the matrix is not symmetric, or `params` is invalid.
pub fn smacof(
    distances: &[f64],
    k: usize,
    params: &SmacofParams,
) -> Result<Embedding, ComponentsError> {
    params.validate()?;
    smacof_upper(&UpperTriangle::new(distances, k)?, params)
}

/// [`smacof`] of a matrix already packed ([`UpperTriangle::new`]), so that the caller can free
/// the square matrix first.
pub fn smacof_upper(
    delta: &UpperTriangle,
    params: &SmacofParams,
) -> Result<Embedding, ComponentsError> {
    params.validate()?;
    match delta.k {
        0 => {
            return Ok(Embedding {
                points: Vec::new(),
                stress: 0.0,
                iterations: 0,
            });
        }
        1 => {
            return Ok(Embedding {
                points: vec![[0.0, 0.0]],
                stress: 0.0,
                iterations: 0,
            });
        }
        2 => {
            let h = delta.values[0] * delta.unit / 2.0;
            return Ok(Embedding {
                points: vec![[-h, 0.0], [h, 0.0]],
                stress: 0.0,
                iterations: 0,
            });
        }
        _ => {}
    }
    let runs: Vec<Embedding> = (0..params.starts)
        .into_par_iter()
        .map(|s| run_start(delta, params, s as u64, |_| {}))
        .collect();
    // lowest stress, ties to the lowest start index (min_by keeps the first of equal elements)
    let best = runs
        .into_iter()
        .min_by(|a, b| a.stress.total_cmp(&b.stress))
        .ok_or(ComponentsError::Empty {
            what: "set of SMACOF starts",
        })?;
    Ok(best)
}

/// The upper triangle of a distance matrix (`δ_ij`, `i < j`), row after row (row `i` at
/// `row_start(i, k)`), divided by `unit`, the power of two that brings the largest distance
/// into `[½, 1)` (1 when every distance is 0): what SMACOF reads. Half the memory of the square
/// matrix, read in order, with coordinates of order 1; dividing by a power of two is exact, so
/// scaling back is too.
#[derive(Debug, Clone, PartialEq)]
pub struct UpperTriangle {
    k: usize,
    values: Vec<f64>,
    unit: f64,
    /// The largest value of `values`.
    max: f64,
}

impl UpperTriangle {
    /// Packs a `k × k` symmetric row-major matrix of finite non-negative values. Errors as
    /// [`smacof`]'s for the matrix.
    pub fn new(distances: &[f64], k: usize) -> Result<UpperTriangle, ComponentsError> {
        check_matrix(distances, k)?;
        let max = upper_max(distances, k);
        let unit = scale_unit(max);
        let mut values = Vec::with_capacity(k * k.saturating_sub(1) / 2);
        for i in 0..k {
            values.extend(
                distances[i * k + i + 1..(i + 1) * k]
                    .iter()
                    .map(|d| d / unit),
            );
        }
        Ok(UpperTriangle {
            k,
            values,
            unit,
            max: max / unit,
        })
    }

    /// [`UpperTriangle::new`], packed in the square matrix's own memory (no second copy).
    pub fn from_square(distances: Vec<f64>, k: usize) -> Result<UpperTriangle, ComponentsError> {
        check_matrix(&distances, k)?;
        Ok(Self::pack_in_place(distances, k))
    }

    /// A geodesic distance matrix packed in its own memory. Its type already guarantees what
    /// [`UpperTriangle::from_square`] checks (symmetric, finite, non-negative), so the matrix is
    /// not read a third time for it.
    pub fn from_distances(distances: DistanceMatrix) -> UpperTriangle {
        let k = distances.len();
        Self::pack_in_place(distances.into_vec(), k)
    }

    /// Moves row i's entries `j > i` to [`row_start`]`(i, k)` (never past their place in the
    /// square, so rows move in order) and scales them as they move.
    fn pack_in_place(mut distances: Vec<f64>, k: usize) -> UpperTriangle {
        let max = upper_max(&distances, k);
        let unit = scale_unit(max);
        let mut at = 0;
        for i in 0..k {
            let m = k - i - 1;
            distances.copy_within(i * k + i + 1..(i + 1) * k, at);
            distances[at..at + m].iter_mut().for_each(|d| *d /= unit);
            at += m;
        }
        distances.truncate(at);
        distances.shrink_to_fit();
        UpperTriangle {
            k,
            values: distances,
            unit,
            max: max / unit,
        }
    }

    /// Number of points K.
    pub fn len(&self) -> usize {
        self.k
    }

    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.k == 0
    }

    /// Row `i`'s scaled distances to the points `j > i`.
    fn row(&self, i: usize) -> &[f64] {
        &self.values[row_start(i, self.k)..][..self.k - i - 1]
    }
}

fn check_matrix(d: &[f64], k: usize) -> Result<(), ComponentsError> {
    let expected = k.saturating_mul(k);
    if d.len() != expected {
        return Err(ComponentsError::MatrixSize {
            len: d.len(),
            k,
            expected,
        });
    }
    for i in 0..k {
        for j in 0..k {
            let v = d[i * k + j];
            if !(v.is_finite() && (v >= 0.0 || i == j)) {
                return Err(ComponentsError::BadDistance { i, j, value: v });
            }
        }
    }
    for i in 0..k {
        for j in i + 1..k {
            let (a, b) = (d[i * k + j], d[j * k + i]);
            if (a - b).abs() > 1e-9 * a.max(b) {
                return Err(ComponentsError::Asymmetric {
                    i,
                    j,
                    dij: a,
                    dji: b,
                });
            }
        }
    }
    Ok(())
}

/// Independent accumulators of the row sums (lets the compiler use SIMD for them without
/// reassociating floating-point sums, which it may not do on its own).
const LANES: usize = 4;

/// About this many pairs `i < j` per block of rows of the Guttman transform (see [`Block`]).
const PAIRS_PER_BLOCK: usize = 1 << 15;

/// Most blocks of rows per transform.
const MAX_BLOCKS: usize = 32;

/// A block of consecutive rows `i` of the upper triangle, with its own accumulators: one
/// transform sweeps the blocks in parallel, then adds their accumulators in block order. The
/// blocks depend on K only, so the sums, and the result, are the same on any number of threads.
struct Block {
    /// First row of the block.
    first: usize,
    /// One past its last row.
    end: usize,
    /// `Σ_j b_ij x_j` over the block's pairs, for rows `first..K` (index `i − first`).
    tx: Vec<f64>,
    /// `Σ_j b_ij y_j`, likewise.
    ty: Vec<f64>,
    /// `Σ_j b_ij`, likewise.
    ts: Vec<f64>,
    /// Scratch row: `b_ij` for the current `i`.
    b: Vec<f64>,
    /// Scratch row: `(d_ij − δ_ij)²` for the current `i`.
    r2: Vec<f64>,
    /// The block's share of the stress.
    stress: f64,
}

/// Splits rows `0..k` into blocks of about [`PAIRS_PER_BLOCK`] pairs each (row `i` has
/// `k − 1 − i`), at most [`MAX_BLOCKS`].
fn blocks(k: usize) -> Vec<Block> {
    let pairs = k * k.saturating_sub(1) / 2;
    let count = pairs.div_ceil(PAIRS_PER_BLOCK).clamp(1, MAX_BLOCKS);
    let per = pairs.div_ceil(count).max(1);
    let mut out = Vec::with_capacity(count);
    let (mut first, mut taken) = (0, 0);
    for i in 0..k {
        taken += k - 1 - i;
        if taken >= per || i + 1 == k {
            let m = k - first;
            out.push(Block {
                first,
                end: i + 1,
                tx: vec![0.0; m],
                ty: vec![0.0; m],
                ts: vec![0.0; m],
                b: vec![0.0; m],
                r2: vec![0.0; m],
                stress: 0.0,
            });
            (first, taken) = (i + 1, 0);
        }
    }
    out
}

/// Buffers of one start, allocated once.
struct Work {
    x: Vec<f64>,
    y: Vec<f64>,
    nx: Vec<f64>,
    ny: Vec<f64>,
    /// `Σ_j b_ij` per row.
    s: Vec<f64>,
    blocks: Vec<Block>,
}

/// Runs one start (index `start`) to convergence; `on_stress` sees the stress of every iterate
/// in order (for tests).
fn run_start(
    delta: &UpperTriangle,
    params: &SmacofParams,
    start: u64,
    mut on_stress: impl FnMut(f64),
) -> Embedding {
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    rng.set_stream(start);
    let (k, unit) = (delta.k, delta.unit);
    let scale = delta.max;
    let mut w = Work {
        x: Vec::with_capacity(k),
        y: Vec::with_capacity(k),
        nx: vec![0.0; k],
        ny: vec![0.0; k],
        s: vec![0.0; k],
        blocks: blocks(k),
    };
    match (start == 0 && params.classical_start)
        .then(|| classical(delta, &mut w.blocks))
        .flatten()
    {
        Some((x, y)) => {
            w.x = x;
            w.y = y;
        }
        None => {
            for _ in 0..k {
                w.x.push(rng.random::<f64>() * scale);
                w.y.push(rng.random::<f64>() * scale);
            }
        }
    }
    let mut prev: Option<f64> = None;
    let mut iterations = 0;
    let stress = loop {
        let stress = guttman(delta, &mut w) * unit * unit;
        on_stress(stress);
        if stress == 0.0 || iterations == params.max_iter {
            break stress;
        }
        if let Some(p) = prev
            && (p - stress) < params.rel_tol * p
        {
            break stress;
        }
        if params.relaxation != 1.0 && iterations > 0 {
            let omega = params.relaxation;
            for (n, &o) in w.nx.iter_mut().zip(&w.x) {
                *n = o + omega * (*n - o);
            }
            for (n, &o) in w.ny.iter_mut().zip(&w.y) {
                *n = o + omega * (*n - o);
            }
        }
        std::mem::swap(&mut w.x, &mut w.nx);
        std::mem::swap(&mut w.y, &mut w.ny);
        iterations += 1;
        prev = Some(stress);
    };
    Embedding {
        points: w
            .x
            .iter()
            .zip(&w.y)
            .map(|(&x, &y)| [x * unit, y * unit])
            .collect(),
        stress,
        iterations,
    }
}

/// One Guttman transform: writes `(1/K)·B(X)·X` into `w.nx, w.ny` and returns `σ(X)`. The
/// blocks of rows run in parallel ([`sweep`]), then their sums are added in block order.
fn guttman(delta: &UpperTriangle, w: &mut Work) -> f64 {
    let k = delta.k;
    let Work {
        x,
        y,
        nx,
        ny,
        s,
        blocks,
    } = w;
    let (x, y) = (&x[..], &y[..]);
    blocks.par_iter_mut().for_each(|block| {
        // compiled for the widest vector unit the CPU has: the same operations in the same
        // order, so the same result bit for bit, only more lanes at once
        pulp::Arch::new().dispatch(Sweep { delta, x, y, block })
    });
    let mut stress = 0.0;
    nx.fill(0.0);
    ny.fill(0.0);
    s.fill(0.0);
    for block in blocks.iter() {
        let f = block.first;
        for (((i, &bx), &by), &bs) in (f..k).zip(&block.tx).zip(&block.ty).zip(&block.ts) {
            nx[i] += bx;
            ny[i] += by;
            s[i] += bs;
        }
        stress += block.stress;
    }
    let inv_n = 1.0 / k as f64;
    for i in 0..k {
        nx[i] = (s[i] * x[i] - nx[i]) * inv_n;
        ny[i] = (s[i] * y[i] - ny[i]) * inv_n;
    }
    stress
}

/// [`sweep`] as a `pulp` operation: `with_simd` is instantiated inside a function compiled for
/// each instruction set (AVX-512, AVX2, baseline), and inlining `sweep` into it (both are
/// `inline(always)`) compiles the transform's loops for that set. (A closure would not do: one
/// that is not inlined keeps the baseline set.)
struct Sweep<'a> {
    delta: &'a UpperTriangle,
    x: &'a [f64],
    y: &'a [f64],
    block: &'a mut Block,
}

impl pulp::WithSimd for Sweep<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        sweep(self.delta, self.x, self.y, self.block)
    }
}

/// The power of two that brings `max` into `[½, 1)` (1 for 0).
fn scale_unit(max: f64) -> f64 {
    if max > 0.0 {
        2f64.powi((max.log2().floor() as i32 + 1).clamp(-1000, 1000))
    } else {
        1.0
    }
}

/// Where row `i` (its pairs `j > i`) starts in an [`UpperTriangle`] of `k` points.
fn row_start(i: usize, k: usize) -> usize {
    i * (k - 1) - i * i.saturating_sub(1) / 2
}

fn upper_max(delta: &[f64], k: usize) -> f64 {
    let mut m: f64 = 0.0;
    for i in 0..k {
        for &v in &delta[i * k + i + 1..(i + 1) * k] {
            m = m.max(v);
        }
    }
    m
}

/// `q` when `d > 0`, else 0: a bit mask rather than a branch, so the loop vectorises
/// (`q = δ/d` is inf or NaN when `d = 0`, and is discarded then).
#[inline(always)]
fn nonzero_or_zero(q: f64, d: f64) -> f64 {
    let mask = u64::from(d > 0.0).wrapping_neg();
    f64::from_bits(q.to_bits() & mask)
}

/// One block's share of a Guttman transform: for its rows `i` and every `j > i`, adds `b_ij`,
/// `b_ij·x_j`, `b_ij·y_j` to row `i`'s sums and `b_ij`, `b_ij·x_i`, `b_ij·y_i` to row `j`'s (with
/// `b_ij = δ_ij / d_ij(X)`), and sums `(d_ij − δ_ij)²` into its stress.
///
/// Per row `i`, a first element-wise loop over `j > i` (which the compiler vectorises: no
/// cross-iteration sums) computes `b_ij` and `(d_ij − δ_ij)²` into scratch rows and adds row
/// `i`'s contributions to rows `j`; a second loop sums the scratch rows over `LANES`
/// independent accumulators. Inlined into its caller's `pulp` dispatch, which compiles it for
/// AVX2 and AVX-512 as well and picks the widest the CPU has at run time.
#[inline(always)]
fn sweep(delta: &UpperTriangle, x: &[f64], y: &[f64], block: &mut Block) {
    let k = delta.k;
    let Block {
        first,
        end,
        tx,
        ty,
        ts,
        b,
        r2,
        stress: block_stress,
    } = block;
    let first = *first;
    tx.fill(0.0);
    ty.fill(0.0);
    ts.fill(0.0);
    let mut stress = 0.0;
    for i in first..*end {
        let (xi, yi) = (x[i], y[i]);
        let m = k - i - 1;
        let row = delta.row(i);
        let (xs, ys) = (&x[i + 1..], &y[i + 1..]);
        let local = i - first;
        let (tx_head, txs) = tx.split_at_mut(local + 1);
        let (ty_head, tys) = ty.split_at_mut(local + 1);
        let (ts_head, tss) = ts.split_at_mut(local + 1);
        let (b, r2) = (&mut b[..m], &mut r2[..m]);
        for (((((((&xj, &yj), &dj), bj), rj), txj), tyj), tsj) in xs
            .iter()
            .zip(ys)
            .zip(row)
            .zip(b.iter_mut())
            .zip(r2.iter_mut())
            .zip(txs.iter_mut())
            .zip(tys.iter_mut())
            .zip(tss.iter_mut())
        {
            let (dx, dy) = (xi - xj, yi - yj);
            let d = (dx * dx + dy * dy).sqrt();
            let r = d - dj;
            *rj = r * r;
            let bij = nonzero_or_zero(dj / d, d);
            *bj = bij;
            *txj += bij * xi;
            *tyj += bij * yi;
            *tsj += bij;
        }
        let mut ax = [0.0; LANES];
        let mut ay = [0.0; LANES];
        let mut as_ = [0.0; LANES];
        let mut st = [0.0; LANES];
        let full = m / LANES * LANES;
        for (((bc, rc), xc), yc) in b[..full]
            .chunks_exact(LANES)
            .zip(r2[..full].chunks_exact(LANES))
            .zip(xs[..full].chunks_exact(LANES))
            .zip(ys[..full].chunks_exact(LANES))
        {
            for l in 0..LANES {
                ax[l] += bc[l] * xc[l];
                ay[l] += bc[l] * yc[l];
                as_[l] += bc[l];
                st[l] += rc[l];
            }
        }
        let (mut sx, mut sy, mut ss, mut sst) = (0.0, 0.0, 0.0, 0.0);
        for j in full..m {
            sx += b[j] * xs[j];
            sy += b[j] * ys[j];
            ss += b[j];
            sst += r2[j];
        }
        for l in 0..LANES {
            sx += ax[l];
            sy += ay[l];
            ss += as_[l];
            sst += st[l];
        }
        tx_head[local] += sx;
        ty_head[local] += sy;
        ts_head[local] += ss;
        stress += sst;
    }
    *block_stress = stress;
}

/// `Δ²u` and `Δ²v` into `out_u`, `out_v` (`Δ²` the squared scaled distances, zero on the
/// diagonal): the blocks of rows in parallel, then their sums in block order, as in
/// [`guttman`], so the result is the same on any number of threads.
fn squared_products(
    delta: &UpperTriangle,
    blocks: &mut [Block],
    u: &[f64],
    v: &[f64],
    out_u: &mut [f64],
    out_v: &mut [f64],
) {
    blocks
        .par_iter_mut()
        .for_each(|block| pulp::Arch::new().dispatch(SquaredSweep { delta, u, v, block }));
    out_u.fill(0.0);
    out_v.fill(0.0);
    let k = delta.k;
    for block in blocks.iter() {
        let f = block.first;
        for ((i, &a), &b) in (f..k).zip(&block.tx).zip(&block.ty) {
            out_u[i] += a;
            out_v[i] += b;
        }
    }
}

/// [`squared_sweep`] as a `pulp` operation (see [`Sweep`]).
struct SquaredSweep<'a> {
    delta: &'a UpperTriangle,
    u: &'a [f64],
    v: &'a [f64],
    block: &'a mut Block,
}

impl pulp::WithSimd for SquaredSweep<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        squared_sweep(self.delta, self.u, self.v, self.block)
    }
}

/// One block's share of [`squared_products`]: for its rows `i` and every `j > i`, adds
/// `δ²_ij·u_j` to row `i`'s sums and `δ²_ij·u_i` to row `j`'s (and the same for `v`), into the
/// block's `tx` (for `u`) and `ty` (for `v`). Laid out as [`sweep`]: an element-wise loop, then
/// sums over `LANES` accumulators.
#[inline(always)]
fn squared_sweep(delta: &UpperTriangle, u: &[f64], v: &[f64], block: &mut Block) {
    let Block {
        first,
        end,
        tx,
        ty,
        b,
        ..
    } = block;
    let first = *first;
    tx.fill(0.0);
    ty.fill(0.0);
    for i in first..*end {
        let row = delta.row(i);
        let m = row.len();
        let (ui, vi) = (u[i], v[i]);
        let (us, vs) = (&u[i + 1..], &v[i + 1..]);
        let local = i - first;
        let (tx_head, txs) = tx.split_at_mut(local + 1);
        let (ty_head, tys) = ty.split_at_mut(local + 1);
        let sq = &mut b[..m];
        for (((&d, s), tj), yj) in row
            .iter()
            .zip(sq.iter_mut())
            .zip(txs.iter_mut())
            .zip(tys.iter_mut())
        {
            let d2 = d * d;
            *s = d2;
            *tj += d2 * ui;
            *yj += d2 * vi;
        }
        let (mut au, mut av) = ([0.0; LANES], [0.0; LANES]);
        let full = m / LANES * LANES;
        for ((sc, uc), vc) in sq[..full]
            .chunks_exact(LANES)
            .zip(us[..full].chunks_exact(LANES))
            .zip(vs[..full].chunks_exact(LANES))
        {
            for l in 0..LANES {
                au[l] += sc[l] * uc[l];
                av[l] += sc[l] * vc[l];
            }
        }
        let (mut su, mut sv) = (0.0, 0.0);
        for j in full..m {
            su += sq[j] * us[j];
            sv += sq[j] * vs[j];
        }
        for l in 0..LANES {
            su += au[l];
            sv += av[l];
        }
        tx_head[local] += su;
        ty_head[local] += sv;
    }
}

/// Most subspace-iteration steps of [`classical`] (each two K×K products).
const CLASSICAL_STEPS: usize = 100;

/// Classical scaling (Torgerson 1952; Borg & Groenen 2005, ch. 12): the two leading
/// eigenvectors of `B = −½ J Δ² J` (`Δ²` the squared distances, `J` the centring matrix),
/// scaled by the square roots of their eigenvalues, as x and y coordinates (in the triangle's
/// scaled units). The eigenvectors come from subspace iteration on `B` from a fixed start,
/// orthonormalised at every step, until the pair moves by less than 1e-6 (1 − |cos|) or after
/// [`CLASSICAL_STEPS`] steps: a start for SMACOF needs no more. `B` is never formed:
/// `(Bu)_i = −½ ((Δ²u)_i − r_i·Σu − r·u + g·Σu)`, `r` the row means of `Δ²` and `g` their
/// mean, so a product is one pass over the packed triangle ([`squared_products`]). Subspace
/// iteration finds the eigenvalues of largest magnitude; `None` when either is not positive
/// (every distance 0, or a non-Euclidean matrix whose most negative eigenvalue dominates), so
/// that the caller falls back to a random start.
fn classical(delta: &UpperTriangle, blocks: &mut [Block]) -> Option<(Vec<f64>, Vec<f64>)> {
    let k = delta.k;
    let dot = |a: &[f64], c: &[f64]| a.iter().zip(c).map(|(x, y)| x * y).sum::<f64>();
    let ones = vec![1.0; k];
    let (mut r, mut unused) = (vec![0.0; k], vec![0.0; k]);
    squared_products(delta, blocks, &ones, &ones, &mut r, &mut unused);
    r.iter_mut().for_each(|x| *x /= k as f64);
    let g = r.iter().sum::<f64>() / k as f64;
    // Bu and Bv from Δ²u and Δ²v
    let mut products = |u: &[f64], v: &[f64], bu: &mut [f64], bv: &mut [f64]| {
        squared_products(delta, blocks, u, v, bu, bv);
        for (w, out) in [(u, bu), (v, bv)] {
            let (sum, ru) = (w.iter().sum::<f64>(), dot(&r, w));
            for (o, &ri) in out.iter_mut().zip(&r) {
                *o = -0.5 * (*o - ri * sum - ru + g * sum);
            }
        }
    };
    // a fixed, non-symmetric start: not orthogonal to the leading pair for any real shape
    let mut u: Vec<f64> = (0..k)
        .map(|i| ((i * 7919) % 1013) as f64 / 1013.0 - 0.5)
        .collect();
    let mut v: Vec<f64> = (0..k)
        .map(|i| ((i * 104_729) % 997) as f64 / 997.0 - 0.5)
        .collect();
    let (mut bu, mut bv) = (vec![0.0; k], vec![0.0; k]);
    for _ in 0..CLASSICAL_STEPS {
        products(&u, &v, &mut bu, &mut bv);
        // Gram–Schmidt: u ← Bu/|Bu|, v ← Bv ⟂ u, normalised
        let nu = dot(&bu, &bu).sqrt();
        if nu.is_nan() || nu <= 0.0 {
            return None;
        }
        bu.iter_mut().for_each(|x| *x /= nu);
        let p = dot(&bv, &bu);
        bv.iter_mut().zip(&bu).for_each(|(x, y)| *x -= p * y);
        let nv = dot(&bv, &bv).sqrt();
        if nv.is_nan() || nv <= 0.0 {
            return None;
        }
        bv.iter_mut().for_each(|x| *x /= nv);
        let moved = 1.0 - dot(&bu, &u).abs().min(dot(&bv, &v).abs());
        std::mem::swap(&mut u, &mut bu);
        std::mem::swap(&mut v, &mut bv);
        if moved < 1e-6 {
            break;
        }
    }
    // Rayleigh quotients of the converged pair
    products(&u, &v, &mut bu, &mut bv);
    let (eu, ev) = (dot(&u, &bu), dot(&v, &bv));
    if !(eu > 0.0 && ev > 0.0) {
        return None;
    }
    let (su, sv) = (eu.sqrt(), ev.sqrt());
    Some((
        u.iter().map(|x| x * su).collect(),
        v.iter().map(|x| x * sv).collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_test_support::great_circle_matrix as sphere_matrix;
    use proptest::prelude::*;
    use rand::Rng;

    fn random_points(n: usize, seed: u64) -> Vec<[f64; 2]> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| [rng.random::<f64>() * 10.0, rng.random::<f64>() * 10.0])
            .collect()
    }

    fn dist_matrix(p: &[[f64; 2]]) -> Vec<f64> {
        let k = p.len();
        let mut d = vec![0.0; k * k];
        for i in 0..k {
            for j in 0..k {
                d[i * k + j] = ((p[i][0] - p[j][0]).powi(2) + (p[i][1] - p[j][1]).powi(2)).sqrt();
            }
        }
        d
    }

    fn sum_sq_upper(d: &[f64], k: usize) -> f64 {
        let mut s = 0.0;
        for i in 0..k {
            for j in i + 1..k {
                s += d[i * k + j] * d[i * k + j];
            }
        }
        s
    }

    #[test]
    fn recovers_an_exactly_embeddable_planar_set() {
        let p = random_points(30, 7);
        let d = dist_matrix(&p);
        let e = smacof(&d, 30, &SmacofParams::default()).unwrap();
        let normalised = e.stress / sum_sq_upper(&d, 30);
        assert!(normalised < 1e-6, "normalised stress {normalised}");
        // every pairwise distance of the embedding matches the input (rigid motion only)
        let got = dist_matrix(&e.points);
        let max_err = d
            .iter()
            .zip(&got)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(max_err < 1e-2, "max distance error {max_err}");
        // the reported stress is the stress of the returned points
        let recomputed: f64 = (0..30)
            .flat_map(|i| (i + 1..30).map(move |j| (i, j)))
            .map(|(i, j)| (got[i * 30 + j] - d[i * 30 + j]).powi(2))
            .sum();
        assert!((recomputed - e.stress).abs() <= 1e-9 * (1.0 + e.stress));
    }

    #[test]
    fn the_classical_start_is_the_planar_set_itself() {
        // an exactly planar set (coordinates in [0, 10]): classical scaling recovers it up to
        // the subspace iteration's tolerance, and SMACOF finishes it in a few transforms
        let p = random_points(40, 11);
        let d = dist_matrix(&p);
        let t = UpperTriangle::new(&d, 40).unwrap();
        let (x, y) = classical(&t, &mut blocks(40)).unwrap();
        let got: Vec<[f64; 2]> = x
            .iter()
            .zip(&y)
            .map(|(&a, &b)| [a * t.unit, b * t.unit])
            .collect();
        let err = d
            .iter()
            .zip(&dist_matrix(&got))
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 0.02, "max distance error {err}");
        let params = SmacofParams {
            starts: 1,
            classical_start: true,
            ..Default::default()
        };
        let e = smacof(&d, 40, &params).unwrap();
        assert!(e.stress / sum_sq_upper(&d, 40) < 1e-6);
        // after a single transform the classical start is already there, a random one is not
        let once = |classical_start| {
            let p = SmacofParams {
                starts: 1,
                max_iter: 1,
                classical_start,
                ..Default::default()
            };
            smacof(&d, 40, &p).unwrap().stress / sum_sq_upper(&d, 40)
        };
        assert!(once(true) < 1e-5, "{}", once(true));
        assert!(once(false) > 1e-3, "{}", once(false));
    }

    #[test]
    fn a_classical_start_does_not_depend_on_the_seed_and_falls_back_when_degenerate() {
        let d = sphere_matrix(50, 2);
        let with = |seed| SmacofParams {
            starts: 1,
            classical_start: true,
            seed,
            ..Default::default()
        };
        assert_eq!(
            smacof(&d, 50, &with(0)).unwrap(),
            smacof(&d, 50, &with(9)).unwrap()
        );
        // on the sphere the classical start is at least as good as the best of four random ones
        let classical_stress = smacof(&d, 50, &with(0)).unwrap().stress;
        let four_random = SmacofParams {
            starts: 4,
            classical_start: false,
            ..Default::default()
        };
        let random = smacof(&d, 50, &four_random).unwrap().stress;
        assert!(
            classical_stress <= random * 1.05,
            "{classical_stress} vs {random}"
        );
        // every distance 0: no classical solution, a random start instead (and zero stress)
        let zero = vec![0.0; 16];
        assert!(classical(&UpperTriangle::new(&zero, 4).unwrap(), &mut blocks(4)).is_none());
        let e = smacof(&zero, 4, &with(0)).unwrap();
        assert_eq!(e.stress, 0.0);
    }

    #[test]
    fn deterministic_for_a_seed_whatever_the_thread_count() {
        let d = sphere_matrix(60, 3);
        let params = SmacofParams {
            seed: 42,
            ..Default::default()
        };
        let a = smacof(&d, 60, &params).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| smacof(&d, 60, &params)).unwrap();
        assert_eq!(a, b);
        let c = smacof(
            &d,
            60,
            &SmacofParams {
                seed: 43,
                ..params.clone()
            },
        )
        .unwrap();
        assert_ne!(a.points, c.points);
    }

    #[test]
    fn blocks_cover_every_row_once_and_the_packed_rows_are_the_upper_triangle() {
        for k in [0usize, 1, 2, 3, 257, 400, 1500] {
            let bs = blocks(k);
            assert!(bs.len() <= MAX_BLOCKS);
            let mut next = 0;
            for b in &bs {
                assert_eq!(b.first, next);
                assert!(b.end > b.first);
                next = b.end;
            }
            assert_eq!(next, k, "k = {k}");
            if k > 256 {
                assert!(bs.len() > 1, "k = {k}: {} block", bs.len());
            }
        }
        let k = 37;
        let d = sphere_matrix(k, 4);
        let t = UpperTriangle::new(&d, k).unwrap();
        assert_eq!(UpperTriangle::from_square(d.clone(), k).unwrap(), t);
        assert!(UpperTriangle::from_square(vec![0.0; 5], 2).is_err());
        let max = upper_max(&d, k);
        assert!((0.5..1.0).contains(&(max / t.unit)), "{max} / {}", t.unit);
        assert_eq!(t.max * t.unit, max);
        assert_eq!(t.values.len(), k * (k - 1) / 2);
        for i in 0..k {
            for j in i + 1..k {
                assert_eq!(t.row(i)[j - i - 1] * t.unit, d[i * k + j]);
            }
        }
    }

    /// One transform of the blocked sweep against the textbook formula on the full matrix,
    /// `x_i ← (1/K)·Σ_{j≠i} b_ij·(x_i − x_j)`, over several blocks.
    #[test]
    fn one_transform_matches_the_formula() {
        let k = 300;
        let d = sphere_matrix(k, 8);
        let params = SmacofParams {
            starts: 1,
            classical_start: false,
            max_iter: 1,
            rel_tol: 0.0,
            seed: 3,
            relaxation: 1.0,
        };
        assert!(blocks(k).len() > 1);
        // the random start run_start draws, then one transform by the formula
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        rng.set_stream(0);
        let l = upper_max(&d, k);
        let x0: Vec<[f64; 2]> = (0..k)
            .map(|_| [rng.random::<f64>() * l, rng.random::<f64>() * l])
            .collect();
        let mut stress0 = 0.0;
        let expected: Vec<[f64; 2]> = (0..k)
            .map(|i| {
                let mut acc = [0.0; 2];
                for j in (0..k).filter(|&j| j != i) {
                    let dist =
                        ((x0[i][0] - x0[j][0]).powi(2) + (x0[i][1] - x0[j][1]).powi(2)).sqrt();
                    if j > i {
                        stress0 += (dist - d[i * k + j]).powi(2);
                    }
                    let b = d[i * k + j] / dist;
                    acc[0] += b * (x0[i][0] - x0[j][0]) / k as f64;
                    acc[1] += b * (x0[i][1] - x0[j][1]) / k as f64;
                }
                acc
            })
            .collect();
        let mut hist = Vec::new();
        let e = run_start(&UpperTriangle::new(&d, k).unwrap(), &params, 0, |s| {
            hist.push(s)
        });
        assert!(
            (hist[0] - stress0).abs() <= 1e-9 * stress0,
            "{} vs {stress0}",
            hist[0]
        );
        for (got, want) in e.points.iter().zip(&expected) {
            for c in 0..2 {
                assert!((got[c] - want[c]).abs() <= 1e-9 * l, "{got:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn the_blocked_sweep_gives_the_same_bits_on_any_number_of_threads() {
        let k = 420;
        let d = sphere_matrix(k, 6);
        let params = SmacofParams {
            starts: 2,
            ..Default::default()
        };
        let on = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| smacof(&d, k, &params))
                .unwrap()
        };
        let one = on(1);
        assert_eq!(one, on(2));
        assert_eq!(one, on(3));
    }

    #[test]
    fn relaxed_transforms_reach_the_plain_stress_in_fewer_steps() {
        let d = sphere_matrix(300, 12);
        let run = |relaxation| {
            let params = SmacofParams {
                starts: 1,
                relaxation,
                ..Default::default()
            };
            smacof(&d, 300, &params).unwrap()
        };
        let (plain, relaxed) = (run(1.0), run(1.5));
        assert!(
            relaxed.iterations < plain.iterations,
            "{} vs {}",
            relaxed.iterations,
            plain.iterations
        );
        assert!(
            relaxed.stress <= plain.stress * 1.001,
            "{} vs {}",
            relaxed.stress,
            plain.stress
        );
        for bad in [0.5, 2.0, f64::NAN] {
            let params = SmacofParams {
                relaxation: bad,
                ..Default::default()
            };
            assert!(matches!(
                smacof(&d, 300, &params),
                Err(ComponentsError::InvalidParameter { .. })
            ));
        }
    }

    #[test]
    fn keeps_the_lowest_stress_start() {
        let d = sphere_matrix(40, 5);
        let params = SmacofParams {
            starts: 6,
            seed: 9,
            ..Default::default()
        };
        let best = smacof(&d, 40, &params).unwrap();
        let each: Vec<f64> = (0..6)
            .map(|s| run_start(&UpperTriangle::new(&d, 40).unwrap(), &params, s, |_| {}).stress)
            .collect();
        let min = each.iter().cloned().fold(f64::INFINITY, f64::min);
        assert_eq!(best.stress, min);
    }

    #[test]
    fn small_and_degenerate_inputs() {
        let p = SmacofParams::default();
        assert_eq!(smacof(&[], 0, &p).unwrap().points.len(), 0);
        assert_eq!(smacof(&[0.0], 1, &p).unwrap().points, vec![[0.0, 0.0]]);
        let e = smacof(&[0.0, 3.0, 3.0, 0.0], 2, &p).unwrap();
        assert_eq!(e.points, vec![[-1.5, 0.0], [1.5, 0.0]]);
        assert_eq!(e.stress, 0.0);
        // all distances zero: every point collapses to one place
        let e = smacof(&[0.0; 9], 3, &p).unwrap();
        assert_eq!(e.stress, 0.0);
        // three collinear points: SMACOF approaches a 1-D solution in the plane only linearly,
        // so the relative-decrease rule stops near (not at) zero stress (Σδ² = 6)
        let e = smacof(&[0.0, 1.0, 2.0, 1.0, 0.0, 1.0, 2.0, 1.0, 0.0], 3, &p).unwrap();
        assert!(e.stress / 6.0 < 1e-4, "{}", e.stress);
    }

    #[test]
    fn rejects_bad_input() {
        let p = SmacofParams::default();
        assert!(matches!(
            smacof(&[0.0; 5], 2, &p),
            Err(ComponentsError::MatrixSize { .. })
        ));
        assert!(matches!(
            smacof(&[0.0, f64::INFINITY, f64::INFINITY, 0.0], 2, &p),
            Err(ComponentsError::BadDistance { i: 0, j: 1, .. })
        ));
        assert!(matches!(
            smacof(&[0.0, -1.0, -1.0, 0.0], 2, &p),
            Err(ComponentsError::BadDistance { .. })
        ));
        assert!(matches!(
            smacof(&[0.0, 1.0, 2.0, 0.0], 2, &p),
            Err(ComponentsError::Asymmetric { i: 0, j: 1, .. })
        ));
        let bad = SmacofParams {
            starts: 0,
            ..Default::default()
        };
        assert!(matches!(
            smacof(&[0.0], 1, &bad),
            Err(ComponentsError::InvalidParameter { .. })
        ));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        /// Majorisation: the stress of successive iterates never increases.
        #[test]
        fn stress_never_increases(
            k in 3usize..40,
            seed in any::<u64>(),
            start in 0u64..4,
            relaxation in prop_oneof![Just(1.0), 1.0f64..1.99],
        ) {
            let d = sphere_matrix(k, seed);
            let params = SmacofParams {
                seed,
                rel_tol: 0.0,
                max_iter: 60,
                relaxation,
                ..Default::default()
            };
            let mut hist = Vec::new();
            run_start(&UpperTriangle::new(&d, k).unwrap(), &params, start, |s| hist.push(s));
            for w in hist.windows(2) {
                prop_assert!(w[1] <= w[0] * (1.0 + 1e-12) + 1e-15, "{} -> {}", w[0], w[1]);
            }
        }
    }
}
