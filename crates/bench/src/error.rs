//! The bench crate's error type.

use std::path::PathBuf;

use keycomp_mesh::MeshError;

/// Everything that can go wrong generating a transformed shape, reading or writing a
/// correspondence file, or evaluating components.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BenchError {
    /// A transformation strength outside 1..=5.
    #[error("transformation strength {strength} is out of range: use 1 (mildest) to 5 (strongest)")]
    InvalidStrength {
        /// The strength given.
        strength: u8,
    },
    /// A transformation name that is not one of the [`Kind`](crate::Kind)s.
    #[error(
        "unknown transformation '{name}': use one of holes, microholes, noise, shotnoise, scale, \
         localscale, topology, sampling"
    )]
    UnknownKind {
        /// The name given.
        name: String,
    },
    /// The null mesh has no face of positive area, so sizes relative to the shape are undefined.
    #[error("the null mesh has zero surface area: nothing to transform")]
    ZeroArea,
    /// A transformation produced a mesh that does not validate (for example every face removed).
    #[error("the {kind} transformation produced an invalid mesh: {source}")]
    InvalidOutput {
        /// The transformation's name ([`Kind::name`](crate::Kind::name)).
        kind: &'static str,
        /// Why the mesh does not validate.
        #[source]
        source: MeshError,
    },
    /// The topology transformation found too few places to weld: the shape has no two parts
    /// that are close in space but far apart along the surface (a convex shape has none).
    #[error(
        "topology: found {found} of the {needed} weld sites needed; the shape has too few parts \
         that are close in space but far apart along the surface (a convex shape such as a \
         sphere has none): use a shape with limbs or several pieces, or a lower strength"
    )]
    NothingToWeld {
        /// Bridges needed for the strength.
        needed: usize,
        /// Bridges found.
        found: usize,
    },
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// A correspondence file is malformed.
    #[error("{}: line {line}: {message}", path.display())]
    MapFormat {
        /// The file.
        path: PathBuf,
        /// 1-based line number (the last line + 1 when the file ends too early).
        line: usize,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A correspondence refers to a null vertex that does not exist.
    #[error(
        "correspondence entry {index} maps to null vertex {target} but the null mesh has only \
         {null_vertices} vertices: the map does not belong to this null mesh"
    )]
    MapOutOfRange {
        /// Transformed vertex id (the entry's index).
        index: usize,
        /// The null vertex id it maps to.
        target: u32,
        /// Number of null vertices.
        null_vertices: usize,
    },
    /// A mesh file could not be read (the error names the file).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A benchmark data folder is missing or holds no usable shape.
    #[error("{}: {message}", path.display())]
    Data {
        /// The folder or file.
        path: PathBuf,
        /// What is wrong and what to do.
        message: String,
    },
}
