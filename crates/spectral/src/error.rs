//! The spectral crate's error type.

use thiserror::Error;

/// What went wrong while assembling the Laplacian, computing the spectrum or using it.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum SpectralError {
    /// A face refers to a vertex that does not exist.
    #[error(
        "face {face} refers to vertex {vertex} but the mesh has {vertices} vertices; \
         validate the mesh with Mesh::from_raw"
    )]
    FaceOutOfRange {
        /// 0-based face index.
        face: usize,
        /// The offending vertex id.
        vertex: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// A face has a non-finite corner coordinate.
    #[error(
        "face {face} has a non-finite corner coordinate; validate the mesh with Mesh::from_raw"
    )]
    NonFiniteGeometry {
        /// 0-based face index.
        face: usize,
    },
    /// The mesh has no face of positive area, so there is no surface to analyse.
    #[error("the mesh has no face of positive area; a spectrum needs a surface")]
    NoSurface,
    /// A parameter is out of its valid range.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// The parameter's field name.
        name: &'static str,
        /// Its value, as text.
        value: String,
        /// The valid range and what to do.
        reason: &'static str,
    },
    /// The sparse Cholesky factorisation of `W − σM` failed (the shifted matrix is not
    /// numerically positive definite, or memory ran out).
    #[error(
        "sparse Cholesky factorisation of W − σM failed ({detail}); \
         the mesh may contain extremely degenerate triangles: try a larger relative shift \
         (SpectrumParams::shift) or clean the mesh"
    )]
    Factorization {
        /// The factoriser's own message.
        detail: String,
    },
    /// The eigensolver stopped before the requested eigenpairs converged.
    #[error(
        "shift-invert Lanczos converged {converged} of {requested} eigenpairs in {restarts} \
         restarts; raise SpectrumParams::max_restarts or the basis size, or ask for fewer \
         eigenpairs"
    )]
    NotConverged {
        /// Leading eigenpairs that met the tolerance.
        converged: usize,
        /// Eigenpairs asked for.
        requested: usize,
        /// Restart cycles run.
        restarts: usize,
    },
    /// The dense eigensolver (used for tiny meshes and the projected problem) failed.
    #[error("dense symmetric eigensolver failed to converge ({detail})")]
    DenseEigen {
        /// The solver's own message.
        detail: String,
    },
    /// A per-vertex array has the wrong length for the mesh.
    #[error(
        "{what} has {found} entries but the mesh has {expected} vertices; \
         pass values computed on the same mesh"
    )]
    LengthMismatch {
        /// What array.
        what: &'static str,
        /// Its length.
        found: usize,
        /// The mesh's vertex count.
        expected: usize,
    },
}

/// Result with [`SpectralError`].
pub type Result<T> = std::result::Result<T, SpectralError>;
