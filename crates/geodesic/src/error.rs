//! The geodesic crate's error type.

use thiserror::Error;

/// What went wrong while building a [`crate::GeodesicSolver`] or running it.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum GeodesicError {
    /// A source or target vertex id is not a vertex of the mesh.
    #[error(
        "vertex {vertex} is out of range: the mesh has {vertices} vertices; \
         pass ids of the mesh the solver was built from"
    )]
    VertexOutOfRange {
        /// The offending id.
        vertex: u32,
        /// Number of vertices of the solver's mesh.
        vertices: usize,
    },
    /// The topology was built from a different mesh (vertex counts differ).
    #[error(
        "the topology has {topology} vertices but the mesh has {mesh}; \
         build the Topology from the same mesh"
    )]
    TopologyMismatch {
        /// Vertices in the mesh.
        mesh: usize,
        /// Vertices in the topology.
        topology: usize,
    },
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
    /// A face has a non-finite corner position, so its edge lengths are not numbers.
    #[error(
        "face {face} has a non-finite corner coordinate; \
         validate the mesh with Mesh::from_raw"
    )]
    NonFiniteGeometry {
        /// 0-based face index.
        face: usize,
    },
    /// A landmark is not an index into the sources, or appears twice.
    #[error(
        "landmark {landmark} is not a distinct index into the {sources} sources; \
         pass each landmark once, as a position in the sources slice"
    )]
    BadLandmark {
        /// The offending landmark index.
        landmark: usize,
        /// Number of sources.
        sources: usize,
    },
}
