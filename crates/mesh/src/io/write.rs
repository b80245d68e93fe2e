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

/// Writes `mesh` as a binary glTF 2.0 file (GLB): one mesh of one indexed triangle primitive,
/// drawn by one node at the origin; positions as 32-bit floats (rounded from the mesh's
/// `f64`), indices as 32-bit integers, vertex ids kept. Written atomically (see the module
/// documentation).
pub fn write_glb(mesh: &Mesh, path: &Path) -> Result<(), MeshError> {
    write_atomically(path, |w| w.write_all(&glb_bytes(mesh, None)))
}

/// The bytes of [`write_glb`]'s file, with `colors` (one per vertex, sRGB) as the primitive's
/// `COLOR_0` (normalised unsigned bytes, RGBA with A = 255, 4-byte aligned as glTF asks of
/// vertex attributes). Colours of another length than the vertices are left out.
pub fn glb_bytes(mesh: &Mesh, colors: Option<&[[u8; 3]]>) -> Vec<u8> {
    let colors = colors.filter(|c| c.len() == mesh.positions.len());
    let mut bin = Vec::with_capacity(16 * mesh.positions.len() + 12 * mesh.faces.len());
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in &mesh.positions {
        let c = [p.x as f32, p.y as f32, p.z as f32];
        for k in 0..3 {
            lo[k] = lo[k].min(c[k]);
            hi[k] = hi[k].max(c[k]);
            bin.extend_from_slice(&c[k].to_le_bytes());
        }
    }
    let positions_len = bin.len();
    for f in &mesh.faces {
        for v in f {
            bin.extend_from_slice(&v.to_le_bytes());
        }
    }
    let indices_len = bin.len() - positions_len;
    let (color_attribute, color_view, color_accessor) = match colors {
        Some(colors) => {
            let offset = bin.len();
            for c in colors {
                bin.extend_from_slice(&[c[0], c[1], c[2], 255]);
            }
            (
                r#","COLOR_0":2"#.to_string(),
                format!(
                    r#",{{"buffer":0,"byteOffset":{offset},"byteLength":{},"target":34962}}"#,
                    bin.len() - offset
                ),
                format!(
                    r#",{{"bufferView":2,"componentType":5121,"normalized":true,"count":{},"type":"VEC4"}}"#,
                    colors.len()
                ),
            )
        }
        None => Default::default(),
    };
    let json = format!(
        concat!(
            r#"{{"asset":{{"version":"2.0","generator":"keycomp"}},"scene":0,"scenes":[{{"nodes":[0]}}],"#,
            r#""nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0{}}},"indices":1,"mode":4}}]}}],"#,
            r#""buffers":[{{"byteLength":{}}}],"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{},"target":34962}},"#,
            r#"{{"buffer":0,"byteOffset":{},"byteLength":{},"target":34963}}{}],"#,
            r#""accessors":[{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3","min":[{:?},{:?},{:?}],"max":[{:?},{:?},{:?}]}},"#,
            r#"{{"bufferView":1,"componentType":5125,"count":{},"type":"SCALAR"}}{}]}}"#
        ),
        color_attribute,
        bin.len(),
        positions_len,
        positions_len,
        indices_len,
        color_view,
        mesh.positions.len(),
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2],
        3 * mesh.faces.len(),
        color_accessor,
    );
    glb_container(json.as_bytes(), &bin)
}

/// A GLB file of one JSON chunk and one BIN chunk (left out when `bin` is empty), each padded
/// to 4 bytes (JSON with spaces, BIN with zeros), after the 12-byte header.
pub(crate) fn glb_container(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |b: &[u8], with: u8| {
        let mut v = b.to_vec();
        v.resize(b.len().div_ceil(4) * 4, with);
        v
    };
    let (json, bin) = (pad(json, b' '), pad(bin, 0));
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
    }
    out
}

/// Writes what `body` produces to `path` through [`super::output::Output`], the error naming
/// the file.
fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> Result<(), MeshError> {
    write_file(path, body).map_err(|e| MeshError::from(e).in_file(path))
}
