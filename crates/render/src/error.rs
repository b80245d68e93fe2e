//! The render crate's error type.

use std::path::PathBuf;

/// What went wrong while rendering or writing an image.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// The colour slice does not have one entry per vertex.
    #[error(
        "{colors} vertex colours given for a mesh of {vertices} vertices: pass exactly one colour per vertex"
    )]
    ColorCount {
        /// Number of colours passed.
        colors: usize,
        /// Number of vertices of the mesh.
        vertices: usize,
    },
    /// A render parameter is out of range.
    #[error("render parameter {name} = {value} is out of range: expected {expected}")]
    InvalidParam {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: String,
        /// What is accepted.
        expected: &'static str,
    },
    /// A face refers to a vertex that does not exist.
    #[error(
        "face {face} refers to vertex {index} but the mesh has {vertices} vertices: build meshes with Mesh::from_raw, which checks this"
    )]
    FaceIndex {
        /// The face's index.
        face: usize,
        /// The offending vertex id.
        index: u32,
        /// Number of vertices of the mesh.
        vertices: usize,
    },
    /// A vertex used by a face has a NaN or infinite coordinate.
    #[error(
        "vertex {vertex} has a non-finite coordinate: build meshes with Mesh::from_raw, which rejects these"
    )]
    NonFinite {
        /// The vertex id.
        vertex: u32,
    },
    /// The image could not be encoded as PNG.
    #[error("PNG encoding failed: {message}")]
    Encode {
        /// The encoder's message.
        message: String,
    },
    /// The PNG file could not be written.
    #[error("cannot write {}: {source} (check that the directory exists and is writable)", path.display())]
    Io {
        /// The file being written.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}
