//! Reading and writing mesh files. The format is chosen by the file's extension
//! (case-insensitive): `.off`, `.obj`, `.ply`, `.stl`, `.gltf`, `.glb`.
//!
//! Every reader parses the file into raw vertices and triangles and then validates them with
//! [`Mesh::from_raw`]: vertex ids are the file's own vertex order (never welded or reordered,
//! except STL, whose corners are merged by position), polygons are fan-triangulated, degenerate
//! faces are dropped and counted in [`Repairs`]. Bad input is an error naming the file, where in
//! it (a line for text formats, an element, facet or byte for binary ones) and why; no input makes
//! a reader panic or allocate more than the file's size justifies.
//!
//! Readers accept regular files only (a FIFO would block, a device would never end). Writers
//! ([`write_off`], [`write_ply_colored`]) go through [`output::Output`]: atomically, to a
//! temporary file in the same folder, synced, then renamed over the target, so an error never
//! leaves a half-written file; symbolic links are followed, FIFOs and devices written in place,
//! directories refused.
//!
//! Each format's conventions are documented in its module (`off.rs`, `obj.rs`, `ply.rs`,
//! `stl.rs`, `gltf.rs` in this folder).

mod gltf;
mod obj;
mod off;
pub mod output;
mod ply;
mod stl;
mod text;
mod write;

#[cfg(test)]
mod fixtures;
#[cfg(test)]
mod tests;

use std::path::Path;

use crate::{ErrorKind, Mesh, MeshError, Point3, Repairs, VertexId};

pub use write::{write_glb, write_off, write_off_to, write_ply_colored};

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
    /// glTF 2.0: `.gltf` (JSON with `.bin` or `data:` buffers) or `.glb` (binary).
    Gltf,
}

impl Format {
    /// The format for a file extension (without the dot, case-insensitive), if supported.
    pub fn from_extension(extension: &str) -> Option<Format> {
        match extension.to_ascii_lowercase().as_str() {
            "off" => Some(Format::Off),
            "obj" => Some(Format::Obj),
            "ply" => Some(Format::Ply),
            "stl" => Some(Format::Stl),
            "gltf" | "glb" => Some(Format::Gltf),
            _ => None,
        }
    }

    /// The format of a path, from its extension. Errors with [`ErrorKind::UnknownFormat`] (and
    /// the path) when the extension is missing or not supported.
    pub fn from_path(path: &Path) -> Result<Format, MeshError> {
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().into_owned())
            .unwrap_or_default();
        Format::from_extension(&extension)
            .ok_or_else(|| MeshError::new(ErrorKind::UnknownFormat { extension }).in_file(path))
    }

    /// The usual lower-case file extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Off => "off",
            Format::Obj => "obj",
            Format::Ply => "ply",
            Format::Stl => "stl",
            Format::Gltf => "gltf",
        }
    }
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

/// Vertices and triangles as parsed, before validation.
#[derive(Debug)]
pub(crate) struct RawMesh {
    pub(crate) positions: Vec<Point3<f64>>,
    pub(crate) faces: Vec<[VertexId; 3]>,
}

/// Reads and validates a mesh file; the format is chosen by the file's extension.
///
/// Errors carry the path; see the module documentation for what is checked.
pub fn read_mesh(path: &Path) -> Result<LoadedMesh, MeshError> {
    let format = Format::from_path(path)?;
    let bytes = output::read_input(path).map_err(|e| MeshError::from(e).in_file(path))?;
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    read_bytes(&bytes, format, Some(folder)).map_err(|e| e.in_file(path))
}

/// Parses and validates the contents of a mesh file in the given format. Errors carry no path
/// (see [`read_mesh`]); useful for data not in a file, tests and fuzzing.
///
/// A glTF file whose buffers are separate `.bin` files cannot be read this way (there is no
/// folder to find them in); GLB and glTF with `data:` buffers can.
pub fn read_mesh_from_bytes(bytes: &[u8], format: Format) -> Result<LoadedMesh, MeshError> {
    read_bytes(bytes, format, None)
}

/// [`read_mesh_from_bytes`], with the folder where a glTF file's buffers are.
fn read_bytes(
    bytes: &[u8],
    format: Format,
    folder: Option<&Path>,
) -> Result<LoadedMesh, MeshError> {
    // text formats saved by some editors start with a UTF-8 byte-order mark: skip it
    let bytes = match format {
        Format::Off | Format::Obj | Format::Ply | Format::Gltf => {
            bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes)
        }
        Format::Stl => bytes,
    };
    let raw = match format {
        Format::Off => off::read_off(bytes),
        Format::Obj => obj::read_obj(bytes),
        Format::Ply => ply::read_ply(bytes),
        Format::Stl => stl::read_stl(bytes),
        Format::Gltf => gltf::read_gltf(bytes, folder),
    }?;
    let (mesh, repairs) = Mesh::from_raw(raw.positions, raw.faces)?;
    Ok(LoadedMesh {
        mesh,
        repairs,
        format,
    })
}
