//! Reads PCD files, the Point Cloud Library's format (v0.7, and the older v0.5/v0.6 headers).
//!
//! Header: text lines, `#` comments and blank lines skipped, in any order, up to the `DATA` line:
//! - `VERSION` (ignored), `FIELDS` (or the old `COLUMNS`): the field names; `SIZE`: bytes per
//!   value, 1, 2, 4 or 8; `TYPE`: `F` (float, 4 or 8 bytes), `I` (signed) or `U` (unsigned
//!   integer); `COUNT`: values per field (`rgb` 1, `fpfh` 33, …). `SIZE`, `TYPE` and `COUNT`
//!   have one entry per field; missing, they default to 4, `F` and 1 (as old files assume).
//! - `WIDTH`, `HEIGHT`, `POINTS`: `HEIGHT > 1` is an organised cloud, `HEIGHT` rows of `WIDTH`
//!   points (a range image); `HEIGHT` 1 an unorganised one. `WIDTH x HEIGHT` must equal
//!   `POINTS`. Missing `POINTS` is `WIDTH x HEIGHT`; missing `WIDTH` and `HEIGHT` are `POINTS`
//!   and 1; missing `HEIGHT` is 1.
//! - `VIEWPOINT` (the sensor pose) is read past: points are used as stored.
//! - `DATA ascii`, `binary` or `binary_compressed`. Any other line is an error.
//!
//! Data:
//! - `ascii`: one point per line, the fields' values separated by whitespace (`nan` allowed);
//!   blank lines skipped; lines after the declared points are ignored with a warning.
//! - `binary`: `POINTS` records of the fields' values in order, little endian, no padding.
//! - `binary_compressed`: two little-endian `u32`, the compressed and the decompressed size, then
//!   the LZF-compressed data ([`super::lzf`]), which decompresses to the fields one after the
//!   other (all points' `x`, then all points' `y`, …).
//!
//! Fields: `x`, `y`, `z` are required (the first value when a COUNT is above 1);
//! `normal_x`, `normal_y`, `normal_z` give normals; all other fields are skipped.
//!
//! Invalid points: PCL marks a point it has no measurement for with NaN coordinates. In an
//! organised cloud such points are the grid's absent cells: the cloud is a range grid,
//! triangulated by [`crate::grid::triangulate_grid`] over `HEIGHT` rows and `WIDTH` columns, its
//! vertices the valid points in file order. PCL's organised clouds have row 0 at the top as seen
//! from the sensor, so the winding is reversed to make the triangles face the sensor. In an
//! unorganised cloud NaN points are dropped with one warning giving their count. An infinite
//! coordinate is an error.
//!
//! Before any allocation the declared sizes are checked against the bytes that follow the header
//! (a binary point takes its record's size, an ascii point at least two bytes per value, the
//! compressed data its declared size, and LZF cannot expand more than 88 times), so a header
//! declaring a billion points in a small file is a "truncated" error naming the first point that
//! cannot fit. Other errors name the header line, the data line (ascii) or the point (binary), or
//! the byte of the compressed data.

use super::text::{Lines, parse_f64, show};
use super::{Parsed, Raw, RawGrid, RawPoints, lzf};
use crate::{ErrorKind, Location, MeshError, Point3, Vector3, VertexId};

/// Parses the bytes of a PCD file into points or, for an organised cloud, a range grid.
pub(crate) fn read_pcd(bytes: &[u8]) -> Result<Parsed, MeshError> {
    if bytes.is_empty() {
        return Err(MeshError::new(ErrorKind::Empty));
    }
    let header = Header::parse(bytes)?;
    let data = &bytes[header.data_start..];
    let mut warnings = Vec::new();
    let samples = match header.data {
        Data::Ascii => read_ascii(&header, data, &mut warnings)?,
        Data::Binary => read_binary(&header, data, &mut warnings)?,
        Data::Compressed => read_compressed(&header, data)?,
    };
    finish(&header, samples, warnings)
}

/// How the points are stored after the header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Data {
    Ascii,
    Binary,
    Compressed,
}

/// One field: its name, value type, values per point, and byte offset in a binary record.
#[derive(Debug)]
struct Field {
    name: String,
    kind: u8,
    size: usize,
    count: usize,
    offset: usize,
}

/// Where the fields the reader uses are: the field indices of x, y, z and of the normals.
#[derive(Debug)]
struct Wanted {
    xyz: [usize; 3],
    normals: Option<[usize; 3]>,
}

#[derive(Debug)]
struct Header {
    fields: Vec<Field>,
    wanted: Wanted,
    /// Bytes per binary record.
    point_step: usize,
    width: u64,
    height: u64,
    points: u64,
    data: Data,
    /// Byte offset and line number of the first byte after the `DATA` line.
    data_start: usize,
    data_line: u64,
}

/// The header's lines by keyword, as `(line number, values)`.
#[derive(Default)]
struct Keys<'a> {
    fields: Option<(u64, Vec<&'a [u8]>)>,
    size: Option<(u64, Vec<&'a [u8]>)>,
    kind: Option<(u64, Vec<&'a [u8]>)>,
    count: Option<(u64, Vec<&'a [u8]>)>,
    width: Option<(u64, Vec<&'a [u8]>)>,
    height: Option<(u64, Vec<&'a [u8]>)>,
    points: Option<(u64, Vec<&'a [u8]>)>,
}

fn syntax(line: u64, message: String) -> MeshError {
    MeshError::new(ErrorKind::Syntax(message)).at(Location::Line(line))
}

fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(u8::is_ascii_whitespace)
        .filter(|t| !t.is_empty())
}

impl Header {
    fn parse(bytes: &[u8]) -> Result<Header, MeshError> {
        let mut lines = Keys::default();
        let (mut pos, mut number) = (0usize, 0u64);
        let data = loop {
            if pos >= bytes.len() {
                return Err(MeshError::new(ErrorKind::Truncated {
                    expected: "the header (no 'DATA' line)".into(),
                })
                .at(Location::Line(number + 1)));
            }
            let end = bytes[pos..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(bytes.len(), |i| pos + i);
            let line = &bytes[pos..end];
            pos = (end + 1).min(bytes.len());
            number += 1;
            let mut w = words(line);
            let Some(key) = w.next() else { continue };
            if key.starts_with(b"#") {
                continue;
            }
            let values: Vec<&[u8]> = w.collect();
            let slot = match key {
                b"VERSION" | b"VIEWPOINT" => continue,
                b"FIELDS" | b"COLUMNS" => &mut lines.fields,
                b"SIZE" => &mut lines.size,
                b"TYPE" => &mut lines.kind,
                b"COUNT" => &mut lines.count,
                b"WIDTH" => &mut lines.width,
                b"HEIGHT" => &mut lines.height,
                b"POINTS" => &mut lines.points,
                b"DATA" => {
                    break match values.first().copied() {
                        Some(b"ascii") => Data::Ascii,
                        Some(b"binary") => Data::Binary,
                        Some(b"binary_compressed") => Data::Compressed,
                        other => {
                            return Err(syntax(
                                number,
                                format!(
                                    "unknown PCD data encoding '{}' (expected ascii, binary or \
                                     binary_compressed)",
                                    show(other.unwrap_or_default())
                                ),
                            ));
                        }
                    };
                }
                _ => {
                    let what = if number == 1 { "not a PCD file: " } else { "" };
                    return Err(syntax(
                        number,
                        format!(
                            "{what}unknown PCD header line '{}' (expected VERSION, FIELDS, SIZE, \
                             TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT, POINTS or DATA)",
                            show(line.trim_ascii())
                        ),
                    ));
                }
            };
            *slot = Some((number, values));
        };
        let data_line = number + 1;
        let data_start = pos;

        let Some((fields_line, names)) = lines.fields.filter(|(_, n)| !n.is_empty()) else {
            return Err(MeshError::new(ErrorKind::Syntax(
                "the PCD header has no FIELDS line naming the fields".into(),
            )));
        };
        let n = names.len();
        let per_field = |entry: &Option<(u64, Vec<&[u8]>)>, what: &str| match entry {
            Some((line, v)) if v.len() != n => Err(syntax(
                *line,
                format!("{what} has {} entries but FIELDS names {n} fields", v.len()),
            )),
            _ => Ok(()),
        };
        per_field(&lines.size, "SIZE")?;
        per_field(&lines.kind, "TYPE")?;
        per_field(&lines.count, "COUNT")?;
        let mut fields = Vec::with_capacity(n);
        let mut offset = 0usize;
        for (i, name) in names.iter().enumerate() {
            let size: usize = match &lines.size {
                Some((line, v)) => match v[i] {
                    b"1" => 1,
                    b"2" => 2,
                    b"4" => 4,
                    b"8" => 8,
                    t => {
                        return Err(syntax(
                            *line,
                            format!("SIZE '{}' is not 1, 2, 4 or 8", show(t)),
                        ));
                    }
                },
                None => 4,
            };
            let kind = match &lines.kind {
                Some((line, v)) => match v[i] {
                    b"F" if size >= 4 => b'F',
                    b"I" => b'I',
                    b"U" => b'U',
                    t => {
                        return Err(syntax(
                            *line,
                            format!(
                                "TYPE '{}' of field '{}' with SIZE {size} is not one of F (4 or \
                                 8 bytes), I or U",
                                show(t),
                                show(name)
                            ),
                        ));
                    }
                },
                None if size >= 4 => b'F',
                None => {
                    return Err(syntax(
                        fields_line,
                        format!("field '{}' has SIZE {size} but no TYPE line", show(name)),
                    ));
                }
            };
            let count = match &lines.count {
                Some((line, v)) => {
                    match std::str::from_utf8(v[i]).ok().and_then(|t| t.parse().ok()) {
                        Some(c) if c >= 1 => c,
                        _ => {
                            return Err(syntax(
                                *line,
                                format!("COUNT '{}' is not a positive integer", show(v[i])),
                            ));
                        }
                    }
                }
                None => 1,
            };
            let bytes_per_point = size.checked_mul(count);
            fields.push(Field {
                name: String::from_utf8_lossy(name).into_owned(),
                kind,
                size,
                count,
                offset,
            });
            offset = match bytes_per_point.and_then(|b| offset.checked_add(b)) {
                Some(o) => o,
                None => {
                    return Err(MeshError::new(ErrorKind::Syntax(
                        "the fields' SIZE x COUNT add up to more bytes than this machine can \
                         address"
                            .into(),
                    )));
                }
            };
        }
        let point_step = offset;
        let find = |name: &str| fields.iter().position(|f| f.name == name);
        let mut xyz = [0; 3];
        for (k, c) in ["x", "y", "z"].into_iter().enumerate() {
            xyz[k] = find(c).ok_or_else(|| {
                syntax(
                    fields_line,
                    format!("the PCD file has no '{c}' field (FIELDS names the point's values)"),
                )
            })?;
        }
        let normals = match (find("normal_x"), find("normal_y"), find("normal_z")) {
            (Some(a), Some(b), Some(c)) => Some([a, b, c]),
            _ => None,
        };

        let count_of = |entry: &Option<(u64, Vec<&[u8]>)>,
                        what: &str|
         -> Result<Option<u64>, MeshError> {
            let Some((line, v)) = entry else {
                return Ok(None);
            };
            match v.as_slice() {
                [t] => std::str::from_utf8(t)
                    .ok()
                    .and_then(|t| t.parse().ok())
                    .map(Some)
                    .ok_or_else(|| syntax(*line, format!("{what} '{}' is not a count", show(t)))),
                _ => Err(syntax(*line, format!("{what} needs one number"))),
            }
        };
        let (width, height, points) = (
            count_of(&lines.width, "WIDTH")?,
            count_of(&lines.height, "HEIGHT")?,
            count_of(&lines.points, "POINTS")?,
        );
        let (width, height) = match (width, height, points) {
            (None, None, Some(p)) => (p, 1),
            (Some(w), None, _) => (w, 1),
            (Some(w), Some(h), _) => (w, h),
            (None, Some(_), _) => {
                return Err(MeshError::new(ErrorKind::Syntax(
                    "the PCD header gives HEIGHT but no WIDTH".into(),
                )));
            }
            (None, None, None) => {
                return Err(MeshError::new(ErrorKind::Syntax(
                    "the PCD header gives neither POINTS nor WIDTH: the number of points is \
                     unknown"
                        .into(),
                )));
            }
        };
        let grid = width.checked_mul(height);
        let points = points.or(grid).unwrap_or(u64::MAX);
        if grid != Some(points) {
            let line = lines.points.as_ref().map_or(0, |(l, _)| *l);
            let e = MeshError::new(ErrorKind::Syntax(format!(
                "WIDTH {width} x HEIGHT {height} is not the POINTS count {points}"
            )));
            return Err(if line > 0 {
                e.at(Location::Line(line))
            } else {
                e
            });
        }
        Ok(Header {
            fields,
            wanted: Wanted { xyz, normals },
            point_step,
            width,
            height,
            points,
            data,
            data_start,
            data_line,
        })
    }

    /// Total values per point (the sum of the COUNTs; no larger than `point_step`, which did not
    /// overflow).
    fn values_per_point(&self) -> u64 {
        self.fields
            .iter()
            .fold(0u64, |sum, f| sum.saturating_add(f.count as u64))
    }
}

/// Positions (NaN where a point is invalid) and normals of every point, in file order.
struct Samples {
    positions: Vec<[f64; 3]>,
    normals: Option<Vec<[f64; 3]>>,
}

impl Samples {
    fn with_capacity(points: usize, normals: bool) -> Samples {
        Samples {
            positions: Vec::with_capacity(points),
            normals: normals.then(|| Vec::with_capacity(points)),
        }
    }
}

/// A point's position: an infinite coordinate is an error at `at`; NaN marks an invalid point.
fn check(xyz: [f64; 3], at: impl FnOnce() -> Location) -> Result<[f64; 3], MeshError> {
    if xyz.iter().any(|c| c.is_infinite()) {
        return Err(MeshError::new(ErrorKind::NonFiniteCoordinate).at(at()));
    }
    Ok(xyz)
}

fn read_ascii(
    header: &Header,
    data: &[u8],
    warnings: &mut Vec<String>,
) -> Result<Samples, MeshError> {
    let values = header.values_per_point();
    // Each point takes at least one byte per value and one separator or line break after each.
    let fits = (data.len() as u64 + 1) / values.saturating_mul(2).max(1);
    if header.points > fits {
        return Err(MeshError::new(ErrorKind::Truncated {
            expected: format!(
                "point {fits}: the header declares {} points, the data has room for at most \
                 {fits}",
                header.points
            ),
        })
        .at(Location::Point(fits)));
    }
    let points = header.points as usize;
    // The index of each wanted field's first value among a line's values.
    let first_value: Vec<usize> = header
        .fields
        .iter()
        .scan(0, |at, f| {
            let here = *at;
            *at += f.count;
            Some(here)
        })
        .collect();
    let xyz_at = header.wanted.xyz.map(|f| first_value[f]);
    let normal_at = header.wanted.normals.map(|n| n.map(|f| first_value[f]));
    let mut samples = Samples::with_capacity(points, normal_at.is_some());
    let mut tokens: Vec<&[u8]> = Vec::new();
    let mut extra = 0u64;
    let mut first_extra = 0;
    let offset = header.data_line - 1;
    let mut lines = Lines::new(data, None);
    for (n, line) in lines.by_ref() {
        let line_number = offset + n;
        tokens.clear();
        tokens.extend(words(line));
        if tokens.is_empty() {
            continue;
        }
        if samples.positions.len() == points {
            if extra == 0 {
                first_extra = line_number;
            }
            extra += 1;
            continue;
        }
        if tokens.len() as u64 != values {
            let names: Vec<&str> = header.fields.iter().map(|f| f.name.as_str()).collect();
            return Err(syntax(
                line_number,
                format!(
                    "point {} has {} values but the fields ({}) need {values}",
                    samples.positions.len(),
                    tokens.len(),
                    names.join(" ")
                ),
            ));
        }
        let value = |i: usize| {
            parse_f64(tokens[i]).ok_or_else(|| {
                syntax(
                    line_number,
                    format!("'{}' is not a number", show(tokens[i])),
                )
            })
        };
        let xyz = [value(xyz_at[0])?, value(xyz_at[1])?, value(xyz_at[2])?];
        samples
            .positions
            .push(check(xyz, || Location::Line(line_number))?);
        if let (Some(ns), Some(at)) = (&mut samples.normals, normal_at) {
            ns.push([value(at[0])?, value(at[1])?, value(at[2])?]);
        }
    }
    if samples.positions.len() < points {
        return Err(MeshError::new(ErrorKind::Truncated {
            expected: format!(
                "point {} of the {} declared",
                samples.positions.len(),
                header.points
            ),
        })
        .at(Location::Line(offset + lines.line() + 1)));
    }
    if extra > 0 {
        warnings.push(format!(
            "line {first_extra}: {extra} lines after the {} declared points ignored",
            header.points
        ));
    }
    Ok(samples)
}

/// Reads one value of `field` from the start of `bytes` (little endian) as a number.
fn value(field: &Field, bytes: &[u8]) -> f64 {
    fn le<const N: usize>(bytes: &[u8]) -> [u8; N] {
        let mut b = [0; N];
        b.copy_from_slice(&bytes[..N]);
        b
    }
    match (field.kind, field.size) {
        (b'F', 4) => f32::from_le_bytes(le(bytes)).into(),
        (b'F', _) => f64::from_le_bytes(le(bytes)),
        (b'I', 1) => (bytes[0] as i8).into(),
        (b'I', 2) => i16::from_le_bytes(le(bytes)).into(),
        (b'I', 4) => i32::from_le_bytes(le(bytes)).into(),
        (b'I', _) => i64::from_le_bytes(le(bytes)) as f64,
        (_, 1) => bytes[0].into(),
        (_, 2) => u16::from_le_bytes(le(bytes)).into(),
        (_, 4) => u32::from_le_bytes(le(bytes)).into(),
        _ => u64::from_le_bytes(le(bytes)) as f64,
    }
}

fn read_binary(
    header: &Header,
    data: &[u8],
    warnings: &mut Vec<String>,
) -> Result<Samples, MeshError> {
    let step = header.point_step;
    let fits = data.len() as u64 / step as u64;
    if header.points > fits {
        return Err(MeshError::new(ErrorKind::Truncated {
            expected: format!(
                "point {fits}: the header declares {} points of {step} bytes, the data has \
                 room for {fits}",
                header.points
            ),
        })
        .at(Location::Point(fits)));
    }
    let points = header.points as usize;
    let extra = data.len() - points * step;
    if extra > 0 {
        warnings.push(format!(
            "{extra} bytes after the {points} declared points ignored"
        ));
    }
    let fields = &header.fields;
    let get = |record: &[u8], f: usize| value(&fields[f], &record[fields[f].offset..]);
    let mut samples = Samples::with_capacity(points, header.wanted.normals.is_some());
    for (i, record) in data.chunks_exact(step).take(points).enumerate() {
        let xyz = header.wanted.xyz.map(|f| get(record, f));
        samples
            .positions
            .push(check(xyz, || Location::Point(i as u64))?);
        if let (Some(ns), Some(n)) = (&mut samples.normals, header.wanted.normals) {
            ns.push(n.map(|f| get(record, f)));
        }
    }
    Ok(samples)
}

/// LZF output is at most this many times its input (a 3-byte reference gives 264 bytes).
const LZF_MAX_RATIO: u64 = 88;

fn read_compressed(header: &Header, data: &[u8]) -> Result<Samples, MeshError> {
    let at_data = header.data_start as u64;
    let word = |k: usize| {
        data.get(4 * k..4 * k + 4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
    };
    let (Some(packed), Some(unpacked)) = (word(0), word(1)) else {
        return Err(MeshError::new(ErrorKind::Truncated {
            expected: "the compressed data's two sizes".into(),
        })
        .at(Location::Byte(at_data)));
    };
    let (packed, unpacked) = (packed as u64, unpacked as u64);
    let need = header.points.saturating_mul(header.point_step as u64);
    if unpacked != need {
        return Err(MeshError::new(ErrorKind::Syntax(format!(
            "the compressed data decompresses to {unpacked} bytes, but {} points of {} bytes \
             need {need}",
            header.points, header.point_step
        )))
        .at(Location::Byte(at_data + 4)));
    }
    let available = data.len() as u64 - 8;
    if packed > available {
        return Err(MeshError::new(ErrorKind::Truncated {
            expected: format!(
                "the compressed data: the header declares {packed} bytes, the file has {available}"
            ),
        })
        .at(Location::Byte(at_data + 8 + available)));
    }
    if unpacked > packed.saturating_mul(LZF_MAX_RATIO) {
        return Err(MeshError::new(ErrorKind::Syntax(format!(
            "{packed} bytes of LZF data cannot decompress to {unpacked} bytes: the sizes are \
             corrupt"
        )))
        .at(Location::Byte(at_data)));
    }
    let input = &data[8..8 + packed as usize];
    let raw = lzf::decompress(input, unpacked as usize).map_err(|(offset, why)| {
        MeshError::new(ErrorKind::Syntax(format!(
            "the compressed data is corrupt: {why}"
        )))
        .at(Location::Byte(at_data + 8 + offset as u64))
    })?;
    let points = header.points as usize;
    // Field-major: field k's values for all points start at points x (bytes of fields before k).
    let fields = &header.fields;
    let get = |i: usize, f: usize| {
        let field = &fields[f];
        let start = points * field.offset + i * field.size * field.count;
        value(field, &raw[start..])
    };
    let mut samples = Samples::with_capacity(points, header.wanted.normals.is_some());
    for i in 0..points {
        let xyz = header.wanted.xyz.map(|f| get(i, f));
        samples
            .positions
            .push(check(xyz, || Location::Point(i as u64))?);
        if let (Some(ns), Some(n)) = (&mut samples.normals, header.wanted.normals) {
            ns.push(n.map(|f| get(i, f)));
        }
    }
    Ok(samples)
}

/// An organised cloud becomes a range grid, an unorganised one points without the invalid ones.
fn finish(
    header: &Header,
    samples: Samples,
    mut warnings: Vec<String>,
) -> Result<Parsed, MeshError> {
    let valid = |p: &[f64; 3]| !p.iter().any(|c| c.is_nan());
    let total = samples.positions.len();
    let kept = samples.positions.iter().filter(|p| valid(p)).count();
    if kept == 0 && total > 0 {
        return Err(MeshError::new(ErrorKind::Other(format!(
            "all {total} points are invalid (NaN coordinates): the cloud is empty"
        ))));
    }
    if header.height > 1 {
        let mut positions = Vec::with_capacity(kept);
        let mut cells = Vec::with_capacity(total);
        for p in &samples.positions {
            if valid(p) {
                let id = VertexId::try_from(positions.len()).map_err(|_| {
                    MeshError::new(ErrorKind::Other(
                        "the organised cloud has more points than a mesh can index (2^32)".into(),
                    ))
                })?;
                cells.push(Some(id));
                positions.push(Point3::from(*p));
            } else {
                cells.push(None);
            }
        }
        let raw = Raw::Grid(RawGrid {
            positions,
            rows: header.height as usize,
            cols: header.width as usize,
            cells,
            flip: true,
        });
        return Ok(Parsed { raw, warnings });
    }
    if kept < total {
        warnings.push(format!(
            "{} points with NaN coordinates (PCL's invalid points) dropped",
            total - kept
        ));
    }
    let keep: Vec<bool> = samples.positions.iter().map(valid).collect();
    let positions = samples
        .positions
        .iter()
        .filter(|p| valid(p))
        .map(|p| Point3::from(*p))
        .collect();
    let normals = samples.normals.map(|ns| {
        ns.iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(n, _)| Vector3::from(*n))
            .collect()
    });
    Ok(Parsed {
        raw: Raw::Points(RawPoints { positions, normals }),
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{PcdData, pcd};
    use super::super::{Geometry, Source, read_input_from_bytes};
    use super::*;
    use crate::Format;

    const ALL: [PcdData; 3] = [PcdData::Ascii, PcdData::Binary, PcdData::Compressed];
    const NAN: f64 = f64::NAN;

    fn parsed(bytes: &[u8]) -> Parsed {
        read_pcd(bytes).unwrap_or_else(|e| panic!("{e}"))
    }

    fn err(bytes: &[u8]) -> (ErrorKind, Option<Location>) {
        let e = read_pcd(bytes).unwrap_err();
        (e.kind, e.location)
    }

    /// Six points (exact in f32), the third and fifth invalid.
    const POINTS: [[f64; 3]; 6] = [
        [0.0, 0.0, 1.0],
        [1.5, 0.0, 1.0],
        [NAN, NAN, NAN],
        [0.0, 2.0, 1.25],
        [1.0, NAN, 1.0],
        [-3.0, 1.0, 0.5],
    ];
    const NORMALS: [[f64; 3]; 6] = [[0.0, 0.0, -1.0]; 6];

    #[test]
    fn unorganised_clouds_in_every_encoding_drop_invalid_points() {
        for data in ALL {
            let p = parsed(&pcd(&POINTS, Some(&NORMALS), 6, 1, data));
            let Raw::Points(r) = p.raw else {
                panic!("{data:?}: {:?}", p.raw)
            };
            let want: Vec<Point3<f64>> = [0, 1, 3, 5]
                .iter()
                .map(|&i| Point3::from(POINTS[i]))
                .collect();
            assert_eq!(r.positions, want, "{data:?}");
            assert_eq!(
                r.normals,
                Some(vec![Vector3::new(0.0, 0.0, -1.0); 4]),
                "{data:?}"
            );
            assert_eq!(
                p.warnings,
                vec!["2 points with NaN coordinates (PCL's invalid points) dropped"],
                "{data:?}"
            );
            let p = parsed(&pcd(&POINTS[..2], None, 2, 1, data));
            assert!(matches!(p.raw, Raw::Points(ref r) if r.normals.is_none()));
            assert!(p.warnings.is_empty());
        }
    }

    #[test]
    fn organised_clouds_are_range_grids_facing_the_sensor() {
        // 3 rows of 4 points on the plane z = 2 in PCL's camera frame (x right, y down, the
        // sensor at the origin looking along +z); two cells invalid.
        let mut points = Vec::new();
        for r in 0..3 {
            for c in 0..4 {
                points.push(if (r, c) == (1, 1) || (r, c) == (2, 3) {
                    [NAN; 3]
                } else {
                    [c as f64 * 0.5, r as f64 * 0.5, 2.0]
                });
            }
        }
        for data in ALL {
            let bytes = pcd(&points, None, 4, 3, data);
            let input = read_input_from_bytes(&bytes, Format::Pcd).unwrap();
            assert_eq!(input.source, Source::RangeGrid { rows: 3, cols: 4 });
            assert!(input.warnings.is_empty(), "{:?}", input.warnings);
            let Geometry::Mesh(m) = input.geometry else {
                panic!()
            };
            assert_eq!(m.num_vertices(), 10);
            // 6 blocks: (0,0), (0,1), (1,0), (1,1) lose a corner, (1,2) loses (2,3): 1 triangle
            // each; (0,2) keeps both.
            assert_eq!(m.num_faces(), 7, "{data:?}");
            for f in 0..m.num_faces() {
                let [a, b, c] = m.triangle(f);
                let n = (b - a).cross(&(c - a));
                assert!(n.z < 0.0, "{data:?}: face {f} faces away from the sensor");
            }
        }
    }

    #[test]
    fn old_headers_and_defaults() {
        // v0.5: COLUMNS, no SIZE/TYPE/COUNT (floats), no WIDTH/HEIGHT.
        let text = b"COLUMNS x y z\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6\n";
        let Raw::Points(r) = parsed(text).raw else {
            panic!()
        };
        assert_eq!(r.positions.len(), 2);
        // Binary, no SIZE/TYPE: four-byte floats; WIDTH only.
        let mut b = b"FIELDS x y z\nWIDTH 1\nDATA binary\n".to_vec();
        [1.0f32, 2.0, 3.0]
            .iter()
            .for_each(|v| b.extend(v.to_le_bytes()));
        let Raw::Points(r) = parsed(&b).raw else {
            panic!()
        };
        assert_eq!(r.positions, vec![Point3::new(1.0, 2.0, 3.0)]);
        // Integer coordinates of every size, CRLF and comments anywhere in the header.
        let mut b = b"# c\r\nVERSION .6\r\nFIELDS z y x\r\n# c\r\nSIZE 1 2 8\r\nTYPE I U I\r\n\
                      COUNT 1 1 1\r\nWIDTH 1\r\nHEIGHT 1\r\nPOINTS 1\r\nDATA binary\r\n"
            .to_vec();
        b.push(-5i8 as u8);
        b.extend(60000u16.to_le_bytes());
        b.extend((-7i64).to_le_bytes());
        let Raw::Points(r) = parsed(&b).raw else {
            panic!()
        };
        assert_eq!(r.positions, vec![Point3::new(-7.0, 60000.0, -5.0)]);
    }

    #[test]
    fn lines_after_the_points_are_a_warning() {
        let text = b"FIELDS x y z\nPOINTS 1\nDATA ascii\n1 2 3\n\n4 5 6\n7 8 9\n";
        let p = parsed(text);
        assert_eq!(
            p.warnings,
            vec!["line 6: 2 lines after the 1 declared points ignored"]
        );
        let mut b = pcd(&POINTS[..1], None, 1, 1, PcdData::Binary);
        b.extend([0; 5]);
        assert_eq!(
            parsed(&b).warnings,
            vec!["5 bytes after the 1 declared points ignored"]
        );
    }

    #[test]
    fn header_errors_name_the_line() {
        let cases: &[(&str, u64, &str)] = &[
            (
                "FIELDS x y z\nSIZE 4 4\nPOINTS 1\nDATA ascii\n",
                2,
                "SIZE has 2 entries",
            ),
            (
                "FIELDS x y z\nSIZE 4 4 3\nPOINTS 1\nDATA ascii\n",
                2,
                "SIZE '3'",
            ),
            (
                "FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nPOINTS 1\nDATA ascii\n",
                3,
                "TYPE 'F'",
            ),
            (
                "FIELDS x y z\nTYPE F F Q\nPOINTS 1\nDATA ascii\n",
                2,
                "TYPE 'Q'",
            ),
            (
                "FIELDS x y z\nCOUNT 1 0 1\nPOINTS 1\nDATA ascii\n",
                2,
                "COUNT '0'",
            ),
            (
                "FIELDS x y z\nWIDTH 2\nHEIGHT 2\nPOINTS 5\nDATA ascii\n",
                4,
                "WIDTH 2 x HEIGHT 2",
            ),
            ("FIELDS x y z\nPOINTS -1\nDATA ascii\n", 2, "POINTS '-1'"),
            ("FIELDS x y\nPOINTS 1\nDATA ascii\n", 1, "no 'z' field"),
            ("FIELDS x y z\nPOINTS 1\nDATA zip\n", 3, "'zip'"),
            (
                "FIELDS x y z\nPOINTS 1\nWHATEVER 3\nDATA ascii\n",
                3,
                "'WHATEVER 3'",
            ),
            ("ply\nformat ascii 1.0\n", 1, "not a PCD file"),
        ];
        for (text, line, what) in cases {
            let (k, l) = err(text.as_bytes());
            assert!(
                matches!(k, ErrorKind::Syntax(ref m) if m.contains(what)),
                "{text:?}: {k:?}"
            );
            assert_eq!(l, Some(Location::Line(*line)), "{text:?}");
        }
        let (k, _) = err(b"POINTS 1\nDATA ascii\n");
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("FIELDS")),
            "{k:?}"
        );
        let (k, _) = err(b"FIELDS x y z\nHEIGHT 3\nDATA ascii\n");
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("no WIDTH")),
            "{k:?}"
        );
        let (k, l) = err(b"FIELDS x y z\nPOINTS 1\n1 2 3\n");
        assert!(matches!(k, ErrorKind::Syntax(_)), "{k:?}");
        assert_eq!(l, Some(Location::Line(3)));
        let (k, l) = err(b"# only\nFIELDS x y z\n");
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        assert_eq!(l, Some(Location::Line(3)));
        assert!(matches!(err(b"").0, ErrorKind::Empty));
    }

    #[test]
    fn data_errors_name_the_line_or_the_point() {
        let head = "FIELDS x y z rgb\nCOUNT 1 1 1 1\nPOINTS 3\nDATA ascii\n";
        let first = "0.0 0.0 0.0 1.0\n";
        let last = "\n0.0 1.0 0.0 1.0\n";
        let case = |second: &str| err(format!("{head}{first}{second}{last}").as_bytes());
        let (k, l) = case("1.0 0.0 0.0");
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("has 3 values")),
            "{k:?}"
        );
        assert_eq!(l, Some(Location::Line(6)));
        let (k, l) = case("1 0 0 1 2");
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("has 5 values")),
            "{k:?}"
        );
        assert_eq!(l, Some(Location::Line(6)));
        let (k, l) = case("1.0 x 0.0 1.0");
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("'x'")),
            "{k:?}"
        );
        assert_eq!(l, Some(Location::Line(6)));
        let (k, l) = case("1.0 inf 0.0 1.0");
        assert!(matches!(k, ErrorKind::NonFiniteCoordinate), "{k:?}");
        assert_eq!(l, Some(Location::Line(6)));
        // A bad value in a skipped field is not read.
        assert!(read_pcd(format!("{head}0 0 0 a\n1 0 0 b\n0 1 0 c\n").as_bytes()).is_ok());
        // Fewer lines than points, in a file long enough for them.
        let (k, l) = err(format!("{head}0.0 0.0 0.0 1.0\n1.0 0.0 0.0 1.0\n\n\n\n\n").as_bytes());
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        assert_eq!(l, Some(Location::Line(11)));
        let (k, _) = err(format!("{head}nan nan nan 1\nnan 0 0 1\n0 nan 0 1\n").as_bytes());
        assert!(
            matches!(k, ErrorKind::Other(ref m) if m.contains("all 3 points")),
            "{k:?}"
        );

        // Binary: an infinite coordinate names the point; a cut file the first missing point.
        let mut points = POINTS;
        points[4] = [1.0, f64::INFINITY, 0.0];
        for data in [PcdData::Binary, PcdData::Compressed] {
            let (k, l) = err(&pcd(&points, None, 6, 1, data));
            assert!(
                matches!(k, ErrorKind::NonFiniteCoordinate),
                "{data:?} {k:?}"
            );
            assert_eq!(l, Some(Location::Point(4)), "{data:?}");
        }
        let b = pcd(&POINTS, None, 6, 1, PcdData::Binary);
        let (k, l) = err(&b[..b.len() - 3]);
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        assert_eq!(l, Some(Location::Point(5)));
    }

    #[test]
    fn compressed_data_errors() {
        let b = pcd(&POINTS, Some(&NORMALS), 6, 1, PcdData::Compressed);
        let data_start = b
            .windows(23)
            .position(|w| w == b"DATA binary_compressed\n")
            .unwrap()
            + 23;
        // Cut in the compressed data, cut in the sizes.
        let (k, _) = err(&b[..b.len() - 1]);
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        let (k, l) = err(&b[..data_start + 6]);
        assert!(matches!(k, ErrorKind::Truncated { .. }), "{k:?}");
        assert_eq!(l, Some(Location::Byte(data_start as u64)));
        // A decompressed size that is not the points' size.
        let mut bad = b.clone();
        bad[data_start + 4] ^= 1;
        let (k, l) = err(&bad);
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("decompresses to")),
            "{k:?}"
        );
        assert_eq!(l, Some(Location::Byte(data_start as u64 + 4)));
        // A corrupt stream: the first control byte made a reference to before the start.
        let mut bad = b.clone();
        bad[data_start + 8] = 0x20;
        let (k, l) = err(&bad);
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("corrupt")),
            "{k:?}"
        );
        assert_eq!(l, Some(Location::Byte(data_start as u64 + 8)));
    }

    #[test]
    fn absurd_counts_are_truncation_without_allocating() {
        for data in ["ascii", "binary"] {
            let text = format!(
                "FIELDS x y z\nWIDTH 1000000\nHEIGHT 1000\nPOINTS 1000000000\nDATA {data}\n0 0 0\n"
            );
            let (k, l) = err(text.as_bytes());
            assert!(matches!(k, ErrorKind::Truncated { .. }), "{data}: {k:?}");
            assert!(matches!(l, Some(Location::Point(_))), "{data}: {l:?}");
        }
        // The compressed sizes agree with the points but not with LZF's limits.
        let mut b = b"FIELDS x y z\nPOINTS 100000000\nDATA binary_compressed\n".to_vec();
        b.extend(4u32.to_le_bytes());
        b.extend(1_200_000_000u32.to_le_bytes());
        b.extend([0, 0, 0, 0]);
        let (k, _) = err(&b);
        assert!(
            matches!(k, ErrorKind::Syntax(ref m) if m.contains("cannot decompress")),
            "{k:?}"
        );
        // Sizes that overflow: COUNT x SIZE, WIDTH x HEIGHT.
        let (k, _) = err(b"FIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 9999999999999999999\nPOINTS 1\nDATA binary\n");
        assert!(matches!(k, ErrorKind::Syntax(_)), "{k:?}");
        let (k, _) = err(b"FIELDS x y z\nWIDTH 99999999999\nHEIGHT 99999999999\nDATA binary\n");
        assert!(matches!(k, ErrorKind::Syntax(_)), "{k:?}");
        // Huge counts and no points: nothing to allocate, nothing read.
        for data in ["ascii", "binary", "binary_compressed"] {
            let text = format!(
                "FIELDS x y z\nCOUNT 1 1 999999999999999\nPOINTS 0\nDATA {data}\n\0\0\0\0\0\0\0\0"
            );
            let e = read_input_from_bytes(text.as_bytes(), Format::Pcd).unwrap_err();
            assert!(matches!(e.kind, ErrorKind::NoVertices), "{data}: {e}");
        }
    }
}
