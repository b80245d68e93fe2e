//! Triangle meshes for keycomp: reading and validating OFF, OBJ, PLY, STL and glTF meshes and
//! the point clouds and range scans that scanners give (PLY range grids and vertex-only PLY,
//! XYZ, PTS, PCD), writing OFF, coloured PLY and GLB, geometry (areas, bounding box, unit-area
//! normalisation), adjacency and synthetic shapes generated in code, range-grid triangulation
//! ([`grid`]), simplification by half-edge collapse ([`simplify`]) and multi-source Dijkstra
//! over the edges ([`graph`]).
//!
//! Two entry points read files: [`read_mesh`] when a mesh is needed (range grids come
//! triangulated; a file of points only is an [`ErrorKind::PointCloud`] error), [`read_input`]
//! for anything a file holds, a mesh or a [`PointCloud`] ([`Geometry`]), with what it was
//! ([`Source`]) and what was noticed on the way (warnings).
//!
//! Vertex ids are the file's own vertex order: readers never weld or reorder vertices (STL, which
//! has no shared vertices, is the one exception: its corners are merged by exact position, in
//! order of first appearance; an organised PCD cloud, whose invalid points are dropped, the
//! other). Faces with a repeated index or zero area are dropped and counted in a [`Repairs`]
//! report; unreferenced vertices are kept. Non-manifold edges, open boundaries and several
//! connected pieces are valid input.

pub mod cut;
mod error;
pub mod geometry;
pub mod graph;
pub mod grid;
pub mod io;
pub mod sample;
pub mod simplify;
pub mod smooth;
pub mod synth;
mod topology;

pub use error::{ErrorKind, Location, MeshError};
pub use grid::triangulate_grid;
pub use io::{
    Format, Geometry, LoadedInput, LoadedMesh, Source, glb_bytes, read_input,
    read_input_from_bytes, read_mesh, read_mesh_from_bytes, write_glb, write_off, write_off_to,
    write_ply_colored,
};
pub use nalgebra::{Point3, Vector3};
pub use topology::Topology;

/// A vertex id: the index of the vertex in the file's own vertex order.
pub type VertexId = u32;

/// A triangle mesh: vertex positions and triangles (three vertex ids, counter-clockwise as in
/// the file).
///
/// Connectivity (adjacency) lives in [`Topology`], built once from a mesh; geometry helpers are
/// in [`geometry`].
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Vertex positions, indexed by [`VertexId`].
    pub positions: Vec<Point3<f64>>,
    /// Triangles as vertex ids.
    pub faces: Vec<[VertexId; 3]>,
}

/// Points without connectivity: a scan or a point cloud as read from a file.
///
/// Positions are finite; normals, when the file gives them (and every one is finite), have one
/// entry per point, as stored (not normalised).
#[derive(Debug, Clone, PartialEq)]
pub struct PointCloud {
    /// Point positions, in the file's order (invalid points dropped where a format marks them).
    pub positions: Vec<Point3<f64>>,
    /// Per-point normals, when the file has them.
    pub normals: Option<Vec<Vector3<f64>>>,
}

impl PointCloud {
    /// Number of points.
    pub fn num_points(&self) -> usize {
        self.positions.len()
    }
}

/// What [`Mesh::from_raw`] changed or noticed while validating raw data. Nothing here is an
/// error: these are repairs that change nothing a user cares about.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Repairs {
    /// Faces dropped because two of their vertex ids were equal.
    pub repeated_index_faces: usize,
    /// Faces dropped because their area is zero (collinear or coincident corners).
    pub zero_area_faces: usize,
    /// Vertices no face refers to (kept, so ids stay the file's own, but ignored by algorithms).
    pub unreferenced_vertices: usize,
}

impl Repairs {
    /// Total number of faces dropped.
    pub fn dropped_faces(&self) -> usize {
        self.repeated_index_faces + self.zero_area_faces
    }
}

/// A face is dropped as zero-area when twice its area is at most this fraction of its longest
/// squared edge (that is, its corners are collinear to about 1e-12 relative precision).
const ZERO_AREA_RELATIVE: f64 = 1e-12;

impl Mesh {
    /// Validates raw vertex and face data and builds a mesh.
    ///
    /// Errors (with the offending element as [`Location::Vertex`] or [`Location::Face`]): a
    /// non-finite coordinate, a face index out of range, no faces left after dropping degenerate
    /// ones. Faces with a repeated vertex id or zero area are dropped and counted in the returned
    /// [`Repairs`]. The error carries no path; readers add it.
    pub fn from_raw(
        positions: Vec<Point3<f64>>,
        faces: Vec<[VertexId; 3]>,
    ) -> Result<(Mesh, Repairs), MeshError> {
        if positions.is_empty() {
            return Err(MeshError::new(ErrorKind::NoVertices));
        }
        if let Some(i) = positions
            .iter()
            .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
        {
            return Err(
                MeshError::new(ErrorKind::NonFiniteCoordinate).at(Location::Vertex(i as u64))
            );
        }
        let n = positions.len();
        let mut repairs = Repairs::default();
        let mut kept = Vec::with_capacity(faces.len());
        for (fi, f) in faces.into_iter().enumerate() {
            if let Some(&bad) = f.iter().find(|&&v| v as usize >= n) {
                return Err(MeshError::new(ErrorKind::IndexOutOfRange {
                    index: bad as u64,
                    vertices: n as u64,
                })
                .at(Location::Face(fi as u64)));
            }
            if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
                repairs.repeated_index_faces += 1;
                continue;
            }
            let [a, b, c] = f.map(|v| positions[v as usize]);
            let cross = (b - a).cross(&(c - a)).norm();
            let longest = (b - a)
                .norm_squared()
                .max((c - b).norm_squared())
                .max((a - c).norm_squared());
            if cross <= ZERO_AREA_RELATIVE * longest {
                repairs.zero_area_faces += 1;
                continue;
            }
            kept.push(f);
        }
        if kept.is_empty() {
            return Err(MeshError::new(ErrorKind::NoFaces {
                dropped: repairs.dropped_faces() as u64,
            }));
        }
        let mut used = vec![false; n];
        for f in &kept {
            for &v in f {
                used[v as usize] = true;
            }
        }
        repairs.unreferenced_vertices = used.iter().filter(|u| !**u).count();
        Ok((
            Mesh {
                positions,
                faces: kept,
            },
            repairs,
        ))
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of faces.
    pub fn num_faces(&self) -> usize {
        self.faces.len()
    }

    /// The three corner positions of face `f`.
    #[inline]
    pub fn triangle(&self, f: usize) -> [Point3<f64>; 3] {
        self.faces[f].map(|v| self.positions[v as usize])
    }
}
