//! The error type of the MSER crate.

use keycomp_components::ComponentsError;
use keycomp_spectral::SpectralError;
use thiserror::Error;

/// What can stop a component tree, the stable-component selection or an MSER detection.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum MserError {
    /// A parameter is out of its valid range.
    #[error("invalid MSER parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// The parameter's field name.
        name: &'static str,
        /// Its value, as text.
        value: String,
        /// The valid range.
        reason: &'static str,
    },
    /// Two per-vertex arrays of different lengths.
    #[error("{what} has {found} entries but the graph has {expected} vertices")]
    LengthMismatch {
        /// Which array.
        what: &'static str,
        /// Its length.
        found: usize,
        /// The vertex count.
        expected: usize,
    },
    /// An edge or keypoint names a vertex that does not exist.
    #[error("vertex {vertex} is out of range: the graph has {vertices} vertices")]
    VertexOutOfRange {
        /// The offending id.
        vertex: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// A weight or mass that is not usable (infinite weight, negative or NaN mass).
    #[error(
        "{what} {index} is {value}: weights must be finite (or NaN to leave it out), masses finite and ≥ 0"
    )]
    BadValue {
        /// Which kind of value.
        what: &'static str,
        /// Its index.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The Laplace–Beltrami spectrum could not be computed.
    #[error(transparent)]
    Spectral(#[from] SpectralError),
    /// The smallest enclosing sphere of a component failed (non-finite coordinates).
    #[error(transparent)]
    Components(#[from] ComponentsError),
}

/// Result with [`MserError`].
pub type Result<T> = std::result::Result<T, MserError>;
