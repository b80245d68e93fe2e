//! The smallest eigenpairs of `W φ = λ M φ` by shift-invert block Lanczos with full
//! reorthogonalisation and thick restart, over a sparse Cholesky factorisation of `W − σM`.
//!
//! Shift-invert: T. Ericsson and A. Ruhe, "The spectral transformation Lanczos method for the
//! numerical solution of large sparse generalized symmetric eigenvalue problems", *Mathematics
//! of Computation* 35(152):1251–1268, 1980. Lanczos: C. Lanczos, "An iteration method for the
//! solution of the eigenvalue problem of linear differential and integral operators", *Journal
//! of Research of the National Bureau of Standards* 45(4):255–282, 1950. Thick restart: K. Wu
//! and H. Simon, "Thick-restart Lanczos method for large symmetric eigenvalue problems", *SIAM
//! Journal on Matrix Analysis and Applications* 22(2):602–616, 2000.
//!
//! See [`crate::spectrum`] for the method's description, parameters and complexity.

use std::time::{Duration, Instant};

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::prelude::{Reborrow, ReborrowMut};
use faer::sparse::linalg::cholesky::{
    LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Accum, Conj, Mat, MatMut, MatRef, Par, Side};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{Result, SpectralError};
use crate::laplacian::Laplacian;
use crate::params::{Method, SpectrumParams};

/// Up to this many unknowns the problem is solved densely (symmetric eigensolver on
/// `M^{-1/2} W M^{-1/2}`): faster than Lanczos at this size, and exact.
pub const DENSE_MAX: usize = 600;

/// A column whose M-norm falls below this fraction of its norm before orthogonalisation is
/// numerically in the span of the basis (block breakdown) and is replaced by a random one.
const BREAKDOWN: f64 = 1e-12;

/// A thick restart keeps the `count` wanted Ritz vectors plus this fraction (1/KEEP_DIVISOR)
/// of the remaining basis columns.
const KEEP_DIVISOR: usize = 3;

/// What the eigensolver returns, in system indices.
pub(crate) struct Eigenpairs {
    /// Eigenvalues, ascending.
    pub values: Vec<f64>,
    /// Eigenvectors, column-major `n × values.len()`, M-orthonormal.
    pub vectors: Vec<f64>,
    pub method: Method,
    pub factorization: Duration,
    pub iteration: Duration,
    pub restarts: usize,
    pub operator_columns: usize,
    pub basis_size: usize,
    pub factor_nonzeros: usize,
    pub solve: Duration,
    pub orthogonalization: Duration,
}

/// The `count` smallest eigenpairs of the Laplacian's pencil.
pub(crate) fn smallest_eigenpairs(
    lap: &Laplacian,
    count: usize,
    params: &SpectrumParams,
) -> Result<Eigenpairs> {
    let n = lap.system_size();
    let count = count.min(n);
    let b = params.block_size;
    let m_max = basis_size(count, params, n);
    if n <= DENSE_MAX || m_max + b > n {
        return dense(lap, count);
    }
    lanczos(lap, count, m_max, params)
}

/// The number of Ritz columns per cycle (before the residual block), a multiple of the block
/// size: `params.basis_size`, or `max(2·count, count + 8·block)` when that is 0.
pub(crate) fn basis_size(count: usize, params: &SpectrumParams, n: usize) -> usize {
    let b = params.block_size.max(1);
    let want = if params.basis_size == 0 {
        (2 * count).max(count + 8 * b)
    } else {
        params.basis_size.max(count + 2 * b)
    };
    let m = want.div_ceil(b) * b;
    m.min(n.saturating_sub(b) / b * b)
}

/// Dense fallback for small systems: eigen-decomposition of `M^{-1/2} W M^{-1/2}`.
fn dense(lap: &Laplacian, count: usize) -> Result<Eigenpairs> {
    let t0 = Instant::now();
    let n = lap.system_size();
    let isq: Vec<f64> = lap.mass.iter().map(|m| 1.0 / m.sqrt()).collect();
    let mut a = Mat::<f64>::zeros(n, n);
    for r in 0..n {
        for e in lap.row_offsets[r]..lap.row_offsets[r + 1] {
            let c = lap.cols[e] as usize;
            a[(r, c)] = lap.values[e] * isq[r] * isq[c];
        }
    }
    let evd = a
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| SpectralError::DenseEigen {
            detail: format!("{e:?}"),
        })?;
    let s = evd.S().column_vector();
    let u = evd.U();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| s[i].total_cmp(&s[j]));
    let mut values = Vec::with_capacity(count);
    let mut vectors = Vec::with_capacity(n * count);
    for &j in order.iter().take(count) {
        values.push(s[j].max(0.0));
        vectors.extend((0..n).map(|i| u[(i, j)] * isq[i]));
    }
    Ok(Eigenpairs {
        values,
        vectors,
        method: Method::Dense,
        factorization: Duration::ZERO,
        iteration: t0.elapsed(),
        restarts: 0,
        operator_columns: 0,
        basis_size: n,
        factor_nonzeros: 0,
        solve: Duration::ZERO,
        orthogonalization: Duration::ZERO,
    })
}

/// The shift-invert operator `x ↦ (W − σM)⁻¹ M x` over a sparse Cholesky factor.
pub(crate) struct Operator<'a> {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
    mass: &'a [f64],
}

impl<'a> Operator<'a> {
    pub(crate) fn new(lap: &'a Laplacian, sigma: f64, par: Par) -> Result<Self> {
        let fail = |detail: String| SpectralError::Factorization { detail };
        let n = lap.system_size();
        let mut trip = Vec::with_capacity(lap.nonzeros() / 2 + n);
        for r in 0..n {
            for e in lap.row_offsets[r]..lap.row_offsets[r + 1] {
                let c = lap.cols[e] as usize;
                if c >= r {
                    let v = if c == r {
                        lap.values[e] - sigma * lap.mass[r]
                    } else {
                        lap.values[e]
                    };
                    // lower triangle: row c, column r
                    trip.push(Triplet::new(c, r, v));
                }
            }
        }
        let k = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &trip)
            .map_err(|e| fail(format!("{e:?}")))?;
        let symbolic = factorize_symbolic_cholesky(
            k.symbolic(),
            Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| fail(format!("{e:?}")))?;
        let mut values = vec![0.0; symbolic.len_val()];
        let mut mem = MemBuffer::try_new(
            symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()),
        )
        .map_err(|e| fail(format!("{e:?}")))?;
        symbolic
            .factorize_numeric_llt(
                &mut values,
                k.as_ref(),
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|e| fail(format!("{e:?}")))?;
        Ok(Operator {
            symbolic,
            values,
            mass: &lap.mass,
        })
    }

    /// Non-zeros of the Cholesky factor.
    fn factor_nonzeros(&self) -> usize {
        self.values.len()
    }

    /// `out = (W − σM)⁻¹ M x`. The triangular solves run sequentially per column group, the
    /// groups in parallel on the rayon pool: faer's own parallel solve spends more time
    /// dispatching tiny supernodes than solving.
    pub(crate) fn apply(&self, x: MatRef<'_, f64>, mut out: MatMut<'_, f64>) {
        for j in 0..x.ncols() {
            for i in 0..x.nrows() {
                out[(i, j)] = self.mass[i] * x[(i, j)];
            }
        }
        let chunk = x.ncols().div_ceil(rayon::current_num_threads().max(1));
        self.solve_split(out, chunk.max(1));
    }

    fn solve_split(&self, x: MatMut<'_, f64>, chunk: usize) {
        if x.ncols() > chunk {
            let mid = x.ncols() / 2;
            let (a, b) = x.split_at_col_mut(mid);
            rayon::join(|| self.solve_split(a, chunk), || self.solve_split(b, chunk));
        } else {
            let llt = LltRef::new(&self.symbolic, &self.values);
            let mut mem = MemBuffer::new(
                self.symbolic
                    .solve_in_place_scratch::<f64>(x.ncols(), Par::Seq),
            );
            llt.solve_in_place_with_conj(Conj::No, x, Par::Seq, MemStack::new(&mut mem));
        }
    }
}

/// M-inner product of two vectors.
fn mdot(mass: &[f64], a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (mc, ac, bc) = (mass.chunks_exact(4), a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = mc
        .remainder()
        .iter()
        .zip(ac.remainder())
        .zip(bc.remainder())
        .map(|((m, x), y)| m * x * y)
        .sum();
    for ((m, x), y) in mc.zip(ac).zip(bc) {
        for l in 0..4 {
            acc[l] += m[l] * x[l] * y[l];
        }
    }
    acc.iter().sum::<f64>() + tail
}

/// `y ← y − c x`.
fn axpy(c: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi -= c * xi;
    }
}

/// The columns of a column-major block with unit row stride as slices (owned `Mat`s and their
/// column ranges are).
fn columns_mut<'a>(x: MatMut<'a, f64>) -> Vec<&'a mut [f64]> {
    let n = x.nrows();
    let mut out = Vec::with_capacity(x.ncols());
    let mut rest = x;
    while rest.ncols() > 0 {
        let (first, tail) = rest.split_at_col_mut(1);
        rest = tail;
        if let Some(c) = first.col_mut(0).try_as_col_major_mut() {
            out.push(c.as_slice_mut());
        }
    }
    debug_assert!(out.iter().all(|c| c.len() == n));
    out
}

/// Makes the block `x` M-orthonormal against `basis` (already M-orthonormal) and within itself.
/// Classical Gram–Schmidt against the basis, twice (CGS2, BLAS-3), then modified Gram–Schmidt
/// within the block, twice. Adds the basis coefficients to `coef` (`basis.ncols() × b`) and
/// writes the block's own triangular factor to `r` (`b × b`), so that
/// `x_in = basis · coef + x_out · r`. A column that is numerically in the span (breakdown) is
/// replaced by a random M-orthonormal one and gets `r[i][i] = 0`.
fn orthonormalize(
    basis: MatRef<'_, f64>,
    mut x: MatMut<'_, f64>,
    mass: &[f64],
    mut coef: Option<MatMut<'_, f64>>,
    mut r: Option<MatMut<'_, f64>>,
    rng: &mut ChaCha8Rng,
    par: Par,
) -> Result<()> {
    let b = x.ncols();
    let norm0: Vec<f64> = columns_mut(x.rb_mut())
        .iter()
        .map(|c| mdot(mass, c, c).sqrt())
        .collect();
    project_out(
        basis,
        x.rb_mut(),
        mass,
        coef.as_mut().map(|c| c.rb_mut()),
        par,
    );
    for i in 0..b {
        let mut diag = 0.0;
        let mut attempts = 0;
        let mut reference = norm0[i];
        loop {
            let (done, mut cur) = x.rb_mut().split_at_col_mut(i);
            let done = columns_mut(done);
            let cur = columns_mut(cur.rb_mut().subcols_mut(0, 1));
            let Some(cur) = cur.into_iter().next() else {
                break;
            };
            for _ in 0..2 {
                for (j, xj) in done.iter().enumerate() {
                    let c = mdot(mass, xj, cur);
                    axpy(c, xj, cur);
                    if attempts == 0
                        && let Some(r) = r.as_mut()
                    {
                        r[(j, i)] += c;
                    }
                }
            }
            let nrm = mdot(mass, cur, cur).sqrt();
            if attempts == 0 {
                diag = nrm;
            }
            if nrm > BREAKDOWN * reference && nrm > 0.0 {
                let inv = 1.0 / nrm;
                cur.iter_mut().for_each(|v| *v *= inv);
                break;
            }
            // breakdown: a fresh random direction, orthogonal to everything so far
            attempts += 1;
            diag = 0.0;
            if attempts > 3 {
                return Err(SpectralError::DenseEigen {
                    detail: "Krylov basis exhausted: the mesh has too few vertices for the \
                             requested basis size"
                        .to_string(),
                });
            }
            cur.iter_mut()
                .for_each(|v| *v = rng.random_range(-1.0..1.0));
            reference = mdot(mass, cur, cur).sqrt();
            project_out(basis, x.rb_mut().subcols_mut(i, 1), mass, None, par);
        }
        if let Some(r) = r.as_mut() {
            r[(i, i)] = diag;
        }
    }
    Ok(())
}

/// `x ← x − basis (basisᵀ M x)`, twice; accumulates the coefficients into `coef`.
fn project_out(
    basis: MatRef<'_, f64>,
    mut x: MatMut<'_, f64>,
    mass: &[f64],
    mut coef: Option<MatMut<'_, f64>>,
    par: Par,
) {
    if basis.ncols() == 0 {
        return;
    }
    let (n, b) = (x.nrows(), x.ncols());
    let mut mx = Mat::<f64>::zeros(n, b);
    let mut c = Mat::<f64>::zeros(basis.ncols(), b);
    for _ in 0..2 {
        for (dst, src) in columns_mut(mx.as_mut())
            .into_iter()
            .zip(columns_mut(x.rb_mut()))
        {
            for ((d, s), m) in dst.iter_mut().zip(src.iter()).zip(mass) {
                *d = m * s;
            }
        }
        faer::linalg::matmul::matmul(
            c.as_mut(),
            Accum::Replace,
            basis.transpose(),
            mx.as_ref(),
            1.0,
            par,
        );
        faer::linalg::matmul::matmul(x.rb_mut(), Accum::Add, basis, c.as_ref(), -1.0, par);
        if let Some(coef) = coef.as_mut() {
            for j in 0..b {
                for i in 0..basis.ncols() {
                    coef[(i, j)] += c[(i, j)];
                }
            }
        }
    }
}

/// Shift-invert block Lanczos with thick restart (see [`crate::spectrum`]).
fn lanczos(
    lap: &Laplacian,
    count: usize,
    m_max: usize,
    params: &SpectrumParams,
) -> Result<Eigenpairs> {
    let par = faer::get_global_parallelism();
    let n = lap.system_size();
    let b = params.block_size;
    let mass = &lap.mass[..];
    let sigma = -params.shift / lap.area();

    let t0 = Instant::now();
    let op = Operator::new(lap, sigma, par)?;
    let factorization = t0.elapsed();
    let t1 = Instant::now();

    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    // V: n × (m_max + b) M-orthonormal columns; H: the projected operator, with
    // Op V[:, 0..c] = V[:, 0..c+b] H[0..c+b, 0..c].
    let cap = m_max + b;
    let mut v = Mat::<f64>::zeros(n, cap);
    let mut h = Mat::<f64>::zeros(cap, cap);
    for j in 0..b {
        for i in 0..n {
            v[(i, j)] = rng.random_range(-1.0..1.0);
        }
    }
    let empty = Mat::<f64>::zeros(n, 0);
    orthonormalize(
        empty.as_ref(),
        v.as_mut().subcols_mut(0, b),
        mass,
        None,
        None,
        &mut rng,
        par,
    )?;
    let mut c = 0; // columns to which Op has been applied
    let mut x = Mat::<f64>::zeros(n, b);
    let mut restarts = 0;
    let mut operator_columns = 0;
    let mut solve_time = Duration::ZERO;
    let mut orth_time = Duration::ZERO;
    loop {
        // extend the basis
        while c + b <= m_max {
            let ta = Instant::now();
            op.apply(v.as_ref().subcols(c, b), x.as_mut());
            solve_time += ta.elapsed();
            let ta = Instant::now();
            operator_columns += b;
            let (basis, _) = v.as_mut().split_at_col_mut(c + b);
            let (hcoef, hrest) = h
                .as_mut()
                .submatrix_mut(0, c, cap, b)
                .split_at_row_mut(c + b);
            orthonormalize(
                basis.rb(),
                x.as_mut(),
                mass,
                Some(hcoef),
                Some(hrest.subrows_mut(0, b)),
                &mut rng,
                par,
            )?;
            v.as_mut().subcols_mut(c + b, b).copy_from(x.as_ref());
            orth_time += ta.elapsed();
            c += b;
        }

        // Rayleigh–Ritz on the projected (symmetrised) matrix
        let mut t = Mat::<f64>::zeros(c, c);
        for j in 0..c {
            for i in 0..c {
                t[(i, j)] = 0.5 * (h[(i, j)] + h[(j, i)]);
            }
        }
        let evd = t
            .self_adjoint_eigen(Side::Lower)
            .map_err(|e| SpectralError::DenseEigen {
                detail: format!("{e:?}"),
            })?;
        let theta_all = evd.S().column_vector();
        // descending θ = ascending λ
        let order: Vec<usize> = (0..c).rev().collect();
        let mut y = Mat::<f64>::zeros(c, c);
        let mut theta = vec![0.0; c];
        for (k, &j) in order.iter().enumerate() {
            theta[k] = theta_all[j];
            y.col_mut(k).copy_from(evd.U().col(j));
        }
        // residual coupling S = H[c..c+b, 0..c] · Y
        let mut s = Mat::<f64>::zeros(b, c);
        faer::linalg::matmul::matmul(
            s.as_mut(),
            Accum::Replace,
            h.as_ref().submatrix(c, 0, b, c),
            y.as_ref(),
            1.0,
            par,
        );
        let resid = |k: usize| s.col(k).norm_l2();
        let converged = (0..count)
            .take_while(|&k| theta[k] > 0.0 && resid(k) <= params.tolerance * theta[k])
            .count();
        let done = converged >= count;
        if done || restarts >= params.max_restarts {
            if !done {
                return Err(SpectralError::NotConverged {
                    converged,
                    requested: count,
                    restarts,
                });
            }
            let mut phi = Mat::<f64>::zeros(n, count);
            faer::linalg::matmul::matmul(
                phi.as_mut(),
                Accum::Replace,
                v.as_ref().subcols(0, c),
                y.as_ref().subcols(0, count),
                1.0,
                par,
            );
            let values: Vec<f64> = theta[..count]
                .iter()
                .map(|&t| (sigma + 1.0 / t).max(0.0))
                .collect();
            let mut vectors = Vec::with_capacity(n * count);
            for c in columns_mut(phi.as_mut()) {
                vectors.extend_from_slice(c);
            }
            return Ok(Eigenpairs {
                values,
                vectors,
                method: Method::Lanczos,
                factorization,
                iteration: t1.elapsed(),
                restarts,
                operator_columns,
                basis_size: m_max,
                factor_nonzeros: op.factor_nonzeros(),
                solve: solve_time,
                orthogonalization: orth_time,
            });
        }

        // thick restart: keep p Ritz vectors and the residual block
        restarts += 1;
        // keep the wanted pairs plus a third of the rest, but leave room for two new blocks
        // when the basis allows (one new block per cycle converges very slowly)
        let p = (count + (m_max - count) / KEEP_DIVISOR)
            .min((m_max.saturating_sub(2 * b)).max(count))
            .min(m_max - b);
        let mut kept = Mat::<f64>::zeros(n, p);
        faer::linalg::matmul::matmul(
            kept.as_mut(),
            Accum::Replace,
            v.as_ref().subcols(0, c),
            y.as_ref().subcols(0, p),
            1.0,
            par,
        );
        for j in 0..b {
            let src = v.col(c + j).to_owned();
            v.col_mut(p + j).copy_from(&src);
        }
        v.as_mut().subcols_mut(0, p).copy_from(kept.as_ref());
        h.fill(0.0);
        for k in 0..p {
            h[(k, k)] = theta[k];
            for i in 0..b {
                // the symmetric entries H[k, p + i] come from orthogonalising Op applied to
                // the residual block in the next extension
                h[(p + i, k)] = s[(i, k)];
            }
        }
        c = p;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use keycomp_mesh::synth;

    #[test]
    fn lanczos_agrees_with_the_dense_solver() {
        // a torus has no large multiplicities' worth of symmetry problems and many distinct
        // eigenvalues; 1,200 unknowns
        let mesh = synth::torus(2.0, 0.7, 40, 30);
        let lap = Laplacian::new(&mesh).expect("valid");
        let params = SpectrumParams::default();
        let count = 60;
        let dense = dense(&lap, count).expect("dense");
        let m = basis_size(count, &params, lap.system_size());
        let lz = lanczos(&lap, count, m, &params).expect("converges");
        assert_eq!(lz.method, Method::Lanczos);
        for (a, b) in dense.values.iter().zip(&lz.values) {
            assert!((a - b).abs() < 1e-8 * a.max(1.0), "{a} vs {b}");
        }
        // eigenvectors agree up to sign where the eigenvalue is simple
        let n = lap.system_size();
        for j in 1..count {
            let gap = |k: usize| (dense.values[k] - dense.values[j]).abs();
            if gap(j - 1) < 1e-6 || (j + 1 < count && gap(j + 1) < 1e-6) {
                continue;
            }
            let (u, v) = (
                &dense.vectors[j * n..(j + 1) * n],
                &lz.vectors[j * n..(j + 1) * n],
            );
            let d = mdot(&lap.mass, u, v).abs();
            if j + 1 == count {
                break; // its partner may lie beyond the computed pairs
            }
            assert!((d - 1.0).abs() < 1e-8, "pair {j}: |⟨u, v⟩_M| = {d}");
        }
    }

    #[test]
    fn small_basis_needs_restarts_but_converges() {
        let mesh = synth::torus(2.0, 0.7, 40, 30);
        let lap = Laplacian::new(&mesh).expect("valid");
        let params = SpectrumParams {
            basis_size: 40,
            ..Default::default()
        };
        let count = 20;
        let m = basis_size(count, &params, lap.system_size());
        assert_eq!(m, 40);
        let lz = lanczos(&lap, count, m, &params).expect("converges");
        assert!(lz.restarts > 0);
        let dense = dense(&lap, count).expect("dense");
        for (a, b) in dense.values.iter().zip(&lz.values) {
            assert!((a - b).abs() < 1e-8 * a.max(1.0), "{a} vs {b}");
        }
    }
}
