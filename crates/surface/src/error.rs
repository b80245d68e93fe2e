//! Errors of the canonical surface.

/// Why a canonical surface could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SurfaceError {
    /// The input has no area: no faces of positive area, or points that do not span a surface.
    #[error(
        "the input has no surface area to analyse (degenerate faces, or fewer than 3 distinct points)"
    )]
    NoArea,
    /// Nothing was left once the offset surface was made (an input far smaller than the grid).
    #[error("no surface could be made from the input")]
    Empty,
    /// Invalid parameters.
    #[error("invalid surface parameters: {0}")]
    Params(String),
}
