//! Reads Stanford PLY files (ascii, binary little endian, binary big endian) with `ply-rs-bw`.
//!
//! Conventions:
//! - Vertices: the `vertex` element's `x`, `y`, `z` properties, of any scalar type; `nx`, `ny`,
//!   `nz` (all three) are a point cloud's normals; other properties (colours, confidence, …) are
//!   ignored.
//! - Faces: the `face` element's `vertex_indices` (or `vertex_index`) list, of any integer type,
//!   0-based; polygons are fan-triangulated `(i1, ik, ik+1)`.
//! - Triangle strips: the `tristrips` element's `vertex_indices` list; `-1` separates strips; in
//!   each strip triangle k is `(s[k], s[k+1], s[k+2])` with the first two swapped for odd k, so the
//!   winding stays consistent. Strip triangles with a repeated index are the strip format's way
//!   of stitching and turning, not faces, so they are skipped without being counted as repairs.
//! - Range grids (the Stanford 3D Scanning Repository's raw scans): a `range_grid` element with a
//!   `vertex_indices` (or `vertex_index`) integer list per cell, row-major, and the grid's size in
//!   the header's `obj_info num_rows R` and `obj_info num_cols C` lines (`R x C` must be the
//!   element's count; without them the grid cannot be read: an error). A cell with an empty list
//!   is absent, with one index it is that vertex; with more, the first is used and the cells are
//!   counted in one warning. The grid is triangulated by [`crate::grid::triangulate_grid`] (the
//!   triangles face the scanner). `obj_info is_interlaced 1` (Cyberware scanners, odd rows
//!   shifted by half a column) needs nothing special: the grid is then staggered, and splitting
//!   each block along its shorter diagonal gives well-shaped triangles (checked on the bunny's
//!   scans: median edge within 5 % of the sample spacing).
//! - A file whose face, `tristrips` and `range_grid` elements are all absent or empty is a point
//!   cloud: its vertices, with their normals when present. When a file has both faces and a
//!   grid, the faces are used and a warning says so.
//! - Other elements (edges, materials, …) are read past and ignored.
//! - Header lines whose first word is not a PLY keyword (`ply`, `format`, `comment`, `obj_info`,
//!   `element`, `property`, `end_header`), such as the `bye` some scanners write, are dropped with
//!   a warning naming the line (`line 5: unknown header line 'bye' ignored`); blank header lines
//!   are dropped silently. Line numbers in errors stay the file's own.
//!
//! Before any data is read the header is checked: the required properties must exist with usable
//! types, and the declared counts must fit in the file (each element has a minimum size), so an
//! absurd count is a "truncated" error rather than a huge allocation. Errors name the 1-based line
//! for ascii files and the element (`face element 12`, `range_grid element 4`) for binary ones;
//! header problems found after parsing (a missing `x`, float indices, a grid size that does not
//! match) name the element and property instead.
//! Non-finite coordinates are an error; in ascii files `ply-rs-bw`'s grammar already rejects
//! `nan`/`inf` as syntax, while overflowing values such as `1e999` are reported as non-finite.
//!
//! `ply-rs-bw` is used for the header and the payload: it caps its preallocation, rejects
//! negative list lengths, reports line and element positions, and reads the binary encodings
//! quickly through typed setters. Its messages are wrapped with the element and a plain reason.

use std::borrow::Cow;
use std::io::Read as _;

use ply_rs_bw::parser::{ParseError, Parser, Reader};
use ply_rs_bw::ply::{
    BeginList, ElementDef, Encoding, Header, PropertyAccess, PropertyAccessResult, PropertyType,
    ScalarType,
};

use super::text::show as show_bytes;
use super::{MAX_WARNINGS, Parsed, Raw, RawGrid, RawMesh, RawPoints};
use crate::{ErrorKind, Location, MeshError, Point3, Vector3, VertexId};

/// Parses the bytes of a PLY file into raw vertices and triangles, a range grid or points.
pub(crate) fn read_ply(bytes: &[u8]) -> Result<Parsed, MeshError> {
    if bytes.is_empty() {
        return Err(MeshError::new(ErrorKind::Empty));
    }
    if !(bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r")) {
        return Err(syntax_at(
            Location::Line(1),
            "not a PLY file: the first line must be 'ply'".into(),
        ));
    }
    let clean = CleanHeader::new(bytes);
    let lines = &clean.lines;
    let mut reader = Reader::new(clean.header.as_ref().chain(clean.payload));
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| header_error(e, lines))?;
    let plan = Plan::check(&header)?;
    check_sizes(&header, clean.payload.len())?;

    let ascii = header.encoding == Encoding::Ascii;
    let mut vertices = Vec::new();
    let mut vertex_start = 0;
    // (element name, first line, lists)
    let mut face_lists: Vec<(&str, u64, Vec<IndexList>)> = Vec::new();
    let mut grid_cells: Option<(u64, Vec<GridCell>)> = None;
    for (name, def) in &header.elements {
        let start = reader.line() as u64;
        let at = |e: ParseError| element_error(e, def, start, ascii, lines);
        if name == "vertex" {
            vertices = Parser::<VertexRec>::new()
                .read_payload_for_element(&mut reader, def, &header)
                .map_err(at)?;
            vertex_start = start;
        } else if Some(name.as_str()) == plan.face || Some(name.as_str()) == plan.strips {
            let lists = Parser::<IndexList>::new()
                .read_payload_for_element(&mut reader, def, &header)
                .map_err(at)?;
            face_lists.push((name, start, lists));
        } else if plan.grid.is_some_and(|g| g.name == *name) {
            let cells = Parser::<GridCell>::new()
                .read_payload_for_element(&mut reader, def, &header)
                .map_err(at)?;
            grid_cells = Some((start, cells));
        } else if ascii || min_size(def) > 0 {
            Parser::<Skip>::new()
                .read_payload_for_element(&mut reader, def, &header)
                .map_err(at)?;
        }
    }

    let loc = |name: &str, start: u64, index: usize| {
        if ascii {
            Location::Line(lines.file_line(start + index as u64))
        } else {
            Location::Element {
                name: name.to_string(),
                index: index as u64,
            }
        }
    };
    let positions: Vec<Point3<f64>> = vertices.iter().map(|v| Point3::from(v.xyz)).collect();
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
    let mut warnings = clean.warnings;
    let has_faces = face_lists.iter().any(|(_, _, lists)| !lists.is_empty());

    if has_faces {
        if let Some(g) = plan.grid.filter(|g| g.cells > 0) {
            warnings.push(format!(
                "the file has faces and a '{}' element: the faces are used, the grid ignored",
                g.name
            ));
        }
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
        return Ok(Parsed {
            raw: Raw::Mesh(RawMesh { positions, faces }),
            warnings,
        });
    }
    if let (Some(g), Some((start, cells))) = (plan.grid, grid_cells)
        && !cells.is_empty()
    {
        let mut ids = Vec::with_capacity(cells.len());
        let mut several = 0usize;
        for (i, cell) in cells.iter().enumerate() {
            if cell.len == 0 {
                ids.push(None);
                continue;
            }
            if cell.len > 1 {
                several += 1;
            }
            let v = vertex_id(cell.first, nv).map_err(|e| e.at(loc(g.name, start, i)))?;
            ids.push(Some(v));
        }
        if several > 0 {
            warnings.push(format!(
                "{several} '{}' cells list more than one vertex: the first of each is used",
                g.name
            ));
        }
        return Ok(Parsed {
            raw: Raw::Grid(RawGrid {
                positions,
                rows: g.rows,
                cols: g.cols,
                cells: ids,
                flip: false,
            }),
            warnings,
        });
    }
    if positions.is_empty() {
        // no vertices at all: the mesh validation says so
        return Ok(Parsed {
            raw: Raw::Mesh(RawMesh {
                positions,
                faces: Vec::new(),
            }),
            warnings,
        });
    }
    let normals = plan.normals.then(|| {
        vertices
            .iter()
            .map(|v| Vector3::from(v.normal))
            .collect::<Vec<_>>()
    });
    Ok(Parsed {
        raw: Raw::Points(RawPoints { positions, normals }),
        warnings,
    })
}

/// The PLY keywords a header line can start with; other lines are dropped before the header
/// goes to `ply-rs-bw` (see [`CleanHeader`]).
const KEYWORDS: [&[u8]; 7] = [
    b"ply",
    b"format",
    b"comment",
    b"obj_info",
    b"element",
    b"property",
    b"end_header",
];

/// The header as `ply-rs-bw` reads it: lines whose first word is not a PLY keyword (such as a
/// scanner's `bye`) removed with a warning, blank lines removed silently. Scans the lines up to
/// `end_header`; without one, the bytes are handed over unchanged (and `ply-rs-bw` reports the
/// missing `end_header`).
struct CleanHeader<'a> {
    /// The header lines kept, through `end_header`.
    header: Cow<'a, [u8]>,
    /// Everything after the `end_header` line.
    payload: &'a [u8],
    /// How `ply-rs-bw`'s line numbers map to the file's.
    lines: LineMap,
    warnings: Vec<String>,
}

/// Maps the line numbers `ply-rs-bw` reports (counted in the cleaned header) back to the file's.
#[derive(Default)]
struct LineMap {
    /// The file's line number of each header line kept (empty when none was dropped).
    kept: Vec<u64>,
    /// How many header lines were dropped.
    dropped: u64,
}

impl LineMap {
    /// The file's line number for a line number counted without the dropped lines.
    fn file_line(&self, line: u64) -> u64 {
        if self.dropped == 0 {
            return line;
        }
        match line.checked_sub(1).and_then(|i| self.kept.get(i as usize)) {
            Some(&l) => l,
            None => line + self.dropped,
        }
    }
}

impl<'a> CleanHeader<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        let unchanged = CleanHeader {
            header: Cow::Borrowed(bytes),
            payload: &[],
            lines: LineMap::default(),
            warnings: Vec::new(),
        };
        let mut kept: Vec<(u64, std::ops::Range<usize>)> = Vec::new();
        let mut unknown: Vec<(u64, &[u8])> = Vec::new();
        let (mut pos, mut number) = (0, 0u64);
        loop {
            if pos >= bytes.len() {
                return unchanged;
            }
            let end = bytes[pos..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(bytes.len(), |i| pos + i);
            let next = (end + 1).min(bytes.len());
            number += 1;
            let line = &bytes[pos..end];
            let first = line.split(u8::is_ascii_whitespace).find(|t| !t.is_empty());
            match first {
                _ if number == 1 => kept.push((number, pos..next)),
                Some(word) if KEYWORDS.contains(&word) => kept.push((number, pos..next)),
                Some(_) => unknown.push((number, line)),
                None => {} // blank
            }
            pos = next;
            if first == Some(b"end_header".as_slice()) {
                break;
            }
        }
        let dropped = number - kept.len() as u64;
        let mut warnings: Vec<String> = unknown
            .iter()
            .take(MAX_WARNINGS)
            .map(|(n, l)| format!("line {n}: unknown header line '{}' ignored", show_bytes(l)))
            .collect();
        if unknown.len() > MAX_WARNINGS {
            warnings.push(format!(
                "{} more unknown header lines ignored",
                unknown.len() - MAX_WARNINGS
            ));
        }
        let header = if dropped == 0 {
            Cow::Borrowed(&bytes[..pos])
        } else {
            Cow::Owned(
                kept.iter()
                    .flat_map(|(_, r)| bytes[r.clone()].iter().copied())
                    .collect(),
            )
        };
        CleanHeader {
            header,
            payload: &bytes[pos..],
            lines: LineMap {
                kept: if dropped == 0 {
                    Vec::new()
                } else {
                    kept.iter().map(|(n, _)| *n).collect()
                },
                dropped,
            },
            warnings,
        }
    }
}

/// Which elements hold the faces or the range grid, checked against the header.
struct Plan<'h> {
    face: Option<&'h str>,
    strips: Option<&'h str>,
    grid: Option<GridPlan<'h>>,
    /// The vertex element has `nx`, `ny` and `nz`.
    normals: bool,
}

/// A `range_grid` element and the grid's size from the header's `obj_info` lines.
#[derive(Clone, Copy)]
struct GridPlan<'h> {
    name: &'h str,
    rows: usize,
    cols: usize,
    cells: usize,
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
            grid: None,
            normals: header.elements.get("vertex").is_some_and(|v| {
                ["nx", "ny", "nz"].iter().all(|c| {
                    matches!(
                        v.properties.get(*c).map(|p| &p.data_type),
                        Some(PropertyType::Scalar(_))
                    )
                })
            }),
        };
        let mut grid = None;
        for (name, slot) in [
            ("face", &mut plan.face),
            ("tristrips", &mut plan.strips),
            ("range_grid", &mut grid),
        ] {
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
        if let Some(name) = grid {
            let cells = header.elements.get(name).map_or(0, |d| d.count);
            if cells == 0 {
                return Ok(plan); // an empty grid is no grid
            }
            let (rows, cols) = grid_size(&header.obj_infos, cells)?;
            plan.grid = Some(GridPlan {
                name,
                rows,
                cols,
                cells,
            });
        }
        Ok(plan)
    }
}

/// The size of a range grid: `obj_info num_rows R` and `obj_info num_cols C` header lines, whose
/// product must be the number of `range_grid` cells.
fn grid_size(obj_infos: &[String], cells: usize) -> Result<(usize, usize), MeshError> {
    let bad = |m: String| MeshError::new(ErrorKind::Syntax(m));
    let find = |key: &str| -> Result<Option<usize>, MeshError> {
        for info in obj_infos {
            let mut t = info.split_whitespace();
            if t.next() == Some(key) {
                let value = t.next().unwrap_or_default();
                return value.parse().map(Some).map_err(|_| {
                    bad(format!(
                        "the header's 'obj_info {key} {}' is not a grid size",
                        show(value)
                    ))
                });
            }
        }
        Ok(None)
    };
    let (Some(rows), Some(cols)) = (find("num_rows")?, find("num_cols")?) else {
        return Err(bad(format!(
            "the file has a 'range_grid' element of {cells} cells but the header does not give \
             the grid's size: it needs the lines 'obj_info num_rows R' and 'obj_info num_cols C'"
        )));
    };
    if rows.checked_mul(cols) != Some(cells) {
        return Err(bad(format!(
            "the header's obj_info num_rows {rows} x num_cols {cols} do not match the \
             'range_grid' element's {cells} cells"
        )));
    }
    Ok((rows, cols))
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

fn header_error(e: ParseError, lines: &LineMap) -> MeshError {
    let kind = if e.kind() == std::io::ErrorKind::UnexpectedEof {
        ErrorKind::Truncated {
            expected: "the header (no 'end_header' line)".into(),
        }
    } else {
        ErrorKind::Syntax(format!("bad PLY header: {}", header_reason(&e.to_string())))
    };
    let err = MeshError::new(kind);
    match e.line() {
        Some(l) => err.at(Location::Line(lines.file_line(l as u64))),
        None => err,
    }
}

/// Turns a payload error into one naming the element: the line (ascii) or the element index
/// (binary; `ply-rs-bw` counts one "line" per element there).
fn element_error(
    e: ParseError,
    def: &ElementDef,
    start: u64,
    ascii: bool,
    lines: &LineMap,
) -> MeshError {
    let name = &def.name;
    let line = e.line().map(|l| l as u64);
    let location = match (line, ascii) {
        (Some(l), true) => Some(Location::Line(lines.file_line(l))),
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
    show_bytes(s.as_bytes())
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

/// Vertex positions and normals as they are read.
struct VertexRec {
    xyz: [f64; 3],
    normal: [f64; 3],
}

impl VertexRec {
    fn set(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        let (to, i) = match name {
            "x" => (&mut self.xyz, 0),
            "y" => (&mut self.xyz, 1),
            "z" => (&mut self.xyz, 2),
            "nx" => (&mut self.normal, 0),
            "ny" => (&mut self.normal, 1),
            "nz" => (&mut self.normal, 2),
            _ => return PropertyAccessResult::Ignored,
        };
        to[i] = v;
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for VertexRec {
    fn new() -> Self {
        VertexRec {
            xyz: [0.0; 3],
            normal: [0.0; 3],
        }
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

/// One `range_grid` cell: how many vertices its list names and the first of them.
struct GridCell {
    len: usize,
    first: i64,
}

impl GridCell {
    fn set<T: Copy + Into<i64>>(&mut self, name: &str, list: &[T]) -> PropertyAccessResult {
        if !is_index_list(name) {
            return PropertyAccessResult::Ignored;
        }
        self.len = list.len();
        self.first = list.first().map_or(0, |&v| v.into());
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for GridCell {
    fn new() -> Self {
        GridCell { len: 0, first: 0 }
    }
    fn set_list_char(&mut self, name: &str, v: Vec<i8>) -> PropertyAccessResult {
        self.set(name, &v)
    }
    fn set_list_uchar(&mut self, name: &str, v: Vec<u8>) -> PropertyAccessResult {
        self.set(name, &v)
    }
    fn set_list_short(&mut self, name: &str, v: Vec<i16>) -> PropertyAccessResult {
        self.set(name, &v)
    }
    fn set_list_ushort(&mut self, name: &str, v: Vec<u16>) -> PropertyAccessResult {
        self.set(name, &v)
    }
    fn set_list_int(&mut self, name: &str, v: Vec<i32>) -> PropertyAccessResult {
        self.set(name, &v)
    }
    fn set_list_uint(&mut self, name: &str, v: Vec<u32>) -> PropertyAccessResult {
        self.set(name, &v)
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

    fn parsed(bytes: &[u8]) -> Parsed {
        read_ply(bytes).unwrap_or_else(|e| panic!("{e}"))
    }

    fn raw_mesh(bytes: &[u8]) -> RawMesh {
        match parsed(bytes).raw {
            Raw::Mesh(m) => m,
            other => panic!("{other:?}"),
        }
    }

    /// A 2 x 3 range grid over 5 vertices: cell (0, 1) empty, cell (1, 2) listing two vertices.
    fn grid_file(encoding: &str, obj_info: &str, cells: &[&[i32]]) -> Vec<u8> {
        let mut b = format!(
            "ply\nformat {encoding} 1.0\nobj_info is_interlaced 0\n{obj_info}element vertex 5\n\
             property float x\nproperty float y\nproperty float z\nelement range_grid {}\n\
             property list uchar int vertex_indices\nend_header\n",
            cells.len()
        )
        .into_bytes();
        let v: [[f32; 3]; 5] = [
            [0., 0., 0.],
            [2., 0., 0.],
            [0., 1., 0.],
            [1., 1., 0.],
            [2., 1., 0.],
        ];
        let ascii = encoding == "ascii";
        for p in v {
            if ascii {
                b.extend(format!("{} {} {}\n", p[0], p[1], p[2]).bytes());
            } else {
                p.iter().for_each(|c| b.extend(c.to_le_bytes()));
            }
        }
        for c in cells {
            if ascii {
                let list: Vec<String> = c.iter().map(i32::to_string).collect();
                b.extend(
                    format!("{} {}\n", c.len(), list.join(" "))
                        .trim_end()
                        .bytes(),
                );
                b.push(b'\n');
            } else {
                b.push(c.len() as u8);
                c.iter().for_each(|i| b.extend(i.to_le_bytes()));
            }
        }
        b
    }

    const SIZE: &str = "obj_info num_cols 3\nobj_info num_rows 2\n";
    const CELLS: &[&[i32]] = &[&[0], &[], &[1], &[2], &[3], &[4, 0]];

    #[test]
    fn range_grids_in_ascii_and_binary() {
        for enc in ["ascii", "binary_little_endian"] {
            let p = parsed(&grid_file(enc, SIZE, CELLS));
            let Raw::Grid(g) = p.raw else {
                panic!("{enc}: {:?}", p.raw)
            };
            assert_eq!((g.rows, g.cols), (2, 3), "{enc}");
            assert_eq!(
                g.cells,
                vec![Some(0), None, Some(1), Some(2), Some(3), Some(4)]
            );
            assert_eq!(g.positions.len(), 5);
            assert!(!g.flip);
            assert_eq!(
                p.warnings,
                vec!["1 'range_grid' cells list more than one vertex: the first of each is used"],
                "{enc}"
            );
        }
    }

    #[test]
    fn range_grid_errors() {
        // The grid's size is missing, or does not match the cells.
        let (k, _) = err(&grid_file("ascii", "obj_info num_cols 3\n", CELLS));
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("obj_info num_rows R")),
            "{k:?}"
        );
        let (k, _) = err(&grid_file(
            "ascii",
            "obj_info num_cols 4\nobj_info num_rows 2\n",
            CELLS,
        ));
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("num_rows 2 x num_cols 4")),
            "{k:?}"
        );
        let (k, _) = err(&grid_file(
            "ascii",
            "obj_info num_cols x\nobj_info num_rows 2\n",
            CELLS,
        ));
        assert!(matches!(k, ErrorKind::Syntax(_)), "{k:?}");
        // An index out of range: the line (ascii) or the range_grid element (binary).
        let bad: &[&[i32]] = &[&[0], &[], &[1], &[2], &[9], &[4]];
        let (k, l) = err(&grid_file("ascii", SIZE, bad));
        assert!(
            matches!(
                k,
                ErrorKind::IndexOutOfRange {
                    index: 9,
                    vertices: 5
                }
            ),
            "{k:?}"
        );
        // 12 header lines, 5 vertices, cell 4 on line 22
        assert_eq!(l, Some(Location::Line(22)));
        let (k, l) = err(&grid_file("binary_little_endian", SIZE, bad));
        assert!(
            matches!(k, ErrorKind::IndexOutOfRange { index: 9, .. }),
            "{k:?}"
        );
        assert_eq!(
            l,
            Some(Location::Element {
                name: "range_grid".into(),
                index: 4
            })
        );
        let neg: &[&[i32]] = &[&[0], &[], &[-3], &[2], &[3], &[4]];
        let (k, l) = err(&grid_file("binary_little_endian", SIZE, neg));
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("negative")),
            "{k:?}"
        );
        assert_eq!(
            l,
            Some(Location::Element {
                name: "range_grid".into(),
                index: 2
            })
        );
        // Cut in the middle of the grid.
        let mut cut = grid_file("binary_little_endian", SIZE, CELLS);
        cut.truncate(cut.len() - 7);
        assert!(matches!(err(&cut).0, ErrorKind::Truncated { .. }));
        // A billion cells in a small file: truncated before anything is read.
        let text = b"ply\nformat binary_little_endian 1.0\nobj_info num_cols 1000000\n\
             obj_info num_rows 1000\nelement vertex 0\nproperty float x\nproperty float y\n\
             property float z\nelement range_grid 1000000000\n\
             property list uchar int vertex_indices\nend_header\n\0\0";
        assert!(matches!(err(text).0, ErrorKind::Truncated { .. }));
    }

    #[test]
    fn faces_win_over_a_range_grid() {
        let mut f = grid_file("ascii", SIZE, CELLS);
        let at = f.windows(11).position(|w| w == b"end_header\n").unwrap();
        f.splice(
            at..at,
            b"element face 1\nproperty list uchar int vertex_indices\n"
                .iter()
                .copied(),
        );
        f.extend(b"3 0 1 2\n");
        let p = parsed(&f);
        assert!(
            matches!(p.raw, Raw::Mesh(ref m) if m.faces == vec![[0, 1, 2]]),
            "{:?}",
            p.raw
        );
        assert_eq!(p.warnings.len(), 1, "{:?}", p.warnings);
    }

    #[test]
    fn vertices_without_faces_are_points_with_their_normals() {
        let head = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
                    property float z\n";
        let with_normals = format!(
            "{head}property float nx\nproperty float ny\nproperty float nz\nelement face 0\n\
             property list uchar int vertex_indices\nend_header\n1 2 3 0 0 1\n4 5 6 1 0 0\n"
        );
        let Raw::Points(p) = parsed(with_normals.as_bytes()).raw else {
            panic!()
        };
        assert_eq!(
            p.positions,
            vec![Point3::new(1., 2., 3.), Point3::new(4., 5., 6.)]
        );
        assert_eq!(
            p.normals,
            Some(vec![Vector3::new(0., 0., 1.), Vector3::new(1., 0., 0.)])
        );
        // nx and ny only: no normals.
        let partial = format!(
            "{head}property float nx\nproperty float ny\nend_header\n1 2 3 0 0\n4 5 6 1 0\n"
        );
        let Raw::Points(p) = parsed(partial.as_bytes()).raw else {
            panic!()
        };
        assert_eq!(p.normals, None);
        // An empty range_grid is no grid.
        let empty_grid = format!(
            "{head}element range_grid 0\nproperty list uchar int vertex_indices\nend_header\n\
             1 2 3\n4 5 6\n"
        );
        assert!(matches!(parsed(empty_grid.as_bytes()).raw, Raw::Points(_)));
    }

    #[test]
    fn unknown_and_blank_header_lines_are_ignored_with_a_warning() {
        // As some scans of the Stanford repository have: a 'bye' line, and a blank one.
        let text = "ply\nformat ascii 1.0\nobj_info num_cols 2\nbye\n\nelement vertex 3\n\
                    property float x\nproperty float y\nproperty float z\nscanner says hi\n\
                    element face 1\nproperty list uchar int vertex_indices\nend_header\n\
                    0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        let p = parsed(text.as_bytes());
        assert_eq!(
            p.warnings,
            vec![
                "line 4: unknown header line 'bye' ignored",
                "line 10: unknown header line 'scanner says hi' ignored"
            ]
        );
        assert!(matches!(p.raw, Raw::Mesh(ref m) if m.faces == vec![[0, 1, 2]]));
        // Errors after dropped lines still name the file's own lines: in the header ...
        let bad = text.replace("property float z", "property flot z");
        assert_eq!(err(bad.as_bytes()).1, Some(Location::Line(9)));
        // ... and in the data.
        let bad = text.replace("1 0 0\n", "1 x 0\n");
        assert_eq!(err(bad.as_bytes()).1, Some(Location::Line(15)));
        let bad = text.replace("3 0 1 2", "3 0 1 7");
        assert_eq!(err(bad.as_bytes()).1, Some(Location::Line(17)));
        // Many unknown lines: ten listed, the rest counted.
        let many = text.replace("bye\n", &"bye\n".repeat(25));
        let w = parsed(many.as_bytes()).warnings;
        assert_eq!(w.len(), 11, "{w:?}");
        assert_eq!(w[10], "16 more unknown header lines ignored");
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
                let m = raw_mesh(&ascii(&f, "3 0 1 2 7\n4 0 1 2 3 9\n"));
                assert_eq!(m.positions.len(), 4);
                assert_eq!(m.positions[3], Point3::new(0.0, 0.0, 1.0));
                assert_eq!(m.faces, vec![[0, 1, 2], [0, 1, 2], [0, 2, 3]], "{t} {name}");
            }
        }
    }

    #[test]
    fn tristrips_alternate_winding_and_restart() {
        let f = "element tristrips 1\nproperty list int int vertex_indices\n";
        let m = raw_mesh(&ascii(f, "9 0 1 2 3 -1 3 2 1 1 0\n"));
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
