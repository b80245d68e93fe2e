//! The spectral stage of keycomp: the Laplace–Beltrami spectrum of a mesh, the heat kernel
//! signature and HKS keypoints — the foundation of the comparison method of Sipiran & Bustos,
//! "Key-components: detection of salient regions on 3D meshes", *The Visual Computer* 29(12),
//! 2013, Section 4.4 (diffusion-geometric MSER of Litman, Bronstein & Bronstein 2011 and MSER
//! key-components).
//!
//! The modules, each with its method, steps, complexity and citations:
//! - [`laplacian`]: cotangent stiffness `W` and lumped mass `M` (Pinkall & Polthier 1993,
//!   Meyer et al. 2003);
//! - [`spectrum`]: the smallest eigenpairs of `W φ = λ M φ` by shift-invert block Lanczos with
//!   thick restart over a sparse Cholesky factorisation (Lanczos 1950, Ericsson & Ruhe 1980,
//!   Wu & Simon 2000);
//! - [`hks`]: heat kernel signature and the paper's HKS keypoints (Sun, Ovsjanikov & Guibas
//!   2009);
//! - [`diffuse()`]: one implicit heat step `(M + tW) u = M f` (the robust preset's saliency).
//!
//! ```
//! use keycomp_mesh::{synth, Topology};
//! use keycomp_spectral::{Spectrum, SpectrumParams, hks_keypoints, paper_time};
//!
//! let mesh = synth::icosphere(3, 1.0);
//! let spectrum = Spectrum::compute(&mesh, &SpectrumParams { count: 30, ..Default::default() })?;
//! assert!(spectrum.eigenvalues()[0].abs() < 1e-8);
//! assert!((spectrum.eigenvalues()[1] - 2.0).abs() < 0.02); // l(l+1) with l = 1
//! let hks = spectrum.hks(paper_time(spectrum.area()));
//! let keypoints = hks_keypoints(&mesh, &Topology::new(&mesh), &hks)?;
//! # let _ = keypoints;
//! # Ok::<(), keycomp_spectral::SpectralError>(())
//! ```

pub mod diffuse;
mod eigen;
mod error;
pub mod hks;
pub mod laplacian;
mod params;
pub mod spectrum;

pub use diffuse::{diffuse, diffuse_all};
pub use error::{Result, SpectralError};
pub use hks::{hks_keypoints, paper_time};
pub use laplacian::Laplacian;
pub use params::{Method, SpectrumParams};
pub use spectrum::{SolveStats, Spectrum};
