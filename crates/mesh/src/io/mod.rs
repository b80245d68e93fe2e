//! Reading and writing mesh files. The format is chosen by extension.
//!
//! (Being written: see the module files.)

use std::path::Path;

use crate::{Mesh, MeshError, Repairs};

/// A supported mesh file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Object File Format (`OFF`, `NOFF`, `COFF`, `CNOFF` headers; `#` comments).
    Off,
    /// Wavefront OBJ (polygons are fan-triangulated).
    Obj,
    /// Stanford PLY, ascii or binary (little and big endian).
    Ply,
    /// STL, ascii or binary.
    Stl,
}

/// A mesh read from a file, with what was repaired on the way.
#[derive(Debug, Clone)]
pub struct LoadedMesh {
    /// The validated mesh.
    pub mesh: Mesh,
    /// Faces dropped and vertices unused.
    pub repairs: Repairs,
    /// The file's format.
    pub format: Format,
}

/// Reads and validates a mesh file; the format is chosen by the file's extension.
pub fn read_mesh(path: &Path) -> Result<LoadedMesh, MeshError> {
    let _ = path;
    todo!("io helper")
}

/// Writes `mesh` as ascii OFF.
pub fn write_off(mesh: &Mesh, path: &Path) -> Result<(), MeshError> {
    let _ = (mesh, path);
    todo!("io helper")
}

/// Writes `mesh` as binary little-endian PLY with one RGB colour per vertex.
pub fn write_ply_colored(mesh: &Mesh, colors: &[[u8; 3]], path: &Path) -> Result<(), MeshError> {
    let _ = (mesh, colors, path);
    todo!("io helper")
}
