//! The error type of the components stage.

/// Everything that can go wrong in this crate: bad parameters and malformed inputs. Each variant
/// says which value or element is wrong and what to do about it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ComponentsError {
    /// A parameter is out of its valid range.
    #[error("invalid parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// The parameter's name, as in its params struct (e.g. `cluster.r`).
        name: &'static str,
        /// The rejected value, formatted.
        value: String,
        /// What the valid range is.
        reason: &'static str,
    },
    /// A distance matrix whose length is not `k × k`.
    #[error(
        "distance matrix has {len} entries but k = {k} needs k×k = {expected}; pass the full \
         row-major matrix"
    )]
    MatrixSize {
        /// Length of the slice passed.
        len: usize,
        /// Number of points claimed.
        k: usize,
        /// `k × k`.
        expected: usize,
    },
    /// A distance that is NaN, infinite or negative.
    #[error(
        "distance ({i}, {j}) = {value} is not a finite non-negative number; replace infinite \
         distances (disconnected pieces) by a finite value before embedding"
    )]
    BadDistance {
        /// Row.
        i: usize,
        /// Column.
        j: usize,
        /// The offending value.
        value: f64,
    },
    /// A distance matrix that is not symmetric.
    #[error(
        "distance matrix is not symmetric: d({i}, {j}) = {dij} but d({j}, {i}) = {dji}; \
         symmetrise it, e.g. (d_ij + d_ji) / 2"
    )]
    Asymmetric {
        /// Row.
        i: usize,
        /// Column.
        j: usize,
        /// `d(i, j)`.
        dij: f64,
        /// `d(j, i)`.
        dji: f64,
    },
    /// A point with a NaN or infinite coordinate.
    #[error("{what} {index} has a non-finite coordinate")]
    NonFinitePoint {
        /// Which kind of point (e.g. "2-D point", "sphere point").
        what: &'static str,
        /// Its index in the input.
        index: usize,
    },
    /// An input that must not be empty is empty.
    #[error("{what} is empty; it needs at least one element")]
    Empty {
        /// What was empty (e.g. "point set", "cluster").
        what: &'static str,
    },
    /// An index (vertex id, keypoint index) beyond the end of the data it refers to.
    #[error("{what} {index} is out of range (there are {len})")]
    IndexOutOfRange {
        /// What the index refers to (e.g. "vertex", "keypoint").
        what: &'static str,
        /// The index.
        index: usize,
        /// How many elements there are.
        len: usize,
    },
    /// A computation the surface does not allow (no face of positive area, a factorisation
    /// that fails).
    #[error("{what} failed: {detail}")]
    Degenerate {
        /// The step that failed.
        what: &'static str,
        /// Why.
        detail: String,
    },
}

impl ComponentsError {
    pub(crate) fn param(
        name: &'static str,
        value: impl std::fmt::Display,
        reason: &'static str,
    ) -> Self {
        ComponentsError::InvalidParameter {
            name,
            value: value.to_string(),
            reason,
        }
    }
}
