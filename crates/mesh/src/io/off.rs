//! Reads ascii OFF (Object File Format) files.
//!
//! Layout: an optional header keyword (`OFF`, `NOFF`, `COFF`, `CNOFF`, `STOFF`, … — any of the
//! prefixes `ST`, `C`, `N` before `OFF`), then the counts `vertices faces [edges]` (on the header
//! line or the next line; files without a keyword that start directly with the counts, such as
//! some exports of the Stanford bunny, are accepted too), then one vertex per line, then one face
//! per line as `n i1 … in`.
//!
//! Conventions:
//! - `#` starts a comment anywhere; blank lines are skipped.
//! - A vertex line holds at least three coordinates; further columns (normals for `NOFF`, colours
//!   for `COFF`, texture coordinates for `ST`) are ignored.
//! - Face indices are 0-based; columns after the `n` indices (a face colour) are ignored.
//!   Polygons (n > 3) are fan-triangulated: `(i1, ik, ik+1)`.
//! - The edge count is ignored. Lines after the declared faces are an error (wrong count).
//! - Not supported, with a clear error: binary OFF (`OFF BINARY`), 4-D (`4OFF`) and n-D (`nOFF`).
//!
//! Errors name the 1-based line. The parser works on the byte buffer without allocating per
//! token; preallocation is capped by the file size, so absurd header counts are harmless.

use super::RawMesh;
use super::text::{Lines, capped, parse_f64, parse_i64, parse_xyz, show, syntax, tokens};
use crate::{ErrorKind, Location, MeshError, Point3, VertexId};

/// Parses the bytes of an OFF file into raw vertices and triangles (not yet validated by
/// [`crate::Mesh::from_raw`]).
pub(crate) fn read_off(bytes: &[u8]) -> Result<RawMesh, MeshError> {
    let mut lines = Lines::new(bytes, Some(b'#'));
    let Some((first_line, first)) = lines.next_nonblank() else {
        return Err(MeshError::new(ErrorKind::Empty));
    };

    // Header keyword, then counts on the same line or the next one.
    let mut toks = tokens(first);
    let head = toks.next().unwrap_or_default();
    let (counts_line, counts): (u64, Vec<&[u8]>) = if parse_i64(head).is_some() {
        (first_line, tokens(first).collect())
    } else {
        check_keyword(head, first_line)?;
        let rest: Vec<&[u8]> = toks.collect();
        if rest
            .first()
            .is_some_and(|t| t.eq_ignore_ascii_case(b"BINARY"))
        {
            return Err(MeshError::new(ErrorKind::Other(
                "binary OFF is not supported; convert the file to ascii OFF, PLY or OBJ".into(),
            ))
            .at(Location::Line(first_line)));
        }
        if rest.is_empty() {
            match lines.next_nonblank() {
                Some((n, l)) => (n, tokens(l).collect()),
                None => {
                    return Err(MeshError::new(ErrorKind::Truncated {
                        expected: "the vertex and face counts".into(),
                    })
                    .at(Location::Line(lines.line() + 1)));
                }
            }
        } else {
            (first_line, rest)
        }
    };
    let (nv, nf) = parse_counts(&counts, counts_line)?;

    let mut positions = Vec::with_capacity(capped(nv, bytes.len(), 6));
    for i in 0..nv {
        let Some((ln, line)) = lines.next_nonblank() else {
            return Err(MeshError::new(ErrorKind::Truncated {
                expected: format!("vertex {i} of the {nv} declared"),
            })
            .at(Location::Line(lines.line() + 1)));
        };
        let [x, y, z] = parse_xyz(tokens(line), ln, "a vertex line")?;
        positions.push(Point3::new(x, y, z));
    }

    let mut faces = Vec::with_capacity(capped(nf, bytes.len(), 8));
    for j in 0..nf {
        let Some((ln, line)) = lines.next_nonblank() else {
            return Err(MeshError::new(ErrorKind::Truncated {
                expected: format!("face {j} of the {nf} declared"),
            })
            .at(Location::Line(lines.line() + 1)));
        };
        read_face(line, ln, nv, &mut faces)?;
    }

    if let Some((ln, _)) = lines.next_nonblank() {
        let extra = 1 + lines
            .by_ref()
            .filter(|(_, l)| !super::text::is_blank(l))
            .count();
        return Err(MeshError::new(ErrorKind::WrongCount {
            what: "faces".into(),
            declared: nf,
            found: nf + extra as u64,
        })
        .at(Location::Line(ln)));
    }
    Ok(RawMesh { positions, faces })
}

/// Accepts `[ST][C][N]OFF` in any order of the prefixes; rejects 4-D, n-D and anything else.
fn check_keyword(head: &[u8], line: u64) -> Result<(), MeshError> {
    let unknown = || {
        syntax(
            line,
            format!(
                "expected an OFF header ('OFF', 'NOFF', 'COFF', 'CNOFF') or the vertex and face \
                 counts, found '{}'",
                show(head)
            ),
        )
    };
    let Some(prefix) = head.strip_suffix(b"OFF") else {
        return Err(unknown());
    };
    let prefix: Vec<u8> = match prefix.windows(2).position(|w| w == b"ST") {
        Some(i) => [&prefix[..i], &prefix[i + 2..]].concat(),
        None => prefix.to_vec(),
    };
    if prefix.contains(&b'4') || prefix.contains(&b'n') {
        return Err(MeshError::new(ErrorKind::Other(format!(
            "'{}' (4-D or n-D OFF) is not supported: only 3-D meshes",
            show(head)
        )))
        .at(Location::Line(line)));
    }
    if prefix.iter().all(|&c| c == b'C' || c == b'N') && prefix.len() <= 2 {
        Ok(())
    } else {
        Err(unknown())
    }
}

/// The vertex and face counts (the edge count, if present, is ignored).
fn parse_counts(counts: &[&[u8]], line: u64) -> Result<(u64, u64), MeshError> {
    if counts.len() < 2 {
        return Err(syntax(
            line,
            format!(
                "expected the counts 'vertices faces edges', found {} number(s)",
                counts.len()
            ),
        ));
    }
    let mut out = [0u64; 2];
    for (o, (t, what)) in out.iter_mut().zip(counts.iter().zip(["vertex", "face"])) {
        let v = parse_i64(t).ok_or_else(|| {
            syntax(
                line,
                format!("the {what} count '{}' is not an integer", show(t)),
            )
        })?;
        *o = u64::try_from(v)
            .map_err(|_| syntax(line, format!("the {what} count {v} is negative")))?;
    }
    if out[0] > u64::from(VertexId::MAX) {
        return Err(syntax(
            line,
            format!(
                "{} vertices is more than this program supports (2^32 - 1)",
                out[0]
            ),
        ));
    }
    Ok((out[0], out[1]))
}

/// Parses one face line `n i1 … in [colour]` and appends its fan triangles.
fn read_face(
    line: &[u8],
    ln: u64,
    nv: u64,
    faces: &mut Vec<[VertexId; 3]>,
) -> Result<(), MeshError> {
    let mut toks = tokens(line);
    let Some(nt) = toks.next() else {
        return Err(syntax(ln, "empty face line".into()));
    };
    let n = match parse_i64(nt) {
        Some(n) => n,
        None if parse_f64(nt).is_some() => {
            return Err(syntax(
                ln,
                format!(
                    "expected a face ('n i1 … in'), found '{}': this looks like a vertex; the \
                     header may declare too few vertices",
                    show(nt)
                ),
            ));
        }
        None => {
            return Err(syntax(
                ln,
                format!("the face size '{}' is not an integer", show(nt)),
            ));
        }
    };
    if n < 3 {
        let hint = if tokens(line).any(|t| parse_i64(t).is_none() && parse_f64(t).is_some()) {
            ": this looks like a vertex; the header may declare too few vertices"
        } else {
            ""
        };
        return Err(syntax(
            ln,
            format!("a face needs at least 3 vertices, this one declares {n}{hint}"),
        ));
    }
    let mut index = |k: i64| -> Result<VertexId, MeshError> {
        let Some(t) = toks.next() else {
            return Err(syntax(
                ln,
                format!("the face declares {n} vertices but lists only {k}"),
            ));
        };
        let v = parse_i64(t)
            .ok_or_else(|| syntax(ln, format!("vertex index '{}' is not an integer", show(t))))?;
        if v < 0 {
            return Err(syntax(
                ln,
                format!("vertex index {v} is negative (OFF indices start at 0)"),
            ));
        }
        let v = v as u64;
        if v >= nv {
            return Err(MeshError::new(ErrorKind::IndexOutOfRange {
                index: v,
                vertices: nv,
            })
            .at(Location::Line(ln)));
        }
        Ok(v as VertexId)
    };
    let first = index(0)?;
    let mut prev = index(1)?;
    for k in 2..n {
        let v = index(k)?;
        faces.push([first, prev, v]);
        prev = v;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{Format, read_mesh_from_bytes};

    fn read(text: &str) -> Result<RawMesh, MeshError> {
        read_off(text.as_bytes())
    }

    fn kind_line(text: &str) -> (ErrorKind, Option<Location>) {
        let e = read(text).unwrap_err();
        (e.kind, e.location)
    }

    #[test]
    fn variants_comments_and_counts_on_header_line() {
        let plain = "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 2 3\n";
        let m = read(plain).unwrap();
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.positions[1], Point3::new(1.0, 0.0, 0.0));
        let others = [
            "# comment\nOFF # here too\n# and here\n4 2 5\n0 0 0\n1 0 0 # x\n0 1 0\n\n0 0 1\n3 0 1 2\n3 0 2 3\n",
            "OFF 4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 2 3\n",
            "4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 2 3\n",
            "NOFF\n4 2 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n0 0 1 0 0 1\n3 0 1 2\n3 0 2 3\n",
            "COFF\n4 2\n0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n0 1 0 1 1 1 1\n0 0 1 1 1 1 1\n3 0 1 2 255 0 0\n3 0 2 3\n",
            "CNOFF\r\n4 2 0\r\n0 0 0 0 0 1 1 1 1 1\r\n1 0 0 0 0 1 1 1 1 1\r\n0 1 0 0 0 1 1 1 1 1\r\n0 0 1 0 0 1 1 1 1 1\r\n3 0 1 2\r\n3 0 2 3",
            "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n4 0 1 2 3\n",
        ];
        for t in others {
            let o = read(t).unwrap_or_else(|e| panic!("{t:?}: {e}"));
            assert_eq!(o.positions, m.positions, "{t:?}");
            assert_eq!(o.faces, m.faces, "{t:?}");
        }
    }

    #[test]
    fn errors_name_the_line() {
        let (k, l) = kind_line("");
        assert!(matches!(k, ErrorKind::Empty) && l.is_none());
        let (k, l) = kind_line("# only a comment\n\n");
        assert!(matches!(k, ErrorKind::Empty) && l.is_none());
        let (k, l) = kind_line("OFF\n4 1 0\n0 0 0\n1 0 0\n");
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        assert_eq!(l, Some(Location::Line(5)));
        let (k, l) = kind_line("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        assert_eq!(l, Some(Location::Line(7)));
        let (k, l) = kind_line("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n\n3 2 1 0\n");
        assert!(matches!(
            k,
            ErrorKind::WrongCount {
                declared: 1,
                found: 3,
                ..
            }
        ));
        assert_eq!(l, Some(Location::Line(7)));
        let (k, l) = kind_line("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
        assert!(matches!(
            k,
            ErrorKind::IndexOutOfRange {
                index: 3,
                vertices: 3
            }
        ));
        assert_eq!(l, Some(Location::Line(6)));
        let (k, l) = kind_line("OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n");
        assert!(matches!(k, ErrorKind::NonFiniteCoordinate));
        assert_eq!(l, Some(Location::Line(4)));
        let (k, l) = kind_line("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 inf\n3 0 1 2\n");
        assert!(matches!(k, ErrorKind::NonFiniteCoordinate));
        assert_eq!(l, Some(Location::Line(5)));
        let (k, l) = kind_line("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n");
        assert!(matches!(k, ErrorKind::Syntax(ref m) if m.contains("negative")));
        assert_eq!(l, Some(Location::Line(6)));
        let (k, l) = kind_line("OFF\n3 1 0\n0 0 0\n1 zz 0\n0 1 0\n3 0 1 2\n");
        assert!(matches!(k, ErrorKind::Syntax(ref m) if m.contains("'zz'")));
        assert_eq!(l, Some(Location::Line(4)));
        let (k, l) = kind_line("OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n");
        assert!(matches!(k, ErrorKind::Syntax(_)));
        assert_eq!(l, Some(Location::Line(4)));
        let (k, l) = kind_line("OFF\n2 1 0\n0 0 0\n1 0 0\n0.5 1 0\n3 0 1 2\n");
        assert!(matches!(k, ErrorKind::Syntax(ref m) if m.contains("too few vertices")));
        assert_eq!(l, Some(Location::Line(5)));
        let (k, l) = kind_line("OFF\n2 1 0\n0 0 0\n1 0 0\n0 1 0.5\n3 0 1 2\n");
        assert!(matches!(k, ErrorKind::Syntax(ref m) if m.contains("too few vertices")));
        assert_eq!(l, Some(Location::Line(5)));
        let (k, l) = kind_line("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n");
        assert!(matches!(k, ErrorKind::Syntax(ref m) if m.contains("only 3")));
        assert_eq!(l, Some(Location::Line(6)));
        let (k, l) = kind_line("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
        assert!(matches!(k, ErrorKind::Syntax(_)));
        assert_eq!(l, Some(Location::Line(6)));
        let (k, l) = kind_line("MESH\n3 1 0\n");
        assert!(matches!(k, ErrorKind::Syntax(_)));
        assert_eq!(l, Some(Location::Line(1)));
        let (k, _) = kind_line("4OFF\n3 1 0\n");
        assert!(matches!(k, ErrorKind::Other(_)));
        let (k, _) = kind_line("OFF BINARY\n");
        assert!(matches!(k, ErrorKind::Other(_)));
        let (k, l) = kind_line("OFF\n");
        assert!(matches!(k, ErrorKind::Truncated { .. }));
        assert_eq!(l, Some(Location::Line(2)));
        let (k, l) = kind_line("OFF\n3\n");
        assert!(matches!(k, ErrorKind::Syntax(_)));
        assert_eq!(l, Some(Location::Line(2)));
        let (k, _) = kind_line("OFF\n-3 1 0\n");
        assert!(matches!(k, ErrorKind::Syntax(_)));
    }

    #[test]
    fn absurd_counts_do_not_allocate() {
        let (k, l) = kind_line("OFF\n1000000000000 1000000000000 0\n0 0 0\n");
        assert!(matches!(k, ErrorKind::Syntax(_)), "{k:?}"); // more than u32 vertices
        assert_eq!(l, Some(Location::Line(2)));
        let (k, _) = kind_line("OFF\n4000000000 1000000000000000 0\n0 0 0\n");
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        let (k, _) = kind_line("OFF\n3 1000000000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
    }

    #[test]
    fn no_faces_and_degenerate_faces() {
        let e =
            read_mesh_from_bytes(b"OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", Format::Off).unwrap_err();
        assert!(matches!(e.kind, ErrorKind::PointCloud { points: 3 }));
        let m = read_mesh_from_bytes(
            b"OFF\n4 3 0\n0 0 0\n1 0 0\n0 1 0\n2 0 0\n3 0 1 2\n3 0 0 1\n3 0 1 3\n",
            Format::Off,
        )
        .unwrap();
        assert_eq!(m.mesh.faces, vec![[0, 1, 2]]);
        assert_eq!(m.repairs.repeated_index_faces, 1);
        assert_eq!(m.repairs.zero_area_faces, 1);
    }
}
