//! The eigensolver's parameters ([`SpectrumParams`]) and which solver ran ([`Method`]):
//! shared by the spectrum's driver (`spectrum`) and the solvers (`eigen`). The method they
//! steer is described in [`crate::spectrum`].

use crate::error::{Result, SpectralError};

/// Parameters of [`Spectrum::compute`](crate::Spectrum::compute).
#[derive(Debug, Clone, PartialEq)]
pub struct SpectrumParams {
    /// Number of eigenpairs wanted, the zero eigenvalue(s) included. Default 200. More resolve
    /// finer scales of diffusion (the HKS at small `t`); cost grows about quadratically
    /// (orthogonalisation) and memory linearly. Clamped to the number of referenced vertices.
    pub count: usize,
    /// Convergence tolerance on the shift-inverted residual, `‖Op x − θx‖_M ≤ tol · θ`
    /// (dimensionless). Default `1e-10`, which gives true relative residuals
    /// ([`Spectrum::residuals`](crate::Spectrum::residuals)) of `1e-11`–`1e-7` on meshes of 10k–50k vertices. Raising it saves restarts; below about
    /// `1e-13` rounding may prevent convergence.
    pub tolerance: f64,
    /// Maximum number of thick restarts before giving up with
    /// [`SpectralError::NotConverged`]. Default 50 (a handful are typical).
    pub max_restarts: usize,
    /// Block size `b` of the Lanczos method (columns per operator application). Default 8.
    /// Eigenvalues of multiplicity above `b` may be missed; larger blocks use the BLAS better
    /// but need more operator applications in total.
    pub block_size: usize,
    /// Basis columns per restart cycle `m` (rounded up to a multiple of `block_size`), or 0 for
    /// automatic `max(2·count, count + 8·block_size)`. Larger bases need fewer restarts but cost
    /// `O(n m²)` per cycle and `8 n m` bytes.
    pub basis_size: usize,
    /// Relative shift: `σ = −shift / area` (dimensionless, > 0). Default 1. It makes `W − σM`
    /// positive definite; it barely changes convergence as long as it is small next to the
    /// wanted eigenvalues (`λ_k ≈ 4πk / area` by Weyl's law). It must not be tiny: the
    /// constant mode's `θ_0 = area / shift` sets the scale of the projected matrix, and the
    /// dense Ritz solver's eigenvector error is about `ε θ_0 / gap`, so with `shift = 1e-6`
    /// the residuals of the higher pairs stagnate above the tolerance (measured: 21 of 100
    /// pairs converge on `icosphere(5)`, all 100 in 3 restarts with `shift ≥ 1e-2`).
    pub shift: f64,
    /// Seed of the random start block (ChaCha8). Default `0x5eed`.
    pub seed: u64,
}

impl Default for SpectrumParams {
    fn default() -> Self {
        SpectrumParams {
            count: 200,
            tolerance: 1e-10,
            max_restarts: 50,
            block_size: 8,
            basis_size: 0,
            shift: 1.0,
            seed: 0x5eed,
        }
    }
}

impl SpectrumParams {
    /// Refuses parameters that cannot give a spectrum, naming the parameter and a good value.
    pub(crate) fn validate(&self) -> Result<()> {
        let bad = |name, value: String, reason| {
            Err(SpectralError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if self.count == 0 {
            return bad("count", self.count.to_string(), "must be at least 1");
        }
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return bad(
                "tolerance",
                self.tolerance.to_string(),
                "must be in (0, 1); 1e-10 is a good default",
            );
        }
        if self.block_size == 0 || self.block_size > 64 {
            return bad(
                "block_size",
                self.block_size.to_string(),
                "must be in 1..=64; 8 is a good default",
            );
        }
        if !(self.shift > 0.0 && self.shift.is_finite()) {
            return bad(
                "shift",
                self.shift.to_string(),
                "must be a positive number; 1 is a good default",
            );
        }
        Ok(())
    }
}

/// Which eigensolver produced a spectrum.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Shift-invert block Lanczos over a sparse Cholesky factorisation.
    Lanczos,
    /// Dense symmetric eigensolver (small meshes).
    Dense,
}
