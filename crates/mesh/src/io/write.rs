//! Writes meshes: ascii OFF (exact round trip) and binary little-endian PLY with per-vertex
//! colours (for viewing results in MeshLab, Blender, CloudCompare, …).
//!
//! Both write through [`crate::io::output`]: atomically (a temporary file in the target's folder,
//! synced, renamed over the target; on any error the target is left as it was), following
//! symbolic links, writing FIFOs and devices in place and refusing directories.
//!
//! Coordinates are written with Rust's `{}` formatting of `f64`, the shortest text that parses
//! back to the same number, so reading a written OFF file gives exactly the same mesh. The PLY
//! stores coordinates as `double`, so it is exact too.

use std::io::{self, Write};
use std::path::Path;

use super::output::write_file;
use crate::{ErrorKind, Mesh, MeshError};

/// Writes `mesh` as ascii OFF.
///
/// The file is `OFF`, the counts `V F 0`, one `x y z` line per vertex and one `3 a b c` line per
/// face; numbers round-trip exactly. Written atomically (see the module documentation).
pub fn write_off(mesh: &Mesh, path: &Path) -> Result<(), MeshError> {
    write_atomically(path, |w| write_off_to(mesh, w))
}

/// Writes `mesh` as ascii OFF (as [`write_off`]) to `w`, for callers that manage the file.
pub fn write_off_to(mesh: &Mesh, w: &mut dyn Write) -> io::Result<()> {
    writeln!(w, "OFF")?;
    writeln!(w, "{} {} 0", mesh.positions.len(), mesh.faces.len())?;
    for p in &mesh.positions {
        writeln!(w, "{} {} {}", p.x, p.y, p.z)?;
    }
    for [a, b, c] in &mesh.faces {
        writeln!(w, "3 {a} {b} {c}")?;
    }
    Ok(())
}

/// Writes `mesh` as binary little-endian PLY with one RGB colour per vertex.
///
/// Vertices are `double x, y, z` and `uchar red, green, blue`; faces are
/// `list uchar int vertex_indices`. `colors` must have one entry per vertex (an error otherwise,
/// before anything is written). Written atomically (see the module documentation).
pub fn write_ply_colored(mesh: &Mesh, colors: &[[u8; 3]], path: &Path) -> Result<(), MeshError> {
    if colors.len() != mesh.positions.len() {
        return Err(MeshError::new(ErrorKind::Other(format!(
            "cannot write a coloured PLY: {} colours for {} vertices",
            colors.len(),
            mesh.positions.len()
        )))
        .in_file(path));
    }
    write_atomically(path, |w| {
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment written by keycomp\n\
             element vertex {}\nproperty double x\nproperty double y\nproperty double z\n\
             property uchar red\nproperty uchar green\nproperty uchar blue\n\
             element face {}\nproperty list uchar int vertex_indices\nend_header\n",
            mesh.positions.len(),
            mesh.faces.len()
        )?;
        for (p, c) in mesh.positions.iter().zip(colors) {
            for v in [p.x, p.y, p.z] {
                w.write_all(&v.to_le_bytes())?;
            }
            w.write_all(c)?;
        }
        for f in &mesh.faces {
            w.write_all(&[3])?;
            for &v in f {
                // Vertex ids fit in an `int` for any mesh a PLY reader accepts.
                w.write_all(&(v as i32).to_le_bytes())?;
            }
        }
        Ok(())
    })
}

/// Writes what `body` produces to `path` through [`super::output::Output`], the error naming
/// the file.
fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), MeshError> {
    write_file(path, body).map_err(|e| MeshError::from(e).in_file(path))
}
