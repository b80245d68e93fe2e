//! Reads Wavefront OBJ files: the geometry only (`v` and `f` statements).
//!
//! Conventions:
//! - Vertex i of the mesh is the i-th `v` line of the file, over the whole file: objects (`o`)
//!   and groups (`g`) all go into one mesh with the file's global numbering, and vertices no face
//!   uses are kept. A fourth value (`w`) or vertex colours after `x y z` are ignored.
//! - `f` (and the old `fo`) corners are `v`, `v/vt`, `v//vn` or `v/vt/vn`; only `v` is used.
//!   Indices are 1-based; negative indices are relative to the last vertex defined so far
//!   (`-1` is the previous `v`). A face may refer to a vertex defined later in the file.
//!   Polygons are fan-triangulated: `(v1, vk, vk+1)`.
//! - Everything else (`vt`, `vn`, `l`, `p`, `usemtl`, `mtllib`, `s`, …) is ignored; `#` starts
//!   a comment; a line ending in `\` continues on the next line.
//!
//! Errors name the 1-based line. The `tobj` crate is not used for reading because it renumbers
//! vertices per object in order of first use and drops unused ones (there is no option to keep
//! the file's numbering) and its errors carry no line number; it serves as an oracle in the tests.

use super::RawMesh;
use super::text::{Lines, parse_i64, parse_xyz, show, syntax, tokens};
use crate::{ErrorKind, Location, MeshError, Point3, VertexId};

/// Parses the bytes of an OBJ file into raw vertices and triangles.
pub(crate) fn read_obj(bytes: &[u8]) -> Result<RawMesh, MeshError> {
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(MeshError::new(ErrorKind::Empty));
    }
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    // The largest forward reference (0-based) and its line: checked once all `v` are known.
    let mut forward: Option<(u64, u64)> = None;
    let mut joined: Vec<u8> = Vec::new();
    let mut joined_start = 0;
    for (ln, raw) in Lines::new(bytes, Some(b'#')) {
        // Line continuation: a trailing backslash joins the next line.
        let trimmed = raw.trim_ascii_end();
        if let Some(head) = trimmed.strip_suffix(b"\\") {
            if joined.is_empty() {
                joined_start = ln;
            }
            joined.extend_from_slice(head);
            joined.push(b' ');
            continue;
        }
        let (ln, line) = if joined.is_empty() {
            (ln, raw)
        } else {
            joined.extend_from_slice(raw);
            (joined_start, &joined[..])
        };
        statement(line, ln, &mut positions, &mut faces, &mut forward)?;
        joined.clear();
    }
    if !joined.is_empty() {
        let line = std::mem::take(&mut joined);
        statement(
            &line,
            joined_start,
            &mut positions,
            &mut faces,
            &mut forward,
        )?;
    }
    if let Some((index, ln)) = forward
        && index >= positions.len() as u64
    {
        return Err(MeshError::new(ErrorKind::IndexOutOfRange {
            index,
            vertices: positions.len() as u64,
        })
        .at(Location::Line(ln)));
    }
    Ok(RawMesh { positions, faces })
}

/// Handles one (joined) line.
fn statement(
    line: &[u8],
    ln: u64,
    positions: &mut Vec<Point3<f64>>,
    faces: &mut Vec<[VertexId; 3]>,
    forward: &mut Option<(u64, u64)>,
) -> Result<(), MeshError> {
    let mut toks = tokens(line);
    match toks.next() {
        Some(b"v") => {
            let [x, y, z] = parse_xyz(toks, ln, "a 'v' line")?;
            if positions.len() >= VertexId::MAX as usize {
                return Err(syntax(ln, "more than 2^32 - 1 vertices".into()));
            }
            positions.push(Point3::new(x, y, z));
        }
        Some(b"f") | Some(b"fo") => {
            let defined = positions.len() as u64;
            let mut corner = |t: &[u8]| -> Result<VertexId, MeshError> {
                let v = t.split(|&b| b == b'/').next().unwrap_or_default();
                let i = parse_i64(v).ok_or_else(|| {
                    syntax(
                        ln,
                        format!("face corner '{}' is not a vertex index", show(t)),
                    )
                })?;
                let index = match i {
                    0 => {
                        return Err(syntax(
                            ln,
                            "vertex index 0 is invalid (OBJ indices start at 1)".into(),
                        ));
                    }
                    i if i > 0 => (i - 1) as u64,
                    i => {
                        // Relative: -1 is the last vertex defined so far.
                        let back = i.unsigned_abs();
                        if back > defined {
                            return Err(syntax(
                                ln,
                                format!(
                                    "relative vertex index {i} points before the first vertex \
                                     ({defined} defined so far)"
                                ),
                            ));
                        }
                        defined - back
                    }
                };
                if index >= u64::from(VertexId::MAX) {
                    return Err(MeshError::new(ErrorKind::IndexOutOfRange {
                        index,
                        vertices: defined,
                    })
                    .at(Location::Line(ln)));
                }
                if index >= defined && forward.is_none_or(|(f, _)| index > f) {
                    *forward = Some((index, ln));
                }
                Ok(index as VertexId)
            };
            let mut n = 0;
            let (mut first, mut prev) = (0, 0);
            for t in toks {
                let v = corner(t)?;
                match n {
                    0 => first = v,
                    1 => {}
                    _ => faces.push([first, prev, v]),
                }
                prev = v;
                n += 1;
            }
            if n < 3 {
                return Err(syntax(
                    ln,
                    format!("a face needs at least 3 vertices, this one has {n}"),
                ));
            }
        }
        _ => {}
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> (ErrorKind, Option<Location>) {
        let e = read_obj(text.as_bytes()).unwrap_err();
        (e.kind, e.location)
    }

    #[test]
    fn global_numbering_across_objects_and_corner_forms() {
        let text = "# two objects\nmtllib x.mtl\no a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 9 9 9\n\
                    vt 0 0\nvn 0 0 1\ng g1\nusemtl m\ns 1\nf 1/1/1 2/1/1 3/1/1\n\
                    o b\nv 0 0 1\nv 1 0 1 1.0\nv 0 1 1 0.5 0.5 0.5\nv 1 1 1\n\
                    f -4//1 -3//1 \\\n -1//1 -2//1\nl 1 2\nf 5/1 6/1 7/1\n";
        let m = read_obj(text.as_bytes()).unwrap();
        assert_eq!(m.positions.len(), 8);
        assert_eq!(m.positions[3], Point3::new(9.0, 9.0, 9.0)); // unused, kept
        assert_eq!(m.positions[5], Point3::new(1.0, 0.0, 1.0));
        assert_eq!(m.faces, vec![[0, 1, 2], [4, 5, 7], [4, 7, 6], [4, 5, 6]]);
    }

    #[test]
    fn forward_references_are_allowed() {
        let m = read_obj(b"f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n").unwrap();
        assert_eq!(m.faces, vec![[0, 1, 2]]);
    }

    #[test]
    fn errors_name_the_line() {
        assert!(matches!(err("").0, ErrorKind::Empty));
        assert!(matches!(err(" \n\n").0, ErrorKind::Empty));
        let (k, l) = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
        assert!(matches!(
            k,
            ErrorKind::IndexOutOfRange {
                index: 3,
                vertices: 3
            }
        ));
        assert_eq!(l, Some(Location::Line(4)));
        let (k, l) = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n");
        assert!(matches!(k, ErrorKind::Syntax(_)));
        assert_eq!(l, Some(Location::Line(4)));
        let (k, l) = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
        assert!(matches!(k, ErrorKind::Syntax(_)));
        assert_eq!(l, Some(Location::Line(4)));
        let (k, l) = err("v 0 0 0\nv 1 NaN 0\n");
        assert!(matches!(k, ErrorKind::NonFiniteCoordinate));
        assert_eq!(l, Some(Location::Line(2)));
        let (k, l) = err("v 0 0 0\nv 1 0\n");
        assert!(matches!(k, ErrorKind::Syntax(_)));
        assert_eq!(l, Some(Location::Line(2)));
        let (k, l) = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n");
        assert!(matches!(k, ErrorKind::Syntax(_)));
        assert_eq!(l, Some(Location::Line(4)));
        let (k, l) = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 x 3\n");
        assert!(matches!(k, ErrorKind::Syntax(ref m) if m.contains("'x'")));
        assert_eq!(l, Some(Location::Line(4)));
        let (k, l) = err("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n");
        assert!(matches!(k, ErrorKind::Syntax(_)));
        assert_eq!(l, Some(Location::Line(4)));
    }
}
