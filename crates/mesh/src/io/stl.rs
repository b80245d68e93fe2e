//! Reads STL files, ascii and binary.
//!
//! STL stores every triangle with its own three corners, so there are no shared vertices: corners
//! are merged by exact position (bit-for-bit after turning `-0.0` into `0.0`), and vertex ids are
//! given in order of first appearance. Normals and the binary attribute bytes are ignored.
//!
//! Which encoding: a file whose size is exactly `84 + 50·n` bytes, `n` being the count at byte
//! 80, is binary even when its header starts with `solid` (many exporters write that); otherwise a
//! file starting with `solid` followed by plain ascii text is ascii, and anything else binary. Ascii coordinates are parsed as
//! `f64` (what the text says); binary ones are `f32` widened exactly.
//!
//! Ascii syntax: `solid [name]`, then facets `facet normal nx ny nz` / `outer loop` / three (or
//! more, fan-triangulated) `vertex x y z` / `endloop` / `endfacet`, then `endsolid [name]`; several
//! solids may follow each other. Errors name the 1-based line (ascii) or the facet (binary).
//!
//! The `stl_io` crate is not used for reading: it decides ascii versus binary from the first
//! line alone (so binary files whose header starts with `solid ` fail, and ascii files whose first
//! line is just `solid` are read as binary), its errors carry no line or facet, and it keeps
//! `-0.0` and `0.0` apart. It serves as an independent writer and oracle in the tests.

use std::collections::HashMap;

use super::RawMesh;
use super::text::{Lines, parse_xyz, show, syntax, tokens};
use crate::{ErrorKind, Location, MeshError, Point3, VertexId};

/// Parses the bytes of an STL file into merged vertices and triangles.
pub(crate) fn read_stl(bytes: &[u8]) -> Result<RawMesh, MeshError> {
    if bytes.is_empty() {
        return Err(MeshError::new(ErrorKind::Empty));
    }
    let declared = bytes
        .get(80..84)
        .and_then(|b| <[u8; 4]>::try_from(b).ok())
        .map(|b| u64::from(u32::from_le_bytes(b)));
    let exact_binary = declared.is_some_and(|n| 84 + 50 * n == bytes.len() as u64);
    let looks_ascii = looks_ascii(bytes);
    let mut merger = Merger::default();
    if !exact_binary && looks_ascii {
        read_ascii(bytes, &mut merger)?;
    } else {
        read_binary(bytes, declared, &mut merger)?;
    }
    if merger.faces.is_empty() {
        return Err(MeshError::new(ErrorKind::NoFaces { dropped: 0 }));
    }
    Ok(RawMesh {
        positions: merger.positions,
        faces: merger.faces,
    })
}

/// Starts with `solid`, the first line (a name, in any encoding) has no control bytes, and the
/// next kilobyte is plain ascii text: binary headers and facets almost always hold zero bytes.
fn looks_ascii(bytes: &[u8]) -> bool {
    let text = bytes.trim_ascii_start();
    if !text.starts_with(b"solid") {
        return false;
    }
    let (first, rest) = match text.iter().position(|&b| b == b'\n') {
        Some(i) => (&text[..i], &text[i + 1..]),
        None => (text, &text[text.len()..]),
    };
    first
        .iter()
        .all(|&b| b >= 0x20 && b != 0x7F || b == b'\t' || b == b'\r')
        && rest
            .iter()
            .take(1024)
            .all(|&b| b.is_ascii_graphic() || b.is_ascii_whitespace())
}

/// Merges corners by exact position, in order of first appearance.
#[derive(Default)]
struct Merger {
    ids: HashMap<[u64; 3], VertexId>,
    positions: Vec<Point3<f64>>,
    faces: Vec<[VertexId; 3]>,
}

impl Merger {
    fn id(&mut self, p: [f64; 3]) -> Result<VertexId, MeshError> {
        // `+ 0.0` turns -0.0 into 0.0, so both are the same position.
        let key = p.map(|c| (c + 0.0).to_bits());
        if let Some(&id) = self.ids.get(&key) {
            return Ok(id);
        }
        let id = VertexId::try_from(self.positions.len())
            .map_err(|_| MeshError::new(ErrorKind::Other("more than 2^32 vertices".into())))?;
        self.ids.insert(key, id);
        self.positions.push(Point3::new(p[0], p[1], p[2]));
        Ok(id)
    }

    /// Adds a polygon (fan-triangulated) given by its corner positions.
    fn polygon(&mut self, corners: &[[f64; 3]]) -> Result<(), MeshError> {
        let mut ids = Vec::with_capacity(corners.len());
        for &c in corners {
            ids.push(self.id(c)?);
        }
        for k in 2..ids.len() {
            self.faces.push([ids[0], ids[k - 1], ids[k]]);
        }
        Ok(())
    }
}

fn read_binary(bytes: &[u8], declared: Option<u64>, merger: &mut Merger) -> Result<(), MeshError> {
    let Some(n) = declared else {
        return Err(MeshError::new(ErrorKind::Truncated {
            expected: "the 84-byte binary STL header (an ascii STL must start with 'solid')".into(),
        })
        .at(Location::Byte(bytes.len() as u64)));
    };
    let have = (bytes.len() as u64 - 84) / 50;
    if have < n {
        return Err(MeshError::new(ErrorKind::Truncated {
            expected: format!("facet {have} of the {n} declared"),
        })
        .at(Location::Byte(84 + 50 * have)));
    }
    // Extra bytes after the declared facets are ignored (some writers pad).
    let facets = bytes[84..].chunks_exact(50).take(n as usize);
    merger.faces.reserve(n as usize);
    for (i, rec) in facets.enumerate() {
        let f = |k: usize| {
            let o = 12 + 4 * k;
            f64::from(f32::from_le_bytes([
                rec[o],
                rec[o + 1],
                rec[o + 2],
                rec[o + 3],
            ]))
        };
        let corners = [0, 1, 2].map(|c| [f(3 * c), f(3 * c + 1), f(3 * c + 2)]);
        if corners.iter().flatten().any(|c| !c.is_finite()) {
            return Err(
                MeshError::new(ErrorKind::NonFiniteCoordinate).at(Location::Element {
                    name: "facet".into(),
                    index: i as u64,
                }),
            );
        }
        merger.polygon(&corners)?;
    }
    Ok(())
}

/// Where the ascii reader is in the grammar.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum State {
    /// Before `solid` (start, or after `endsolid`).
    Outside,
    /// Inside a solid, expecting `facet` or `endsolid`.
    Solid,
    /// After `facet`, expecting `outer loop`.
    Facet,
    /// Inside the loop, expecting `vertex` or `endloop`.
    Loop,
    /// After `endloop`, expecting `endfacet`.
    EndLoop,
}

fn read_ascii(bytes: &[u8], merger: &mut Merger) -> Result<(), MeshError> {
    let mut state = State::Outside;
    let mut corners: Vec<[f64; 3]> = Vec::with_capacity(3);
    let mut lines = Lines::new(bytes, None);
    for (ln, line) in lines.by_ref() {
        let mut toks = tokens(line);
        let Some(word) = toks.next() else { continue };
        let word = word.to_ascii_lowercase();
        let expect = |what: &str| {
            Err(syntax(
                ln,
                format!("expected {what}, found '{}'", show(line.trim_ascii())),
            ))
        };
        state = match (state, word.as_slice()) {
            (State::Outside, b"solid") => State::Solid,
            (State::Outside, _) => return expect("'solid'"),
            (State::Solid, b"facet") => State::Facet,
            (State::Solid, b"endsolid") => State::Outside,
            (State::Solid, _) => return expect("'facet' or 'endsolid'"),
            (State::Facet, b"outer") => State::Loop,
            (State::Facet, _) => return expect("'outer loop'"),
            (State::Loop, b"vertex") => {
                corners.push(parse_xyz(toks, ln, "a 'vertex' line")?);
                State::Loop
            }
            (State::Loop, b"endloop") => {
                if corners.len() < 3 {
                    return Err(syntax(
                        ln,
                        format!("a facet needs 3 vertices, this one has {}", corners.len()),
                    ));
                }
                merger.polygon(&corners)?;
                corners.clear();
                State::EndLoop
            }
            (State::Loop, _) => return expect("'vertex' or 'endloop'"),
            (State::EndLoop, b"endfacet") => State::Solid,
            (State::EndLoop, _) => return expect("'endfacet'"),
        };
    }
    if state != State::Outside {
        let expected = match state {
            State::Solid => "'endsolid'",
            State::Facet => "'outer loop'",
            State::Loop => "'vertex' or 'endloop'",
            _ => "'endfacet'",
        };
        return Err(MeshError::new(ErrorKind::Truncated {
            expected: expected.into(),
        })
        .at(Location::Line(lines.line() + 1)));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const TETRA: &str = "solid t\nfacet normal 0 0 -1\n outer loop\n  vertex 0 0 0\n  vertex 0 1 0\n  \
                         vertex 1 0 0\n endloop\nendfacet\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\n\
                         vertex 1 0 0\nvertex 0 0 1\nendloop\nendfacet\nendsolid t\n";

    fn err(bytes: &[u8]) -> (ErrorKind, Option<Location>) {
        let e = read_stl(bytes).unwrap_err();
        (e.kind, e.location)
    }

    #[test]
    fn ascii_merges_by_position_in_first_appearance_order() {
        let m = read_stl(TETRA.as_bytes()).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.positions[1], Point3::new(0.0, 1.0, 0.0));
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
        // Bare `solid`, -0.0, two solids.
        let t = "solid\nfacet normal 0 0 1\nouter loop\nvertex -0 0 0\nvertex 1 0 0\nvertex 0 1 0\n\
                 endloop\nendfacet\nendsolid\nsolid b\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n\
                 vertex 0 1 0\nvertex 0 0 1\nendloop\nendfacet\nendsolid b";
        let m = read_stl(t.as_bytes()).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn binary_with_solid_header() {
        let mut b = b"solid but binary".to_vec();
        b.resize(80, b' ');
        b.extend_from_slice(&1u32.to_le_bytes());
        for v in [
            0.0f32, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0,
        ] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&[0, 0]);
        let m = read_stl(&b).unwrap();
        assert_eq!(m.faces, vec![[0, 1, 2]]);
        assert_eq!(m.positions[2], Point3::new(0.0, 1.0, 0.0));
        // Cut short: truncated at the byte where facet 0 should be.
        b.truncate(100);
        b[0] = b'x';
        let (k, l) = err(&b);
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        assert_eq!(l, Some(Location::Byte(84)));
        let (k, l) = err(&b[..50]);
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        assert_eq!(l, Some(Location::Byte(50)));
    }

    #[test]
    fn ascii_errors_name_the_line() {
        assert!(matches!(err(b"").0, ErrorKind::Empty));
        let (k, l) = err(TETRA.replace("vertex 0 0 1", "vertex 0 0 nan").as_bytes());
        assert!(matches!(k, ErrorKind::NonFiniteCoordinate));
        assert_eq!(l, Some(Location::Line(13)));
        let (k, l) = err(TETRA
            .replace("endloop\nendfacet\nendsolid", "endloop\nendsolid")
            .as_bytes());
        assert!(matches!(k, ErrorKind::Syntax(_)));
        assert_eq!(l, Some(Location::Line(15)));
        let (k, l) = err(&TETRA.as_bytes()[..TETRA.find("endfacet").unwrap()]);
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        assert!(matches!(l, Some(Location::Line(_))));
        let (k, l) = err(TETRA.replace("vertex 0 1 0", "vertex 0 x 0").as_bytes());
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("'x'")),
            "{k:?}"
        );
        assert_eq!(l, Some(Location::Line(5)));
        let (k, _) = err(b"solid x\nendsolid x\n");
        assert!(matches!(k, ErrorKind::NoFaces { dropped: 0 }), "{k:?}");
    }
}
