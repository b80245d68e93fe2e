//! Reads text point clouds: XYZ (`.xyz`) and PTS (`.pts`, Leica and other scanners' export).
//!
//! XYZ layout: one point per line, `x y z` and optionally more columns (normals, colours,
//! intensity, …).
//! - Values are separated by whitespace, commas, or both (`1.5, 2, 3` is three values).
//! - Lines whose first non-blank characters are `#` or `//` are comments; blank lines are
//!   skipped. When the first line that is neither holds no number at all (`x y z`,
//!   `X,Y,Z,Nx,Ny,Nz`), it is taken as column names and skipped with a warning.
//! - The first three values of a line are the point; they must be numbers and finite. Columns
//!   after the third are not checked, except for normals.
//! - Normals: columns 4-6, only when every point line has exactly 6 columns and each of those
//!   triples is a unit vector (length within 10 % of 1). Six columns of colours (`x y z r g b`,
//!   as PTS files often have) are therefore not mistaken for normals; when six columns are found
//!   everywhere but are not all unit vectors, a warning says the normals were ignored.
//!
//! PTS is XYZ with point counts: a line holding a single integer starts a block of that many
//! points (a file holds one block, or one per scan). A block whose point count differs from its
//! count line is a warning, not an error, and counts are never used to allocate, so an absurd
//! count costs nothing. A PTS file without any count line is read as XYZ.
//!
//! Errors name the 1-based line: a value that is not a number, fewer than three values, a NaN or
//! infinite coordinate ([`ErrorKind::NonFiniteCoordinate`]), a file without points.

use super::text::{Lines, is_blank, parse_f64, show, syntax};
use super::{MAX_WARNINGS, Parsed, Raw, RawPoints};
use crate::{ErrorKind, Location, MeshError, Point3, Vector3};

/// Parses the bytes of an XYZ file.
pub(crate) fn read_xyz(bytes: &[u8]) -> Result<Parsed, MeshError> {
    read(bytes, false)
}

/// Parses the bytes of a PTS file.
pub(crate) fn read_pts(bytes: &[u8]) -> Result<Parsed, MeshError> {
    read(bytes, true)
}

/// A normal is taken as one when its length is within this fraction of 1.
const UNIT_TOLERANCE: f64 = 0.1;

/// A PTS block: its count line, the count it declares, the points read so far.
struct Block {
    line: u64,
    declared: u64,
    found: u64,
}

fn read(bytes: &[u8], counts: bool) -> Result<Parsed, MeshError> {
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(MeshError::new(ErrorKind::Empty));
    }
    let mut positions = Vec::new();
    // Normals while every line so far had six columns; None from the first that did not.
    let mut normals: Option<Vec<Vector3<f64>>> = Some(Vec::new());
    let mut not_unit: Option<u64> = None;
    let mut warnings = Vec::new();
    let mut blocks: Vec<Block> = Vec::new();
    let mut first_data = true;
    let mut values: Vec<&[u8]> = Vec::new();
    for (ln, line) in Lines::new(bytes, None) {
        let trimmed = line.trim_ascii_start();
        if is_blank(line) || trimmed.starts_with(b"#") || trimmed.starts_with(b"//") {
            continue;
        }
        values.clear();
        values.extend(
            line.split(|&b| b.is_ascii_whitespace() || b == b',')
                .filter(|t| !t.is_empty()),
        );
        let first = std::mem::take(&mut first_data);
        if first && values.iter().all(|t| parse_f64(t).is_none()) {
            warnings.push(format!(
                "line {ln}: column names '{}' skipped",
                show(line.trim_ascii())
            ));
            continue;
        }
        if counts
            && values.len() == 1
            && let Some(declared) = count(values[0])
        {
            blocks.push(Block {
                line: ln,
                declared,
                found: 0,
            });
            continue;
        }
        let mut xyz = [0.0; 3];
        for (k, c) in xyz.iter_mut().enumerate() {
            let Some(t) = values.get(k) else {
                return Err(syntax(
                    ln,
                    format!(
                        "a point needs 3 coordinates (x y z) but this line has {}",
                        values.len()
                    ),
                ));
            };
            *c = parse_f64(t)
                .ok_or_else(|| syntax(ln, format!("coordinate '{}' is not a number", show(t))))?;
            if !c.is_finite() {
                return Err(MeshError::new(ErrorKind::NonFiniteCoordinate).at(Location::Line(ln)));
            }
        }
        positions.push(Point3::from(xyz));
        if let Some(b) = blocks.last_mut() {
            b.found += 1;
        }
        if let Some(ns) = &mut normals {
            if values.len() == 6 {
                let n = Vector3::from([3, 4, 5].map(|k| parse_f64(values[k]).unwrap_or(f64::NAN)));
                // NaN compares false: not a unit vector either
                let unit = (n.norm() - 1.0).abs() <= UNIT_TOLERANCE;
                if not_unit.is_none() && !unit {
                    not_unit = Some(ln);
                }
                ns.push(n);
            } else {
                normals = None;
            }
        }
    }
    if positions.is_empty() {
        return Err(MeshError::new(ErrorKind::NoVertices));
    }
    if let (Some(_), Some(ln)) = (&normals, not_unit) {
        warnings.push(format!(
            "line {ln}: columns 4-6 are not a unit vector (colours?): no normals read"
        ));
        normals = None;
    }
    let wrong: Vec<&Block> = blocks.iter().filter(|b| b.declared != b.found).collect();
    for b in wrong.iter().take(MAX_WARNINGS) {
        warnings.push(format!(
            "line {}: the point count says {} points but {} follow",
            b.line, b.declared, b.found
        ));
    }
    if wrong.len() > MAX_WARNINGS {
        warnings.push(format!(
            "{} more point counts disagree with their points",
            wrong.len() - MAX_WARNINGS
        ));
    }
    Ok(Parsed {
        raw: Raw::Points(RawPoints { positions, normals }),
        warnings,
    })
}

/// A PTS count: a non-negative integer without sign or decimal point.
fn count(token: &[u8]) -> Option<u64> {
    if token.iter().all(u8::is_ascii_digit) {
        std::str::from_utf8(token).ok()?.parse().ok()
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points(text: &str, pts: bool) -> (RawPoints, Vec<String>) {
        let p = read(text.as_bytes(), pts).unwrap_or_else(|e| panic!("{e}"));
        match p.raw {
            Raw::Points(r) => (r, p.warnings),
            other => panic!("{other:?}"),
        }
    }

    fn err(text: &str, pts: bool) -> (ErrorKind, Option<Location>) {
        let e = read(text.as_bytes(), pts).unwrap_err();
        (e.kind, e.location)
    }

    #[test]
    fn separators_comments_and_columns() {
        let text = "# scan\n// exported\n\n1 2 3\n4,5,6\n 7 ,\t8, 9 255 0 0 0.5\r\n-1e-3 +2 3.\n";
        let (p, w) = points(text, false);
        assert_eq!(
            p.positions,
            vec![
                Point3::new(1.0, 2.0, 3.0),
                Point3::new(4.0, 5.0, 6.0),
                Point3::new(7.0, 8.0, 9.0),
                Point3::new(-1e-3, 2.0, 3.0),
            ]
        );
        assert_eq!(p.normals, None);
        assert!(w.is_empty(), "{w:?}");
    }

    #[test]
    fn normals_only_from_six_columns_of_unit_vectors() {
        let (p, w) = points("0 0 0 0 0 1\n1 0 0 0.6 0.8 0\n", false);
        assert_eq!(
            p.normals,
            Some(vec![
                Vector3::new(0.0, 0.0, 1.0),
                Vector3::new(0.6, 0.8, 0.0)
            ])
        );
        assert!(w.is_empty());
        // One line with seven columns: no normals, no warning.
        let (p, w) = points("0 0 0 0 0 1\n1 0 0 0 0 1 7\n", false);
        assert_eq!(p.normals, None);
        assert!(w.is_empty());
        // Colours in six columns: no normals, with a warning naming the first line.
        let (p, w) = points("0 0 0 255 0 0\n1 0 0 0 255 0\n", false);
        assert_eq!(p.normals, None);
        assert_eq!(w.len(), 1);
        assert!(w[0].starts_with("line 1: columns 4-6"), "{w:?}");
        // Non-numeric columns 4-6: no normals.
        let (p, w) = points("0 0 0 0 0 1\n0 0 0 a b c\n", false);
        assert_eq!(p.normals, None);
        assert!(w[0].starts_with("line 2: columns 4-6"), "{w:?}");
    }

    #[test]
    fn a_header_line_of_column_names_is_skipped() {
        let (p, w) = points("X,Y,Z,Nx,Ny,Nz\n1,2,3,0,0,1\n", false);
        assert_eq!(p.positions, vec![Point3::new(1.0, 2.0, 3.0)]);
        assert!(p.normals.is_some());
        assert_eq!(w, vec!["line 1: column names 'X,Y,Z,Nx,Ny,Nz' skipped"]);
        // Only the first data line can be names.
        assert!(matches!(
            err("1 2 3\nx y z\n", false),
            (ErrorKind::Syntax(_), Some(Location::Line(2)))
        ));
    }

    #[test]
    fn pts_counts_are_checked_as_warnings() {
        let (p, w) = points("3\n0 0 0 10 1 2 3\n1 0 0 10 1 2 3\n0 1 0 10 1 2 3\n", true);
        assert_eq!(p.positions.len(), 3);
        assert!(w.is_empty(), "{w:?}");
        let (p, w) = points("2\n0 0 0\n1 0 0\n0 1 0\n1\n5 5 5\n", true);
        assert_eq!(p.positions.len(), 4);
        assert_eq!(
            w,
            vec!["line 1: the point count says 2 points but 3 follow"]
        );
        // An absurd count allocates nothing: a warning.
        let (p, w) = points("99999999999999999\n0 0 0\n", true);
        assert_eq!(p.positions.len(), 1);
        assert_eq!(w.len(), 1);
        // No count line: read as XYZ.
        let (p, w) = points("0 0 0\n", true);
        assert_eq!(p.positions.len(), 1);
        assert!(w.is_empty());
        // In XYZ a lone integer is a line with too few values.
        assert!(matches!(
            err("3\n0 0 0\n", false),
            (ErrorKind::Syntax(_), Some(Location::Line(1)))
        ));
    }

    #[test]
    fn errors_name_the_line() {
        for pts in [false, true] {
            let (k, l) = err("0 0 0\n1 0\n", pts);
            assert!(
                matches!(k, ErrorKind::Syntax(ref m) if m.contains("has 2")),
                "{k:?}"
            );
            assert_eq!(l, Some(Location::Line(2)));
            let (k, l) = err("0 0 0\n# c\n1 zero 0\n", pts);
            assert!(
                matches!(k, ErrorKind::Syntax(ref m) if m.contains("'zero'")),
                "{k:?}"
            );
            assert_eq!(l, Some(Location::Line(3)));
            for bad in ["nan", "NaN", "inf", "-inf", "1e999"] {
                let (k, l) = err(&format!("0 0 0\n1 {bad} 0\n"), pts);
                assert!(matches!(k, ErrorKind::NonFiniteCoordinate), "{bad} {k:?}");
                assert_eq!(l, Some(Location::Line(2)));
            }
            assert!(matches!(err("", pts).0, ErrorKind::Empty));
            assert!(matches!(err(" \n\n", pts).0, ErrorKind::Empty));
            assert!(matches!(
                err("# only a comment\n", pts).0,
                ErrorKind::NoVertices
            ));
        }
        assert!(matches!(err("5\n", true).0, ErrorKind::NoVertices));
    }
}
