//! Reads Stanford PLY files (ascii, binary little endian, binary big endian) with `ply-rs-bw`.
//!
//! Conventions:
//! - Vertices: the `vertex` element's `x`, `y`, `z` properties, of any scalar type; other
//!   properties (normals, colours, confidence, …) are ignored.
//! - Faces: the `face` element's `vertex_indices` (or `vertex_index`) list, of any integer type,
//!   0-based; polygons are fan-triangulated `(i1, ik, ik+1)`.
//! - Triangle strips: the `tristrips` element's `vertex_indices` list; `-1` separates strips; in
//!   each strip triangle k is `(s[k], s[k+1], s[k+2])` with the first two swapped for odd k, so the
//!   winding stays consistent. Strip triangles with a repeated index are the strip format's way
//!   of stitching and turning, not faces, so they are skipped without being counted as repairs.
//! - Other elements (edges, materials, …) are read past and ignored.
//!
//! Before any data is read the header is checked: the required properties must exist with usable
//! types, and the declared counts must fit in the file (each element has a minimum size), so an
//! absurd count is a "truncated" error rather than a huge allocation. Errors name the 1-based line
//! for ascii files and the element (`face element 12`) for binary ones; header problems found
//! after parsing (a missing `x`, float indices) name the element and property instead.
//! Non-finite coordinates are an error; in ascii files `ply-rs-bw`'s grammar already rejects
//! `nan`/`inf` as syntax, while overflowing values such as `1e999` are reported as non-finite.
//!
//! `ply-rs-bw` is used for the header and the payload: it caps its preallocation, rejects
//! negative list lengths, reports line and element positions, and reads the binary encodings
//! quickly through typed setters. Its messages are wrapped with the element and a plain reason.

use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{
    BeginList, ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult, PropertyType,
    ScalarType,
};

use super::RawMesh;
use crate::{ErrorKind, Location, MeshError, Point3, VertexId};

/// Parses the bytes of a PLY file into raw vertices and triangles.
pub(crate) fn read_ply(bytes: &[u8]) -> Result<RawMesh, MeshError> {
    if bytes.is_empty() {
        return Err(MeshError::new(ErrorKind::Empty));
    }
    if !(bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r")) {
        return Err(syntax_at(
            Location::Line(1),
            "not a PLY file: the first line must be 'ply'".into(),
        ));
    }
    let mut reader = Reader::new(bytes);
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(header_error)?;
    let plan = Plan::check(&header)?;
    check_sizes(&header, reader.get_ref().len())?;

    let ascii = header.encoding == Encoding::Ascii;
    let mut positions = Vec::new();
    let mut vertex_start = 0;
    // (element name, first line, lists)
    let mut face_lists: Vec<(&str, u64, Vec<IndexList>)> = Vec::new();
    for (name, def) in &header.elements {
        let start = reader.line() as u64;
        let at = |e: ParseError| element_error(e, def, start, ascii);
        if name == "vertex" {
            let vs = Parser::<VertexRec>::new()
                .read_payload_for_element(&mut reader, def, &header)
                .map_err(at)?;
            vertex_start = start;
            positions = vs.into_iter().map(|v| Point3::from(v.xyz)).collect();
        } else if Some(name.as_str()) == plan.face || Some(name.as_str()) == plan.strips {
            let lists = Parser::<IndexList>::new()
                .read_payload_for_element(&mut reader, def, &header)
                .map_err(at)?;
            face_lists.push((name, start, lists));
        } else if ascii || min_size(def) > 0 {
            Parser::<Skip>::new()
                .read_payload_for_element(&mut reader, def, &header)
                .map_err(at)?;
        }
    }

    let loc = |name: &str, start: u64, index: usize| {
        if ascii {
            Location::Line(start + index as u64)
        } else {
            Location::Element {
                name: name.to_string(),
                index: index as u64,
            }
        }
    };
    if let Some(i) = positions
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
    {
        return Err(MeshError::new(ErrorKind::NonFiniteCoordinate).at(loc(
            "vertex",
            vertex_start,
            i,
        )));
    }
    let nv = positions.len() as u64;
    let mut faces = Vec::new();
    for (name, start, lists) in face_lists {
        let strips = Some(name) == plan.strips;
        for (j, list) in lists.iter().enumerate() {
            let at = || loc(name, start, j);
            let result = if strips {
                strip_triangles(list, nv, &mut faces)
            } else {
                fan_triangles(list, nv, &mut faces)
            };
            result.map_err(|e| e.at(at()))?;
        }
    }
    Ok(RawMesh { positions, faces })
}

/// Which elements hold the faces, checked against the header.
struct Plan<'h> {
    face: Option<&'h str>,
    strips: Option<&'h str>,
}

impl<'h> Plan<'h> {
    fn check(header: &'h Header) -> Result<Plan<'h>, MeshError> {
        let bad = |m: String| MeshError::new(ErrorKind::Syntax(m));
        if let Some(v) = header.elements.get("vertex") {
            for c in ["x", "y", "z"] {
                match v.properties.get(c).map(|p| &p.data_type) {
                    Some(PropertyType::Scalar(_)) => {}
                    Some(PropertyType::List(..)) => {
                        return Err(bad(format!(
                            "the header's 'vertex' element declares '{c}' as a list; it must \
                             be a number"
                        )));
                    }
                    None => {
                        return Err(bad(format!(
                            "the header's 'vertex' element has no '{c}' property"
                        )));
                    }
                }
            }
        }
        let mut plan = Plan {
            face: None,
            strips: None,
        };
        for (name, slot) in [("face", &mut plan.face), ("tristrips", &mut plan.strips)] {
            let Some(def) = header.elements.get(name) else {
                continue;
            };
            let list = def
                .properties
                .get("vertex_indices")
                .or_else(|| def.properties.get("vertex_index"));
            match list.map(|p| &p.data_type) {
                Some(PropertyType::List(_, t)) if is_integer(t) => *slot = Some(name),
                Some(t) => {
                    return Err(bad(format!(
                        "the header's '{name}' element declares its vertex indices as {t:?}; \
                         they must be a list of integers"
                    )));
                }
                None if def.count == 0 => {}
                None => {
                    return Err(bad(format!(
                        "the header's '{name}' element has no 'vertex_indices' list"
                    )));
                }
            }
        }
        Ok(plan)
    }
}

fn is_integer(t: &ScalarType) -> bool {
    !matches!(t, ScalarType::Float | ScalarType::Double)
}

fn scalar_size(t: &ScalarType) -> u64 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// The fewest bytes one binary element can take (lists empty).
fn min_size(def: &ElementDef) -> u64 {
    def.properties
        .values()
        .map(|p| match &p.data_type {
            PropertyType::Scalar(t) | PropertyType::List(t, _) => scalar_size(t),
        })
        .sum()
}

/// Rejects headers whose declared counts cannot fit in the remaining bytes: a binary element takes
/// at least [`min_size`] bytes, an ascii one at least two (a number and a line break).
fn check_sizes(header: &Header, available: usize) -> Result<(), MeshError> {
    let available = available as u64;
    let mut used: u64 = 0;
    for (name, def) in &header.elements {
        let each = match header.encoding {
            Encoding::Ascii => 2,
            _ => min_size(def),
        };
        let count = def.count as u64;
        let need = count.saturating_mul(each);
        // The last ascii line may lack its line break.
        let slack = u64::from(header.encoding == Encoding::Ascii);
        if used.saturating_add(need) > available + slack {
            let fits = (available + slack).saturating_sub(used) / each.max(1);
            return Err(MeshError::new(ErrorKind::Truncated {
                expected: format!(
                    "'{name}' element {fits}: the header declares {count}, the file has room \
                     for at most {fits}"
                ),
            })
            .at(Location::Element {
                name: name.clone(),
                index: fits,
            }));
        }
        used += need;
    }
    Ok(())
}

fn syntax_at(location: Location, message: String) -> MeshError {
    MeshError::new(ErrorKind::Syntax(message)).at(location)
}

/// Makes a `ply-rs-bw` message fit on one line, without its "Line N:" prefix.
fn clean(text: &str) -> String {
    let text = text
        .strip_prefix("Line ")
        .map_or(text, |rest| rest.split_once(": ").map_or(rest, |(_, m)| m));
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// A one-line reason for a header error. `ply-rs-bw` reports a line its grammar does not
/// accept with the parser's internal state (`ParseError { location: LineCol … }`); that becomes
/// the line and the column where it stopped making sense.
fn header_reason(text: &str) -> String {
    let Some((_, rest)) = text.split_once("String: '") else {
        return clean(text);
    };
    let line = rest.split_once('\'').map_or(rest, |(l, _)| l);
    let column = rest
        .split_once("column: ")
        .and_then(|(_, r)| r.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|d| d.parse::<usize>().ok());
    let line = show(line.trim());
    match column {
        Some(c) => format!("cannot read the line '{line}' (at character {c})"),
        None => format!("cannot read the line '{line}'"),
    }
}

fn header_error(e: ParseError) -> MeshError {
    let kind = if e.kind() == std::io::ErrorKind::UnexpectedEof {
        ErrorKind::Truncated {
            expected: "the header (no 'end_header' line)".into(),
        }
    } else {
        ErrorKind::Syntax(format!("bad PLY header: {}", header_reason(&e.to_string())))
    };
    let err = MeshError::new(kind);
    match e.line() {
        Some(l) => err.at(Location::Line(l as u64)),
        None => err,
    }
}

/// Turns a payload error into one naming the element: the line (ascii) or the element index
/// (binary; `ply-rs-bw` counts one "line" per element there).
fn element_error(e: ParseError, def: &ElementDef, start: u64, ascii: bool) -> MeshError {
    let name = &def.name;
    let line = e.line().map(|l| l as u64);
    let location = match (line, ascii) {
        (Some(l), true) => Some(Location::Line(l)),
        (Some(l), false) => Some(Location::Element {
            name: name.to_string(),
            index: l.saturating_sub(start),
        }),
        (None, _) => None,
    };
    let kind = if e.kind() == std::io::ErrorKind::UnexpectedEof {
        ErrorKind::Truncated {
            expected: format!("the '{name}' element"),
        }
    } else {
        ErrorKind::Syntax(payload_message(&e, def))
    };
    let err = MeshError::new(kind);
    match location {
        Some(l) => err.at(l),
        None => err,
    }
}

/// A one-line reason for a payload error, from `ply-rs-bw`'s nested multi-line message.
fn payload_message(e: &ParseError, def: &ElementDef) -> String {
    let text = e.to_string();
    let quoted = |key: &str| {
        text.split_once(key)
            .and_then(|(_, r)| r.split_once('\''))
            .map(|(v, _)| v.split_whitespace().collect::<Vec<_>>().join(" "))
    };
    let reason = if let Some(v) = quoted("Value: '") {
        format!("'{}' is not a number of the declared type", show(&v))
    } else if text.contains("error at ") {
        "a value is not a number".to_string()
    } else {
        clean(text.rsplit("Error: ").next().unwrap_or(&text))
    };
    let props: Vec<&str> = def.properties.keys().map(String::as_str).collect();
    match quoted("String: '") {
        Some(l) => format!(
            "the '{}' line '{}' does not match the header's properties ({}): {reason}",
            def.name,
            show(&l),
            props.join(" ")
        ),
        None => format!("in the '{}' element: {reason}", def.name),
    }
}

/// Shortens text quoted in an error message.
fn show(s: &str) -> String {
    super::text::show(s.as_bytes())
}

/// Checks one index read from the file.
fn vertex_id(v: i64, nv: u64) -> Result<VertexId, MeshError> {
    if v < 0 {
        return Err(MeshError::new(ErrorKind::Syntax(format!(
            "vertex index {v} is negative (PLY indices start at 0)"
        ))));
    }
    let v = v as u64;
    if v >= nv {
        return Err(MeshError::new(ErrorKind::IndexOutOfRange {
            index: v,
            vertices: nv,
        }));
    }
    Ok(v as VertexId)
}

/// Fan-triangulates one polygon.
fn fan_triangles(
    list: &IndexList,
    nv: u64,
    faces: &mut Vec<[VertexId; 3]>,
) -> Result<(), MeshError> {
    let n = list.len();
    if n < 3 {
        return Err(MeshError::new(ErrorKind::Syntax(format!(
            "a face needs at least 3 vertices, this one has {n}"
        ))));
    }
    let (mut first, mut prev) = (0, 0);
    for (k, v) in list.iter().enumerate() {
        let v = vertex_id(v, nv)?;
        match k {
            0 => first = v,
            1 => {}
            _ => faces.push([first, prev, v]),
        }
        prev = v;
    }
    Ok(())
}

/// Decodes one `tristrips` list: strips separated by `-1`, alternate winding.
fn strip_triangles(
    list: &IndexList,
    nv: u64,
    faces: &mut Vec<[VertexId; 3]>,
) -> Result<(), MeshError> {
    let mut window: [VertexId; 2] = [0, 0];
    let mut k = 0usize; // position in the current strip
    for v in list.iter() {
        if v == -1 {
            k = 0;
            continue;
        }
        let v = vertex_id(v, nv)?;
        if k >= 2 {
            let [a, b] = window;
            let t = if k.is_multiple_of(2) {
                [a, b, v]
            } else {
                [b, a, v]
            };
            if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                faces.push(t);
            }
        }
        window = [window[1], v];
        k += 1;
    }
    Ok(())
}

/// Vertex positions as they are read.
struct VertexRec {
    xyz: [f64; 3],
}

impl VertexRec {
    fn set(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        let i = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return PropertyAccessResult::Ignored,
        };
        self.xyz[i] = v;
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for VertexRec {
    fn new() -> Self {
        VertexRec { xyz: [0.0; 3] }
    }
    fn set_char(&mut self, name: &str, v: i8) -> PropertyAccessResult {
        self.set(name, v.into())
    }
    fn set_uchar(&mut self, name: &str, v: u8) -> PropertyAccessResult {
        self.set(name, v.into())
    }
    fn set_short(&mut self, name: &str, v: i16) -> PropertyAccessResult {
        self.set(name, v.into())
    }
    fn set_ushort(&mut self, name: &str, v: u16) -> PropertyAccessResult {
        self.set(name, v.into())
    }
    fn set_int(&mut self, name: &str, v: i32) -> PropertyAccessResult {
        self.set(name, v.into())
    }
    fn set_uint(&mut self, name: &str, v: u32) -> PropertyAccessResult {
        self.set(name, v.into())
    }
    fn set_float(&mut self, name: &str, v: f32) -> PropertyAccessResult {
        self.set(name, v.into())
    }
    fn set_double(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        self.set(name, v)
    }
}

/// A face's or strip's index list, in whichever integer type the file uses (only one of the
/// vectors is filled).
#[derive(Default)]
struct IndexList {
    i8s: Vec<i8>,
    u8s: Vec<u8>,
    i16s: Vec<i16>,
    u16s: Vec<u16>,
    i32s: Vec<i32>,
    u32s: Vec<u32>,
}

impl IndexList {
    fn len(&self) -> usize {
        self.i8s.len()
            + self.u8s.len()
            + self.i16s.len()
            + self.u16s.len()
            + self.i32s.len()
            + self.u32s.len()
    }

    fn iter(&self) -> impl Iterator<Item = i64> + '_ {
        (self.i8s.iter().map(|&v| i64::from(v)))
            .chain(self.u8s.iter().map(|&v| i64::from(v)))
            .chain(self.i16s.iter().map(|&v| i64::from(v)))
            .chain(self.u16s.iter().map(|&v| i64::from(v)))
            .chain(self.i32s.iter().map(|&v| i64::from(v)))
            .chain(self.u32s.iter().map(|&v| i64::from(v)))
    }
}

fn is_index_list(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

impl PropertyAccess for IndexList {
    fn new() -> Self {
        IndexList::default()
    }
    fn begin_list_char(&mut self, name: &str, _len: usize) -> BeginList<'_, i8> {
        fill_or_skip(name, &mut self.i8s)
    }
    fn begin_list_uchar(&mut self, name: &str, _len: usize) -> BeginList<'_, u8> {
        fill_or_skip(name, &mut self.u8s)
    }
    fn begin_list_short(&mut self, name: &str, _len: usize) -> BeginList<'_, i16> {
        fill_or_skip(name, &mut self.i16s)
    }
    fn begin_list_ushort(&mut self, name: &str, _len: usize) -> BeginList<'_, u16> {
        fill_or_skip(name, &mut self.u16s)
    }
    fn begin_list_int(&mut self, name: &str, _len: usize) -> BeginList<'_, i32> {
        fill_or_skip(name, &mut self.i32s)
    }
    fn begin_list_uint(&mut self, name: &str, _len: usize) -> BeginList<'_, u32> {
        fill_or_skip(name, &mut self.u32s)
    }
}

fn fill_or_skip<'a, T>(name: &str, v: &'a mut Vec<T>) -> BeginList<'a, T> {
    if is_index_list(name) {
        BeginList::Fill(v)
    } else {
        BeginList::UseSetter // read into a temporary and ignored
    }
}

/// An element whose data is ignored.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "ply\nformat ascii 1.0\ncomment c\nelement vertex 4\nproperty float x\n\
                        property float y\nproperty float z\nproperty uchar red\n";

    fn err(bytes: &[u8]) -> (ErrorKind, Option<Location>) {
        let e = read_ply(bytes).unwrap_err();
        (e.kind, e.location)
    }

    fn ascii(face_header: &str, body: &str) -> Vec<u8> {
        format!("{HEAD}{face_header}end_header\n0 0 0 1\n1 0 0 2\n0 1 0 3\n0 0 1 4\n{body}")
            .into_bytes()
    }

    #[test]
    fn ascii_faces_in_any_integer_type_and_name() {
        for t in [
            "uchar", "char", "short", "ushort", "int", "uint", "int32", "uint8",
        ] {
            for name in ["vertex_indices", "vertex_index"] {
                let f = format!(
                    "element face 2\nproperty list uchar {t} {name}\nproperty uchar flags\n"
                );
                let m = read_ply(&ascii(&f, "3 0 1 2 7\n4 0 1 2 3 9\n")).unwrap();
                assert_eq!(m.positions.len(), 4);
                assert_eq!(m.positions[3], Point3::new(0.0, 0.0, 1.0));
                assert_eq!(m.faces, vec![[0, 1, 2], [0, 1, 2], [0, 2, 3]], "{t} {name}");
            }
        }
    }

    #[test]
    fn tristrips_alternate_winding_and_restart() {
        let f = "element tristrips 1\nproperty list int int vertex_indices\n";
        let m = read_ply(&ascii(f, "9 0 1 2 3 -1 3 2 1 1 0\n")).unwrap();
        // 0 1 2 3: (0,1,2), (2,1,3); restart 3 2 1 1 0: (3,2,1), skip (1,2,1), skip (1,1,0)
        assert_eq!(m.faces, vec![[0, 1, 2], [2, 1, 3], [3, 2, 1]]);
    }

    #[test]
    fn ascii_errors_name_the_line() {
        let f = "element face 2\nproperty list uchar int vertex_indices\n";
        // Lines: 1-8 header head, 9-10 face header, 11 end_header, 12-15 vertices, 16-17 faces.
        let (k, l) = err(&ascii(f, "3 0 1 2\n3 0 1 4\n"));
        assert!(matches!(
            k,
            ErrorKind::IndexOutOfRange {
                index: 4,
                vertices: 4
            }
        ));
        assert_eq!(l, Some(Location::Line(17)));
        let (k, l) = err(&ascii(f, "3 0 1 2\n3 0 -1 2\n"));
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("negative")),
            "{k:?}"
        );
        assert_eq!(l, Some(Location::Line(17)));
        let (k, l) = err(&ascii(f, "3 0 1 2\n3 0 x 2\n"));
        assert!(matches!(k, ErrorKind::Syntax(_)), "{k:?}");
        assert_eq!(l, Some(Location::Line(17)));
        let (k, _) = err(&ascii(f, "3 0 1 2\n"));
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        let (k, l) = err(&ascii(f, "3 0 1 2\n2 0 1\n"));
        assert!(matches!(k, ErrorKind::Syntax(_)), "{k:?}");
        assert_eq!(l, Some(Location::Line(17)));
        // ply-rs-bw's ascii grammar has no nan/inf: a syntax error.
        let bad = format!(
            "{HEAD}{f}end_header\n0 0 0 1\n1 0 0 2\n0 1 nan 3\n0 0 1 4\n3 0 1 2\n3 0 1 3\n"
        );
        let (k, l) = err(bad.as_bytes());
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("'0 1 nan 3'")),
            "{k:?}"
        );
        assert_eq!(l, Some(Location::Line(14)));
        let bad = format!(
            "{HEAD}{f}end_header\n0 0 0 1\n1 0 0 2\n0 1 1e999 3\n0 0 1 4\n3 0 1 2\n3 0 1 3\n"
        );
        let (k, l) = err(bad.as_bytes());
        assert!(matches!(k, ErrorKind::NonFiniteCoordinate), "{k:?}");
        assert_eq!(l, Some(Location::Line(14)));
    }

    #[test]
    fn header_errors() {
        assert!(matches!(err(b"").0, ErrorKind::Empty));
        let (k, l) = err(b"plx\nformat ascii 1.0\n");
        assert!(matches!(k, ErrorKind::Syntax(_)));
        assert_eq!(l, Some(Location::Line(1)));
        let (k, _) = err(b"ply\nformat ascii 1.0\nelement vertex 3\n");
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        let (k, l) = err(b"ply\nformat ascii 1.0\nelement vertex 3\nproperty flot x\nend_header\n");
        assert!(matches!(k, ErrorKind::Syntax(_)), "{k:?}");
        assert_eq!(l, Some(Location::Line(4)));
        // The parser's internal state is not shown; the line and where it breaks are.
        let (k, l) = err(b"ply\nformat ascii 1.0\nelement vertex x\nend_header\n");
        let ErrorKind::Syntax(m) = k else {
            panic!("{k:?}")
        };
        assert_eq!(
            m,
            "bad PLY header: cannot read the line 'element vertex x' (at character 16)"
        );
        assert!(!m.contains("ParseError"), "{m}");
        assert_eq!(l, Some(Location::Line(3)));
        let (k, _) = err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n");
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("'z'")),
            "{k:?}"
        );
        let f = "element face 2\nproperty list uchar float vertex_indices\n";
        assert!(matches!(err(&ascii(f, "")).0, ErrorKind::Syntax(_)));
        let f = "element face 2\nproperty uchar flags\n";
        assert!(matches!(err(&ascii(f, "")).0, ErrorKind::Syntax(_)));
    }

    #[test]
    fn absurd_counts_are_truncation() {
        let text = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n\
                     property float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0";
        let (k, l) = err(text);
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        assert_eq!(
            l,
            Some(Location::Element {
                name: "vertex".into(),
                index: 0
            })
        );
        let text = b"ply\nformat ascii 1.0\nelement vertex 1000000000000\n\
                     property float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n";
        assert!(matches!(err(text).0, ErrorKind::Truncated { .. }));
        let text =
            b"ply\nformat binary_little_endian 1.0\nelement junk 1000000000000\nend_header\n";
        // An element without properties takes no bytes: skipped, then there is no vertex.
        let e = super::super::read_mesh_from_bytes(text, super::super::Format::Ply).unwrap_err();
        assert!(matches!(e.kind, ErrorKind::NoVertices), "{e}");
    }
}
