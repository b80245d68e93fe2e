//! The error of shape generation.

/// Errors of shape generation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ShapesError {
    /// The mesher could not mesh the field (bad parameters or an empty or unbounded solid).
    #[error("meshing failed: {0}")]
    Mesher(String),
    /// A generated mesh failed the surface check (a bug, or a resolution too coarse for the
    /// thinnest part).
    #[error("{name}: the generated mesh is not a valid closed surface: {problem}")]
    InvalidSurface {
        /// The shape's name.
        name: String,
        /// What is wrong.
        problem: String,
    },
    /// Bad parameters.
    #[error("invalid parameters: {0}")]
    Params(String),
}
