//! The mesh crate's error type: what went wrong, in which file, where in it.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in a file a problem was found.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Location {
    /// A 1-based line number in a text file.
    Line(u64),
    /// A byte offset in a binary file.
    Byte(u64),
    /// A 0-based vertex index.
    Vertex(u64),
    /// A 0-based face index (in the file's face order).
    Face(u64),
    /// A 0-based point of a point cloud (a binary PCD file's point record).
    Point(u64),
    /// A 0-based element of a named PLY element (`vertex`, `face`, `tristrips`, `range_grid`).
    Element {
        /// The element's name in the PLY header.
        name: String,
        /// 0-based index within the element.
        index: u64,
    },
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(l) => write!(f, "line {l}"),
            Location::Byte(b) => write!(f, "byte {b}"),
            Location::Vertex(v) => write!(f, "vertex {v}"),
            Location::Face(i) => write!(f, "face {i}"),
            Location::Point(i) => write!(f, "point {i}"),
            Location::Element { name, index } => write!(f, "{name} element {index}"),
        }
    }
}

/// The extensions [`crate::Format::from_extension`] knows, for messages.
const SUPPORTED: &str = ".off, .obj, .ply, .stl, .gltf, .glb, .xyz, .pts, .pcd";

/// What went wrong.
#[derive(Debug)]
#[non_exhaustive]
pub enum ErrorKind {
    /// Reading or writing the file failed at the operating-system level.
    Io(std::io::Error),
    /// The file extension is not one of the supported formats.
    UnknownFormat {
        /// The extension found (empty when the file has none).
        extension: String,
    },
    /// The file is empty.
    Empty,
    /// The file ends before the data its header announces.
    Truncated {
        /// What was being read when the data ran out.
        expected: String,
    },
    /// The file's syntax is wrong (bad header, a token that is not a number, …).
    Syntax(String),
    /// The header's counts disagree with the data.
    WrongCount {
        /// What was counted (`vertices`, `faces`, …).
        what: String,
        /// The count the header announces.
        declared: u64,
        /// The count found.
        found: u64,
    },
    /// A face refers to a vertex that does not exist.
    IndexOutOfRange {
        /// The offending vertex index as written in the file (0-based).
        index: u64,
        /// Number of vertices in the file.
        vertices: u64,
    },
    /// A coordinate is NaN or infinite.
    NonFiniteCoordinate,
    /// There are no vertices (a mesh) or points (a point cloud).
    NoVertices,
    /// The mesh has no usable faces.
    NoFaces {
        /// How many faces were dropped as degenerate before none was left.
        dropped: u64,
    },
    /// The file holds points and no faces: returned by [`crate::read_mesh`], which needs a
    /// mesh; [`crate::read_input`] reads such a file as a [`crate::PointCloud`].
    PointCloud {
        /// How many points the file holds.
        points: usize,
    },
    /// Any other problem, described in words.
    Other(String),
}

impl fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ErrorKind::Io(e) => write!(f, "{e}"),
            ErrorKind::UnknownFormat { extension } if extension.is_empty() => write!(
                f,
                "no file extension: cannot tell the format (supported: {SUPPORTED})"
            ),
            ErrorKind::UnknownFormat { extension } => write!(
                f,
                "unknown file format '.{extension}' (supported: {SUPPORTED})"
            ),
            ErrorKind::Empty => write!(f, "the file is empty"),
            ErrorKind::Truncated { expected } => {
                write!(f, "the file is truncated: it ends while reading {expected}")
            }
            ErrorKind::Syntax(m) => write!(f, "{m}"),
            ErrorKind::WrongCount {
                what,
                declared,
                found,
            } => write!(
                f,
                "the header declares {declared} {what} but the file has {found}"
            ),
            ErrorKind::IndexOutOfRange { index, vertices } => write!(
                f,
                "vertex index {index} is out of range (the mesh has {vertices} vertices)"
            ),
            ErrorKind::NonFiniteCoordinate => write!(f, "coordinate is NaN or infinite"),
            ErrorKind::NoVertices => write!(f, "there are no vertices or points"),
            ErrorKind::NoFaces { dropped: 0 } => write!(f, "the mesh has no faces"),
            ErrorKind::NoFaces { dropped } => write!(
                f,
                "the mesh has no usable faces: all {dropped} were degenerate (repeated vertex or zero area)"
            ),
            ErrorKind::PointCloud { points } => write!(
                f,
                "the file holds {points} points and no faces: it is a point cloud, not a mesh; \
                 keycomp reconstructs a surface from points when analysing (`detect`, \
                 `index add`, `query`, `match`)"
            ),
            ErrorKind::Other(m) => write!(f, "{m}"),
        }
    }
}

/// An error reading, validating or writing a mesh: the file (when known), where in it, and what
/// went wrong. Displays as `FILE: LOCATION: REASON`.
#[derive(Debug)]
pub struct MeshError {
    /// The file concerned, when known.
    pub path: Option<PathBuf>,
    /// Where in the file, when known.
    pub location: Option<Location>,
    /// What went wrong.
    pub kind: ErrorKind,
}

impl MeshError {
    /// An error of the given kind with no path or location yet.
    pub fn new(kind: ErrorKind) -> Self {
        MeshError {
            path: None,
            location: None,
            kind,
        }
    }

    /// Sets the location (keeps an existing one).
    pub fn at(mut self, location: Location) -> Self {
        if self.location.is_none() {
            self.location = Some(location);
        }
        self
    }

    /// Sets the file path (keeps an existing one).
    pub fn in_file(mut self, path: &Path) -> Self {
        if self.path.is_none() {
            self.path = Some(path.to_path_buf());
        }
        self
    }
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(p) = &self.path {
            write!(f, "{}: ", p.display())?;
        }
        if let Some(l) = &self.location {
            write!(f, "{l}: ")?;
        }
        write!(f, "{}", self.kind)
    }
}

impl std::error::Error for MeshError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        // the I/O error's text is already part of this error's message
        None
    }
}

impl From<std::io::Error> for MeshError {
    fn from(e: std::io::Error) -> Self {
        MeshError::new(ErrorKind::Io(e))
    }
}
