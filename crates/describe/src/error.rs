//! What stops description ([`DescribeError`]).

use keycomp_geodesic::GeodesicError;

/// Anything that stops description.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DescribeError {
    /// Geodesic distances failed (the detection does not belong to this mesh).
    #[error(transparent)]
    Geodesic(#[from] GeodesicError),
    /// The detection refers to vertices the mesh does not have.
    #[error(
        "the detection does not belong to this mesh: vertex {vertex} out of range ({vertices} vertices)"
    )]
    Mismatch {
        /// The offending id.
        vertex: u32,
        /// Vertices of the mesh.
        vertices: usize,
    },
    /// The parameters cannot describe anything.
    #[error("invalid description parameters: {0}")]
    Params(String),
}
