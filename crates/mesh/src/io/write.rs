//! Writes meshes: ascii OFF (exact round trip) and binary little-endian PLY with per-vertex
//! colours (for viewing results in MeshLab, Blender, CloudCompare, …).
//!
//! Both write atomically: the data goes to a temporary file in the target's directory
//! (`.NAME.PID.N.tmp`), which is flushed, synced and renamed over the target. On any error the
//! temporary file is removed and the target is left as it was.
//!
//! Coordinates are written with Rust's `{}` formatting of `f64`, the shortest text that parses
//! back to the same number, so reading a written OFF file gives exactly the same mesh. The PLY
//! stores coordinates as `double`, so it is exact too.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::{ErrorKind, Mesh, MeshError};

/// Writes `mesh` as ascii OFF.
///
/// The file is `OFF`, the counts `V F 0`, one `x y z` line per vertex and one `3 a b c` line per
/// face; numbers round-trip exactly. Written atomically (see the module documentation).
pub fn write_off(mesh: &Mesh, path: &Path) -> Result<(), MeshError> {
    write_atomically(path, |w| {
        writeln!(w, "OFF")?;
        writeln!(w, "{} {} 0", mesh.positions.len(), mesh.faces.len())?;
        for p in &mesh.positions {
            writeln!(w, "{} {} {}", p.x, p.y, p.z)?;
        }
        for [a, b, c] in &mesh.faces {
            writeln!(w, "3 {a} {b} {c}")?;
        }
        Ok(())
    })
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

/// Makes temporary names unique within the process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Runs `body` on a buffered temporary file next to `path`, then syncs and renames it to `path`.
pub(crate) fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> Result<(), MeshError> {
    let err = |e: io::Error| MeshError::from(e).in_file(path);
    let Some(name) = path.file_name() else {
        return Err(MeshError::new(ErrorKind::Other(
            "cannot write: the path does not name a file".into(),
        ))
        .in_file(path));
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let tmp = dir.join(format!(
        ".{}.{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .map_err(err)?;
    let result = (|| {
        let mut w = BufWriter::new(file);
        body(&mut w)?;
        let file = w.into_inner().map_err(io::IntoInnerError::into_error)?;
        file.sync_data()?;
        drop(file);
        fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = fs::remove_file(&tmp);
        return Err(err(e));
    }
    Ok(())
}
