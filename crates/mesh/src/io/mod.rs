//! Reading and writing mesh, scan and point-cloud files. The format is chosen by the file's
//! extension (case-insensitive): meshes `.off`, `.obj`, `.ply`, `.stl`, `.gltf`, `.glb`; point
//! clouds and scans `.ply` (range grids, vertex-only files), `.xyz`, `.pts`, `.pcd`.
//!
//! Every reader parses the file into raw data and then validates it: a mesh's vertices and
//! triangles with [`Mesh::from_raw`], where vertex ids are the file's own vertex order (never
//! welded or reordered, except STL, whose corners are merged by position, and organised PCD
//! clouds, whose invalid points are dropped), polygons are fan-triangulated, degenerate faces are
//! dropped and counted in [`Repairs`]. A range grid (a PLY `range_grid` element, an organised PCD
//! cloud) is triangulated by [`crate::grid::triangulate_grid`] and is a mesh from then on. A file
//! of vertices and no faces (PLY, OFF or OBJ without faces, XYZ, PTS, an unorganised PCD cloud)
//! is a [`PointCloud`]: [`read_input`] returns it, [`read_mesh`] says so in an
//! [`ErrorKind::PointCloud`] error. Bad input is an error naming the file, where in it (a line
//! for text formats and text data, an element, point, facet or byte for binary ones) and why; no
//! input makes a reader panic or allocate more than the file's size justifies (declared counts
//! are checked against the bytes that remain before anything is allocated). What a reader
//! accepted but the user may want to know (header lines ignored, a point count that disagrees,
//! invalid points dropped) is a warning in [`LoadedInput::warnings`] and
//! [`LoadedMesh::warnings`], one line each, starting with where it was found.
//!
//! Readers accept regular files only (a FIFO would block, a device would never end). Writers
//! ([`write_off`], [`write_ply_colored`]) go through [`output::Output`]: atomically, to a
//! temporary file in the same folder, synced, then renamed over the target, so an error never
//! leaves a half-written file; symbolic links are followed, FIFOs and devices written in place,
//! directories refused.
//!
//! Each format's conventions are documented in its module (`off.rs`, `obj.rs`, `ply.rs`,
//! `stl.rs`, `gltf.rs`, `xyz.rs` for XYZ and PTS, `pcd.rs` with `lzf.rs` in this folder).

mod gltf;
mod lzf;
mod obj;
mod off;
pub mod output;
mod pcd;
mod ply;
mod stl;
mod text;
mod write;
mod xyz;

#[cfg(test)]
mod fixtures;
#[cfg(test)]
mod tests;

use std::path::Path;

use crate::grid::triangulate_grid;
use crate::{ErrorKind, Location, Mesh, MeshError, Point3, PointCloud, Repairs, Vector3, VertexId};

pub use write::{glb_bytes, write_glb, write_off, write_off_to, write_ply_colored};

/// A supported file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Object File Format (`OFF`, `NOFF`, `COFF`, `CNOFF` headers; `#` comments).
    Off,
    /// Wavefront OBJ (polygons are fan-triangulated).
    Obj,
    /// Stanford PLY, ascii or binary (little and big endian): meshes, range grids
    /// (`element range_grid`) and point clouds (vertices only).
    Ply,
    /// STL, ascii or binary.
    Stl,
    /// glTF 2.0: `.gltf` (JSON with `.bin` or `data:` buffers) or `.glb` (binary).
    Gltf,
    /// Text point cloud, one point per line: `x y z`, more columns ignored (`.xyz`).
    Xyz,
    /// Text point cloud (Leica and others): a line with the point count, then one point per
    /// line as in [`Format::Xyz`] (`.pts`).
    Pts,
    /// Point Cloud Library's PCD, ascii, binary or binary_compressed; organised clouds are range
    /// grids (`.pcd`).
    Pcd,
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
            "xyz" => Some(Format::Xyz),
            "pts" => Some(Format::Pts),
            "pcd" => Some(Format::Pcd),
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
            Format::Xyz => "xyz",
            Format::Pts => "pts",
            Format::Pcd => "pcd",
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
    /// What the reader accepted but noticed (see [`LoadedInput::warnings`]).
    pub warnings: Vec<String>,
}

/// What a file holds: a triangle mesh or points.
#[derive(Debug, Clone, PartialEq)]
pub enum Geometry {
    /// A mesh: a mesh file's faces, or a range grid triangulated.
    Mesh(Mesh),
    /// Points without faces.
    Points(PointCloud),
}

impl Geometry {
    /// The vertex or point positions.
    pub fn positions(&self) -> &[Point3<f64>] {
        match self {
            Geometry::Mesh(m) => &m.positions,
            Geometry::Points(p) => &p.positions,
        }
    }
}

/// What kind of data a file held, for reporting what was read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// Faces (or triangle strips) stored in the file.
    Mesh,
    /// A range grid of `rows x cols` cells, triangulated by [`crate::grid::triangulate_grid`]
    /// (a PLY `range_grid` element; an organised PCD cloud, `HEIGHT` rows of `WIDTH`).
    RangeGrid {
        /// Rows of the grid.
        rows: usize,
        /// Columns of the grid.
        cols: usize,
    },
    /// Points only.
    Points,
}

/// Whatever a file holds, read and validated: see [`read_input`].
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedInput {
    /// The mesh or the points.
    pub geometry: Geometry,
    /// Faces dropped and vertices unused (all zero for points).
    pub repairs: Repairs,
    /// The file's format.
    pub format: Format,
    /// What the data was in the file.
    pub source: Source,
    /// What the reader accepted but noticed, one line each starting with where (`line 5:
    /// unknown header line 'bye' ignored`): ignored header lines, a declared count that
    /// disagrees, invalid points dropped, normals ignored. Empty for a clean file.
    pub warnings: Vec<String>,
}

/// Vertices and triangles as parsed, before validation.
#[derive(Debug)]
pub(crate) struct RawMesh {
    pub(crate) positions: Vec<Point3<f64>>,
    pub(crate) faces: Vec<[VertexId; 3]>,
}

/// A range grid as parsed: `cells` (row-major, `rows * cols` of them) index `positions`.
#[derive(Debug)]
pub(crate) struct RawGrid {
    pub(crate) positions: Vec<Point3<f64>>,
    pub(crate) rows: usize,
    pub(crate) cols: usize,
    pub(crate) cells: Vec<Option<VertexId>>,
    /// Reverse the triangles' winding (grids stored with row 0 at the top).
    pub(crate) flip: bool,
}

/// Points as parsed.
#[derive(Debug)]
pub(crate) struct RawPoints {
    pub(crate) positions: Vec<Point3<f64>>,
    pub(crate) normals: Option<Vec<Vector3<f64>>>,
}

/// A file's data as parsed.
#[derive(Debug)]
pub(crate) enum Raw {
    Mesh(RawMesh),
    Grid(RawGrid),
    Points(RawPoints),
}

/// A reader's result: the data and its warnings.
#[derive(Debug)]
pub(crate) struct Parsed {
    pub(crate) raw: Raw,
    pub(crate) warnings: Vec<String>,
}

impl From<RawMesh> for Parsed {
    fn from(raw: RawMesh) -> Self {
        Parsed {
            raw: Raw::Mesh(raw),
            warnings: Vec::new(),
        }
    }
}

/// Most warnings of one kind a reader lists one by one; the rest are counted in one more line.
pub(crate) const MAX_WARNINGS: usize = 10;

/// Reads and validates a mesh file; the format is chosen by the file's extension. A range grid is
/// returned triangulated; a file of points only is an [`ErrorKind::PointCloud`] error (use
/// [`read_input`] to read points).
///
/// Errors carry the path; see the module documentation for what is checked.
pub fn read_mesh(path: &Path) -> Result<LoadedMesh, MeshError> {
    read_input(path)?.into_mesh().map_err(|e| e.in_file(path))
}

/// Parses and validates the contents of a mesh file in the given format. Errors carry no path
/// (see [`read_mesh`]); useful for data not in a file, tests and fuzzing.
///
/// A glTF file whose buffers are separate `.bin` files cannot be read this way (there is no
/// folder to find them in); GLB and glTF with `data:` buffers can.
pub fn read_mesh_from_bytes(bytes: &[u8], format: Format) -> Result<LoadedMesh, MeshError> {
    read_bytes(bytes, format, None)?.into_mesh()
}

/// Reads and validates whatever a file holds, a mesh or points; the format is chosen by the
/// file's extension. Meshes and range grids (triangulated) are [`Geometry::Mesh`], files of
/// points only [`Geometry::Points`]; [`LoadedInput::source`] tells which kind of data it was.
///
/// Errors carry the path; see the module documentation for what is checked.
pub fn read_input(path: &Path) -> Result<LoadedInput, MeshError> {
    let format = Format::from_path(path)?;
    let bytes = output::read_input(path).map_err(|e| MeshError::from(e).in_file(path))?;
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    read_bytes(&bytes, format, Some(folder)).map_err(|e| e.in_file(path))
}

/// Parses and validates the contents of a file in the given format, as [`read_input`]. Errors
/// carry no path; useful for data not in a file, tests and fuzzing (the glTF limits of
/// [`read_mesh_from_bytes`] apply).
pub fn read_input_from_bytes(bytes: &[u8], format: Format) -> Result<LoadedInput, MeshError> {
    read_bytes(bytes, format, None)
}

impl LoadedInput {
    /// The mesh, or an [`ErrorKind::PointCloud`] error for points.
    fn into_mesh(self) -> Result<LoadedMesh, MeshError> {
        match self.geometry {
            Geometry::Mesh(mesh) => Ok(LoadedMesh {
                mesh,
                repairs: self.repairs,
                format: self.format,
                warnings: self.warnings,
            }),
            Geometry::Points(p) => Err(MeshError::new(ErrorKind::PointCloud {
                points: p.positions.len(),
            })),
        }
    }
}

/// [`read_input_from_bytes`], with the folder where a glTF file's buffers are.
fn read_bytes(
    bytes: &[u8],
    format: Format,
    folder: Option<&Path>,
) -> Result<LoadedInput, MeshError> {
    // text formats saved by some editors start with a UTF-8 byte-order mark: skip it
    let bytes = match format {
        Format::Stl => bytes,
        _ => bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes),
    };
    let parsed: Parsed = match format {
        Format::Off => off::read_off(bytes)?.into(),
        Format::Obj => obj::read_obj(bytes)?.into(),
        Format::Ply => ply::read_ply(bytes)?,
        Format::Stl => stl::read_stl(bytes)?.into(),
        Format::Gltf => gltf::read_gltf(bytes, folder)?.into(),
        Format::Xyz => xyz::read_xyz(bytes)?,
        Format::Pts => xyz::read_pts(bytes)?,
        Format::Pcd => pcd::read_pcd(bytes)?,
    };
    let Parsed { raw, mut warnings } = parsed;
    let raw = match raw {
        // OFF and OBJ files of vertices only are how some tools save point clouds.
        Raw::Mesh(m)
            if m.faces.is_empty()
                && !m.positions.is_empty()
                && matches!(format, Format::Off | Format::Obj) =>
        {
            Raw::Points(RawPoints {
                positions: m.positions,
                normals: None,
            })
        }
        raw => raw,
    };
    let (geometry, repairs, source) = match raw {
        Raw::Mesh(m) => {
            let (mesh, repairs) = Mesh::from_raw(m.positions, m.faces)?;
            (Geometry::Mesh(mesh), repairs, Source::Mesh)
        }
        Raw::Grid(g) => {
            let mut faces = triangulate_grid(&g.positions, g.rows, g.cols, &g.cells);
            if faces.is_empty() {
                warnings.push(format!(
                    "the {} x {} range grid gives no triangles (no three neighbouring cells \
                     present): read as {} points",
                    g.rows,
                    g.cols,
                    g.positions.len()
                ));
                let points = points(g.positions, None, &mut warnings)?;
                (Geometry::Points(points), Repairs::default(), Source::Points)
            } else {
                if g.flip {
                    faces.iter_mut().for_each(|f| f.swap(1, 2));
                }
                let (mesh, repairs) = Mesh::from_raw(g.positions, faces)?;
                let source = Source::RangeGrid {
                    rows: g.rows,
                    cols: g.cols,
                };
                (Geometry::Mesh(mesh), repairs, source)
            }
        }
        Raw::Points(p) => {
            let points = points(p.positions, p.normals, &mut warnings)?;
            (Geometry::Points(points), Repairs::default(), Source::Points)
        }
    };
    Ok(LoadedInput {
        geometry,
        repairs,
        format,
        source,
        warnings,
    })
}

/// Validates points: at least one, all finite (readers report a bad one where it is; this is the
/// last check). Normals that are not one per point or not all finite are dropped with a warning.
fn points(
    positions: Vec<Point3<f64>>,
    normals: Option<Vec<Vector3<f64>>>,
    warnings: &mut Vec<String>,
) -> Result<PointCloud, MeshError> {
    if positions.is_empty() {
        return Err(MeshError::new(ErrorKind::NoVertices));
    }
    if let Some(i) = positions
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
    {
        return Err(MeshError::new(ErrorKind::NonFiniteCoordinate).at(Location::Vertex(i as u64)));
    }
    let normals = match normals {
        Some(n) if n.len() != positions.len() => {
            warnings.push(format!(
                "{} normals for {} points: normals ignored",
                n.len(),
                positions.len()
            ));
            None
        }
        Some(n) => match n.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
            Some(i) => {
                warnings.push(format!(
                    "point {i}: its normal is NaN or infinite: normals ignored"
                ));
                None
            }
            None => Some(n),
        },
        None => None,
    };
    Ok(PointCloud { positions, normals })
}
