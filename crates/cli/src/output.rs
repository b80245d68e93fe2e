//! Writing results: JSON and text to stdout (a closed pipe is not an error), and atomic writes
//! of output files.

use std::io::{self, Write};
use std::path::Path;

use anyhow::{Context, Result};
use serde::Serialize;

/// Whether an error chain ends in a broken pipe (stdout closed by `head`, a pager, …).
pub fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<io::Error>()
            .is_some_and(|io| io.kind() == io::ErrorKind::BrokenPipe)
    })
}

/// Prints `value` as pretty JSON on stdout, followed by a newline. Buffered: stdout is line
/// buffered, and pretty JSON has a line per value (a detection's vertex lists made tens of
/// thousands of writes).
pub fn print_json<T: Serialize>(value: &T) -> Result<()> {
    let mut out = io::BufWriter::with_capacity(1 << 16, io::stdout().lock());
    serde_json::to_writer_pretty(&mut out, value).map_err(io::Error::from)?;
    writeln!(out)?;
    out.flush()?;
    Ok(())
}

/// Prints text on stdout.
pub fn print_text(text: &str) -> Result<()> {
    let mut out = io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()?;
    Ok(())
}

/// Writes `bytes` to the file `path` through [`keycomp_mesh::io::output`]: atomically, symbolic
/// links followed, a FIFO or device written in place, a directory or a missing folder refused.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    keycomp_mesh::io::output::write_file(path, |w| w.write_all(bytes))
        .with_context(|| format!("{}: cannot write", path.display()))
}

pub use keycomp::folders::{check_output_folder, create_output_folder};

/// The error and its causes on one line, as anyhow's `{:#}` prints them but saying each cause
/// once ([`keycomp::error_line`]).
pub fn error_chain(e: &anyhow::Error) -> String {
    keycomp::error_line(e.as_ref())
}

/// Writes per-vertex `colours` of `analysed` (the mesh detection ran on) as a coloured PLY of
/// what the file held. When `analysed` is the canonical surface of `input`, each of the input's
/// vertices (or points, written without faces) takes the colour of its nearest canonical
/// vertex, so the picture is of the file's own vertices; without `input`, `analysed` itself.
pub fn write_colours_on_input(
    input: Option<keycomp_mesh::Geometry>,
    analysed: &keycomp_mesh::Mesh,
    colours: &[[u8; 3]],
    out: &Path,
) -> Result<()> {
    use keycomp_mesh::{Geometry, Mesh};
    let Some(input) = input else {
        keycomp_mesh::write_ply_colored(analysed, colours, out)?;
        return Ok(());
    };
    let on_input = match input {
        Geometry::Mesh(m) => m,
        Geometry::Points(c) => Mesh {
            positions: c.positions,
            faces: Vec::new(),
        },
    };
    let nearest = keycomp_surface::nearest_vertices(&on_input.positions, &analysed.positions)
        .unwrap_or_else(|| vec![u32::MAX; on_input.positions.len()]);
    let mapped: Vec<[u8; 3]> = nearest
        .iter()
        .map(|&v| {
            colours
                .get(v as usize)
                .copied()
                .unwrap_or(crate::colors::GREY)
        })
        .collect();
    keycomp_mesh::write_ply_colored(&on_input, &mapped, out)?;
    Ok(())
}

/// The format [`write_moved`] writes `out` in, by its extension: "off", "ply" or "glb"; an
/// error naming `out` for any other (checked before any work).
pub fn moved_format(out: &Path) -> Result<&'static str> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    ["off", "ply", "glb"]
        .into_iter()
        .find(|f| *f == ext)
        .ok_or_else(|| {
            anyhow::anyhow!(
                "{}: the aligned copy is written as .off, .ply or .glb (by its extension)",
                out.display()
            )
        })
}

/// Writes `input` (a file's mesh or points) moved by `t` to `out`, in the format its extension
/// names ([`moved_format`]): `.off` (points as an OFF without faces), `.ply` (binary, grey) or
/// `.glb`. Atomic: a failure leaves nothing half-written.
pub fn write_moved(
    input: &keycomp_mesh::Geometry,
    t: &keycomp::transform::Transform,
    out: &Path,
) -> Result<()> {
    use keycomp_mesh::{Geometry, Mesh, Point3};
    let (positions, faces) = match input {
        Geometry::Mesh(m) => (&m.positions, m.faces.clone()),
        Geometry::Points(c) => (&c.positions, Vec::new()),
    };
    let moved = Mesh {
        positions: positions
            .iter()
            .map(|p| {
                let [x, y, z] = t.apply([p.x, p.y, p.z]);
                Point3::new(x, y, z)
            })
            .collect(),
        faces,
    };
    match moved_format(out)? {
        "off" => keycomp_mesh::write_off(&moved, out)?,
        "ply" => keycomp_mesh::write_ply_colored(
            &moved,
            &vec![crate::colors::GREY; moved.positions.len()],
            out,
        )?,
        "glb" if !moved.faces.is_empty() => keycomp_mesh::write_glb(&moved, out)?,
        _ => anyhow::bail!(
            "{}: a point cloud cannot be written as GLB; use .off or .ply",
            out.display()
        ),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_chain_says_each_cause_once() {
        let io = io::Error::new(io::ErrorKind::NotFound, "No such file");
        let e = anyhow::Error::from(io).context("x.csv: cannot read: No such file");
        assert_eq!(error_chain(&e), "x.csv: cannot read: No such file");
        let e = anyhow::anyhow!("inner").context("outer");
        assert_eq!(error_chain(&e), "outer: inner");
    }
}
