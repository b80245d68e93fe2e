//! The low Laplace–Beltrami spectrum of a mesh: the `k` smallest eigenpairs of the generalised
//! problem `W φ = λ M φ` ([`crate::laplacian`]), eigenvectors M-orthonormal
//! (`φ_iᵀ M φ_j = δ_ij`), computed by a sparse method.
//!
//! Method: shift-invert block Lanczos with full reorthogonalisation and thick restart.
//! C. Lanczos, "An iteration method for the solution of the eigenvalue problem of linear
//! differential and integral operators", *J. Res. Nat. Bur. Standards* 45(4):255–282, 1950;
//! T. Ericsson and A. Ruhe, "The spectral transformation Lanczos method for the numerical
//! solution of large sparse generalized symmetric eigenvalue problems", *Mathematics of
//! Computation* 35(152):1251–1268, 1980; K. Wu and H. Simon, "Thick-restart Lanczos method for
//! large symmetric eigenvalue problems", *SIAM J. Matrix Anal. Appl.* 22(2):602–616, 2000.
//!
//! # Steps
//!
//! 1. **Assemble** `W` and `M` ([`Laplacian::new`]).
//! 2. **Factorise** `K = W − σM` by sparse supernodal Cholesky (`faer`, AMD fill-reducing
//!    ordering), with `σ = −shift / area` ([`SpectrumParams::shift`], default `−1/area`): `W`
//!    is only positive semi-definite (constants are in its kernel); the negative shift makes `K`
//!    positive definite. The eigenvalues are recovered exactly (`λ = σ + 1/θ`); the shift only
//!    affects convergence and conditioning (see the parameter).
//! 3. **Shift-invert**: the operator `Op = K⁻¹ M` is self-adjoint in the M-inner product
//!    `⟨x, y⟩_M = xᵀ M y` and has eigenvalues `θ = 1/(λ − σ)`, so the *smallest* `λ` become the
//!    *largest*, best separated `θ` — the ones Krylov methods find first.
//! 4. **Block Lanczos**: from a seeded random block of `b` M-orthonormal columns, apply `Op` to
//!    the newest block (one multi-right-hand-side Cholesky solve), orthogonalise the result
//!    against the whole basis twice (classical Gram–Schmidt, BLAS-3) and within itself
//!    (modified Gram–Schmidt), append it, until the basis has `m` columns. The coefficients form
//!    the projected matrix `H` with `Op V_m = V_{m+b} H`. A block (rather than one vector)
//!    finds eigenvalues of multiplicity up to `b` — symmetric meshes (the sphere's `2l + 1`,
//!    identical disconnected pieces) have them.
//! 5. **Rayleigh–Ritz**: eigen-decompose the symmetrised `H[0..m, 0..m] = Y Θ Yᵀ` (dense,
//!    `m × m`); Ritz pairs `(θ_i, V y_i)`. The residual of a Ritz pair of `Op` is
//!    `‖Op x − θ x‖_M = ‖H[m..m+b, 0..m] y_i‖` (no extra solve). Pair `i` has converged when
//!    this is `≤ tolerance · θ_i`.
//! 6. **Stop** when the `count` leading pairs have converged: `λ_i = σ + 1/θ_i`, `φ_i = V y_i`.
//!    Otherwise **thick restart**: keep the `count + (m − count)/3` leading Ritz vectors (fewer
//!    if needed to leave room for two new blocks) and the residual block (the projected matrix becomes diagonal plus one coupling block row) and go
//!    back to 4.
//! 7. **Check**: for every pair the true relative residual
//!    `‖W φ − λ M φ‖_{M⁻¹} / max(λ, 1/area)` is computed and stored
//!    ([`Spectrum::residuals`]); the M-norm dual `‖r‖_{M⁻¹} = √(Σ r_i² / m_i)` makes it
//!    independent of the mesh resolution.
//!
//! Up to [`DENSE_MAX_VERTICES`] unknowns (and whenever the basis would not fit) the pencil is
//! solved densely instead (symmetric eigensolver on `M^{-1/2} W M^{-1/2}`), exact and faster at
//! that size; [`SolveStats::method`] says which ran.
//!
//! A thick restart whose wanted set ends inside a cluster of nearly equal eigenvalues converges
//! slowly when the basis is barely larger than `count`; the default basis (`2·count`) avoids
//! that.
//!
//! Results are deterministic for a given seed, machine and thread count (the rayon-parallel
//! BLAS kernels may round differently with a different number of threads).
//!
//! # Complexity
//!
//! With `n` vertices, `k` eigenpairs, `m ≈ 2k` basis columns and `|L|` non-zeros in the
//! Cholesky factor (about 2·10⁶ for the 50k-vertex `nefertiti`, [`SolveStats::factor_nonzeros`]): factorisation
//! `O(|L|^{3/2})`-ish once; per restart cycle `(m − p)/b` block solves of `O(|L| b)`, the
//! orthogonalisation `O(n m²)` and the dense Ritz problem `O(m³)`. Memory: `n (m + b)` basis
//! doubles plus the factor. Typically 2–4 restart cycles. Multiplicities greater than
//! `block_size` may be missed (rounding usually recovers them, but slowly).
//!
//! Measured (`cargo bench -p keycomp-spectral --bench spectrum_timing -- 100 200 300`,
//! 2-core AMD EPYC VM shared with other builds, so ±30 %): total seconds, factorisation
//! 15–70 ms in every case; the orthogonalisation (memory-bound `O(n m²)`) dominates from
//! 200 pairs on.
//!
//! | mesh | vertices | 100 pairs | 200 pairs | 300 pairs |
//! |---|---|---|---|---|
//! | `icosphere(5)` | 10,242 | 0.24 s | 0.50 s | 0.83 s |
//! | TOSCA `cat0` | 27,894 | 0.74 s | 1.5 s | 3.2 s |
//! | `nefertiti` | 49,971 | 1.5 s | 3.0 s | 5.1 s |

use std::time::{Duration, Instant};

use keycomp_mesh::Mesh;

use crate::eigen;
use crate::error::Result;
use crate::laplacian::Laplacian;

pub use crate::params::{Method, SpectrumParams};

pub use crate::eigen::DENSE_MAX as DENSE_MAX_VERTICES;

/// Timings and counters of one [`Spectrum::compute`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveStats {
    /// Which solver ran.
    pub method: Method,
    /// Assembling `W` and `M`.
    pub assembly: Duration,
    /// Sparse Cholesky factorisation of `W − σM` (zero for the dense solver).
    pub factorization: Duration,
    /// Lanczos iterations (or the dense eigensolver), including the Ritz vectors.
    pub iteration: Duration,
    /// Of `iteration`: applying the shift-invert operator (sparse triangular solves).
    pub solve: Duration,
    /// Of `iteration`: Gram–Schmidt orthogonalisation of the new blocks.
    pub orthogonalization: Duration,
    /// Everything, including the residual check.
    pub total: Duration,
    /// Thick restarts run.
    pub restarts: usize,
    /// Columns to which the shift-invert operator was applied (one sparse triangular solve
    /// pair each).
    pub operator_columns: usize,
    /// Basis columns per cycle (`n` for the dense solver).
    pub basis_size: usize,
    /// Number of unknowns (referenced vertices).
    pub unknowns: usize,
    /// Non-zeros of the sparse Cholesky factor (0 for the dense solver).
    pub factor_nonzeros: usize,
}

/// The smallest eigenpairs of the Laplace–Beltrami operator of a mesh. Eigenvalues ascending,
/// eigenvectors indexed by mesh vertex id (0 at unreferenced vertices) and M-orthonormal.
#[derive(Debug, Clone)]
pub struct Spectrum {
    values: Vec<f64>,
    /// Column-major `num_vertices × values.len()`.
    vectors: Vec<f64>,
    num_vertices: usize,
    residuals: Vec<f64>,
    masses: Vec<f64>,
    area: f64,
    stats: SolveStats,
}

impl Spectrum {
    /// Computes the `params.count` smallest eigenpairs of `W φ = λ M φ` for `mesh` (see the
    /// module docs for the method).
    ///
    /// Errors: an invalid parameter, a mesh without surface or with bad indices or
    /// coordinates, a failed factorisation, or no convergence within `max_restarts`.
    pub fn compute(mesh: &Mesh, params: &SpectrumParams) -> Result<Spectrum> {
        params.validate()?;
        let t0 = Instant::now();
        let lap = Laplacian::new(mesh)?;
        let assembly = t0.elapsed();
        let pairs = eigen::smallest_eigenpairs(&lap, params.count, params)?;
        let n = lap.system_size();
        let k = pairs.values.len();

        // true residuals ‖Wφ − λMφ‖_{M⁻¹} / max(λ, 1/area)
        let mut residuals = Vec::with_capacity(k);
        let mut wphi = vec![0.0; n];
        for (j, &lambda) in pairs.values.iter().enumerate() {
            let phi = &pairs.vectors[j * n..(j + 1) * n];
            lap.stiffness_mul(phi, &mut wphi);
            let r2: f64 = (0..n)
                .map(|i| {
                    let r = wphi[i] - lambda * lap.mass[i] * phi[i];
                    r * r / lap.mass[i]
                })
                .sum();
            residuals.push(r2.sqrt() / lambda.max(1.0 / lap.area()));
        }

        let nv = lap.num_mesh_vertices();
        let mut vectors = vec![0.0; nv * k];
        for j in 0..k {
            let src = &pairs.vectors[j * n..(j + 1) * n];
            let dst = &mut vectors[j * nv..(j + 1) * nv];
            for (s, &v) in lap.vertices.iter().enumerate() {
                dst[v as usize] = src[s];
            }
        }
        let stats = SolveStats {
            method: pairs.method,
            assembly,
            factorization: pairs.factorization,
            iteration: pairs.iteration,
            solve: pairs.solve,
            orthogonalization: pairs.orthogonalization,
            total: t0.elapsed(),
            restarts: pairs.restarts,
            operator_columns: pairs.operator_columns,
            basis_size: pairs.basis_size,
            unknowns: n,
            factor_nonzeros: pairs.factor_nonzeros,
        };
        Ok(Spectrum {
            values: pairs.values,
            vectors,
            num_vertices: nv,
            residuals,
            masses: lap.masses(),
            area: lap.area(),
            stats,
        })
    }

    /// Number of eigenpairs.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// Whether there are no eigenpairs (never, for a computed spectrum).
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Number of mesh vertices (the length of every eigenvector).
    pub fn num_vertices(&self) -> usize {
        self.num_vertices
    }

    /// Eigenvalues `λ_0 ≤ λ_1 ≤ …`, in mesh units⁻² (`λ_0 = 0` up to rounding; one zero per
    /// connected piece).
    pub fn eigenvalues(&self) -> &[f64] {
        &self.values
    }

    /// Eigenvector `i` (M-normalised), one entry per mesh vertex. Panics if `i ≥ len()`.
    pub fn eigenvector(&self, i: usize) -> &[f64] {
        &self.vectors[i * self.num_vertices..(i + 1) * self.num_vertices]
    }

    /// The true relative residual of each pair,
    /// `‖W φ − λ M φ‖_{M⁻¹} / max(λ, 1/area)`.
    pub fn residuals(&self) -> &[f64] {
        &self.residuals
    }

    /// The lumped mass of each mesh vertex (the diagonal of `M`).
    pub fn masses(&self) -> &[f64] {
        &self.masses
    }

    /// Total surface area of the mesh, in mesh units squared.
    pub fn area(&self) -> f64 {
        self.area
    }

    /// Timings and counters of the computation.
    pub fn stats(&self) -> &SolveStats {
        &self.stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::SpectralError;
    use keycomp_mesh::{Point3, synth};
    use proptest::prelude::*;

    fn params(count: usize) -> SpectrumParams {
        SpectrumParams {
            count,
            ..Default::default()
        }
    }

    /// `max |ΦᵀMΦ − I|`.
    fn orthonormality_error(s: &Spectrum) -> f64 {
        let m = s.masses();
        let mut worst: f64 = 0.0;
        for i in 0..s.len() {
            for j in 0..=i {
                let d: f64 = (0..s.num_vertices())
                    .map(|v| m[v] * s.eigenvector(i)[v] * s.eigenvector(j)[v])
                    .sum();
                let target = if i == j { 1.0 } else { 0.0 };
                worst = worst.max((d - target).abs());
            }
        }
        worst
    }

    #[test]
    fn sphere_eigenvalues_are_l_l_plus_1_with_multiplicity_2l_plus_1() {
        // icosphere(5): 10,242 vertices, the Lanczos path. Eigenvalues l(l+1)/r² for
        // l = 0..=6, multiplicity 2l + 1 (49 pairs).
        let r = 1.0;
        let mesh = synth::icosphere(5, r);
        let s = Spectrum::compute(&mesh, &params(49)).expect("converges");
        assert_eq!(s.stats().method, Method::Lanczos);
        let ev = s.eigenvalues();
        assert!(ev[0].abs() < 1e-8, "λ0 = {}", ev[0]);
        for l in 1..=6usize {
            let exact = (l * (l + 1)) as f64 / (r * r);
            // discretisation error grows like l⁴ h²: < 0.1 % for l = 1, 2, < 0.5 % to l = 6
            let tol = if l <= 2 { 1e-3 } else { 5e-3 };
            for (i, &lambda) in ev.iter().enumerate().take((l + 1) * (l + 1)).skip(l * l) {
                let rel = (lambda - exact).abs() / exact;
                assert!(rel < tol, "l = {l}: λ{i} = {lambda} vs {exact} ({rel:.2e})");
            }
        }
        assert!(orthonormality_error(&s) < 1e-8);
        assert!(
            s.residuals().iter().all(|&r| r < 1e-7),
            "{:?}",
            s.residuals()
        );
    }

    #[test]
    fn eigenvalues_scale_with_the_inverse_squared_radius() {
        let s1 = Spectrum::compute(&synth::icosphere(3, 1.0), &params(16)).expect("converges");
        let s2 = Spectrum::compute(&synth::icosphere(3, 2.5), &params(16)).expect("converges");
        for (a, b) in s1.eigenvalues().iter().zip(s2.eigenvalues()).skip(1) {
            assert!((b * 6.25 - a).abs() < 1e-8 * a, "{a} vs {b}");
        }
    }

    #[test]
    fn two_spheres_have_two_zero_eigenvalues() {
        // radii 1 and 0.7: spectra l(l+1) and l(l+1)/0.49 interleave
        let a = synth::icosphere(4, 1.0);
        let b = synth::icosphere(4, 0.7);
        let off = a.num_vertices() as u32;
        let mut mesh = a.clone();
        mesh.positions.extend(
            b.positions
                .iter()
                .map(|p| p + keycomp_mesh::Vector3::new(5.0, 0.0, 0.0)),
        );
        mesh.faces
            .extend(b.faces.iter().map(|f| f.map(|v| v + off)));
        let s = Spectrum::compute(&mesh, &params(12)).expect("converges");
        let ev = s.eigenvalues();
        assert!(ev[0].abs() < 1e-8 && ev[1].abs() < 1e-8, "{ev:?}");
        assert!(ev[2] > 1.9, "{ev:?}");
        for &l in &ev[2..5] {
            assert!((l - 2.0).abs() < 0.01, "{ev:?}");
        }
        for &l in &ev[5..8] {
            assert!((l - 2.0 / 0.49).abs() < 0.03, "{ev:?}");
        }
        // each zero mode is constant on each piece (any rotation of the two indicators)
        for i in 0..2 {
            let phi = s.eigenvector(i);
            let (pa, pb) = phi.split_at(off as usize);
            for piece in [pa, pb] {
                let spread = piece.iter().copied().fold(f64::MIN, f64::max)
                    - piece.iter().copied().fold(f64::MAX, f64::min);
                assert!(spread < 1e-6, "mode {i} varies by {spread} on a piece");
            }
        }
        assert!(orthonormality_error(&s) < 1e-8);
    }

    #[test]
    fn unit_square_with_natural_boundary_conditions() {
        // Neumann eigenvalues of the unit square: π²(a² + b²): 0, π², π², 2π², 4π², 4π²
        let mesh = synth::grid(40, 40, 1.0 / 40.0);
        let s = Spectrum::compute(&mesh, &params(6)).expect("converges");
        assert_eq!(s.stats().method, Method::Lanczos);
        let pi2 = std::f64::consts::PI.powi(2);
        let exact = [0.0, pi2, pi2, 2.0 * pi2, 4.0 * pi2, 4.0 * pi2];
        for (l, e) in s.eigenvalues().iter().zip(exact) {
            assert!((l - e).abs() < 0.01 * e.max(1.0), "{l} vs {e}");
        }
    }

    #[test]
    fn unreferenced_vertices_get_zero_entries() {
        let mesh = synth::icosphere(3, 1.0);
        let mut with_extra = mesh.clone();
        with_extra.positions.insert(0, Point3::new(7.0, 7.0, 7.0));
        for f in &mut with_extra.faces {
            *f = f.map(|v| v + 1);
        }
        let a = Spectrum::compute(&mesh, &params(10)).expect("converges");
        let b = Spectrum::compute(&with_extra, &params(10)).expect("converges");
        for (x, y) in a.eigenvalues().iter().zip(b.eigenvalues()) {
            assert!((x - y).abs() < 1e-9 * x.max(1.0));
        }
        for i in 0..10 {
            assert_eq!(b.eigenvector(i)[0], 0.0);
        }
        assert_eq!(b.hks(0.1)[0], 0.0);
    }

    #[test]
    fn deterministic_for_a_seed() {
        let mesh = synth::torus(2.0, 0.6, 40, 20);
        let a = Spectrum::compute(&mesh, &params(20)).expect("converges");
        let b = Spectrum::compute(&mesh, &params(20)).expect("converges");
        assert_eq!(a.eigenvalues(), b.eigenvalues());
        assert_eq!(a.eigenvector(19), b.eigenvector(19));
    }

    #[test]
    fn invalid_parameters_are_reported() {
        let mesh = synth::icosphere(1, 1.0);
        for p in [
            SpectrumParams {
                count: 0,
                ..Default::default()
            },
            SpectrumParams {
                tolerance: 0.0,
                ..Default::default()
            },
            SpectrumParams {
                block_size: 0,
                ..Default::default()
            },
            SpectrumParams {
                shift: -1.0,
                ..Default::default()
            },
        ] {
            assert!(matches!(
                Spectrum::compute(&mesh, &p),
                Err(SpectralError::InvalidParameter { .. })
            ));
        }
    }

    #[test]
    fn more_pairs_than_vertices_are_clamped() {
        let mesh = synth::icosphere(0, 1.0);
        let s = Spectrum::compute(&mesh, &params(50)).expect("converges");
        assert_eq!(s.len(), 12);
        assert_eq!(s.stats().method, Method::Dense);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]
        /// On jittered spheres (obtuse and skinny triangles): eigenvalues are non-negative and
        /// ascending, one zero, eigenvectors M-orthonormal.
        #[test]
        fn jittered_spheres_have_a_valid_spectrum(seed in any::<u64>(), amp in 0.0f64..0.3) {
            use rand::{Rng, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut mesh = synth::icosphere(2, 1.0);
            for p in &mut mesh.positions {
                for c in 0..3 {
                    p[c] += amp * 0.3 * rng.random_range(-1.0..1.0);
                }
            }
            let s = Spectrum::compute(&mesh, &params(20)).expect("converges");
            let ev = s.eigenvalues();
            prop_assert!(ev[0].abs() < 1e-8);
            prop_assert!(ev[1] > 1e-3);
            prop_assert!(ev.windows(2).all(|w| w[0] <= w[1]));
            prop_assert!(orthonormality_error(&s) < 1e-8);
        }
    }
}
