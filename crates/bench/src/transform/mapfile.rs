//! The correspondence file: a text file with one line per transformed vertex holding the null
//! vertex id it maps to, or `-1` when it has none.
//!
//! ```text
//! # keycomp-map v1 transformed=3 null=5
//! 4
//! -1
//! 0
//! ```
//!
//! The header is mandatory and comes first. Blank lines and further lines starting with `#` are
//! ignored; surrounding whitespace and CRLF line ends are accepted. Reading checks the version,
//! the entry count against `transformed=` and every id against `null=`, and reports the path
//! and 1-based line of any problem. Writing goes through [`keycomp_mesh::io::output`]: to a
//! temporary file in the same directory, synced, then renamed over the destination, so a reader
//! never sees a partial file.

use std::path::Path;

use keycomp_mesh::VertexId;

use crate::error::BenchError;

/// The current format version.
pub const MAP_VERSION: u32 = 1;
const MAGIC: &str = "keycomp-map";

/// A correspondence read from a file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MapFile {
    /// For each transformed vertex, its null vertex (`None` for `-1`).
    pub map: Vec<Option<VertexId>>,
    /// The null shape's vertex count from the header; every id is below it.
    pub null_vertices: usize,
}

/// Writes `map` (for a null shape of `null_vertices` vertices) to `path` atomically.
///
/// Errors: [`BenchError::MapOutOfRange`] if an id is not below `null_vertices` (nothing is
/// written), [`BenchError::Io`].
pub fn write_map(
    map: &[Option<VertexId>],
    null_vertices: usize,
    path: &Path,
) -> Result<(), BenchError> {
    let text = format_map(map, null_vertices)?;
    keycomp_mesh::io::output::write_file(path, |w| w.write_all(text.as_bytes())).map_err(|source| {
        BenchError::Io {
            path: path.to_path_buf(),
            source,
        }
    })
}

/// The text of the correspondence file of `map` (as [`write_map`] writes it), for callers that
/// manage the file.
///
/// Errors: [`BenchError::MapOutOfRange`] if an id is not below `null_vertices`.
pub fn format_map(map: &[Option<VertexId>], null_vertices: usize) -> Result<String, BenchError> {
    if let Some((index, target)) = map
        .iter()
        .enumerate()
        .find_map(|(i, m)| m.filter(|&t| t as usize >= null_vertices).map(|t| (i, t)))
    {
        return Err(BenchError::MapOutOfRange {
            index,
            target,
            null_vertices,
        });
    }
    let mut text = format!(
        "# {MAGIC} v{MAP_VERSION} transformed={} null={null_vertices}\n",
        map.len()
    );
    for m in map {
        match m {
            Some(t) => {
                text.push_str(&t.to_string());
                text.push('\n');
            }
            None => text.push_str("-1\n"),
        }
    }
    Ok(text)
}

/// Reads a correspondence file written by [`write_map`].
///
/// Errors: [`BenchError::Io`]; [`BenchError::MapFormat`] with the line for a missing or wrong
/// header, an unsupported version, a token that is not an id or `-1`, an id not below `null=`,
/// or an entry count different from `transformed=`.
pub fn read_map(path: &Path) -> Result<MapFile, BenchError> {
    let text =
        keycomp_mesh::io::output::read_input_text(path).map_err(|source| BenchError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    parse_map(&text, path)
}

/// Parses the text of a correspondence file (see [`read_map`]); `path` only names it in errors.
pub fn parse_map(text: &str, path: &Path) -> Result<MapFile, BenchError> {
    let err = |line: usize, message: String| BenchError::MapFormat {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
    let (hline, header) = lines.next().ok_or_else(|| {
        err(
            1,
            "the file is empty; expected a '# keycomp-map v1 …' header".into(),
        )
    })?;
    let (transformed, null_vertices) = parse_header(header).map_err(|m| err(hline, m))?;
    let mut map = Vec::with_capacity(transformed.min(1 << 24));
    let mut last = hline;
    for (ln, line) in lines {
        last = ln;
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        if map.len() == transformed {
            return Err(err(
                ln,
                format!("more entries than the {transformed} the header declares"),
            ));
        }
        let entry = if line == "-1" {
            None
        } else {
            let id: u64 = line.parse().map_err(|_| {
                err(
                    ln,
                    format!("'{line}' is not a vertex id (a non-negative integer) or -1"),
                )
            })?;
            if id >= null_vertices as u64 {
                return Err(err(
                    ln,
                    format!(
                        "null vertex id {id} is out of range: the header says the null shape has \
                         {null_vertices} vertices"
                    ),
                ));
            }
            Some(id as VertexId)
        };
        map.push(entry);
    }
    if map.len() != transformed {
        return Err(err(
            last + 1,
            format!(
                "the file ends after {} entries but the header declares {transformed}: the file \
                 is truncated",
                map.len()
            ),
        ));
    }
    Ok(MapFile { map, null_vertices })
}

/// Parses `# keycomp-map v1 transformed=N null=M`.
fn parse_header(line: &str) -> Result<(usize, usize), String> {
    let expected = format!("expected a header '# {MAGIC} v{MAP_VERSION} transformed=N null=M'");
    let mut tokens = line.split_whitespace();
    if tokens.next() != Some("#") || tokens.next() != Some(MAGIC) {
        return Err(format!("not a keycomp correspondence file: {expected}"));
    }
    let version = tokens
        .next()
        .and_then(|t| t.strip_prefix('v'))
        .and_then(|t| t.parse::<u32>().ok())
        .ok_or_else(|| format!("missing format version: {expected}"))?;
    if version != MAP_VERSION {
        return Err(format!(
            "unsupported format version v{version}: this build reads v{MAP_VERSION}; regenerate \
             the file with this version of keycomp"
        ));
    }
    let (mut transformed, mut null) = (None, None);
    for t in tokens {
        let (key, value) = t
            .split_once('=')
            .ok_or_else(|| format!("unexpected '{t}' in the header: {expected}"))?;
        let value: usize = value
            .parse()
            .map_err(|_| format!("'{t}': the value is not a count: {expected}"))?;
        match key {
            "transformed" => transformed = Some(value),
            "null" => null = Some(value),
            _ => return Err(format!("unknown header field '{key}': {expected}")),
        }
    }
    match (transformed, null) {
        (Some(t), Some(n)) => Ok((t, n)),
        _ => Err(format!(
            "the header lacks transformed= or null=: {expected}"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.map");
        let map = vec![Some(4), None, Some(0), Some(2)];
        write_map(&map, 5, &path).unwrap();
        let text = fs::read_to_string(&path).unwrap();
        assert_eq!(text, "# keycomp-map v1 transformed=4 null=5\n4\n-1\n0\n2\n");
        let back = read_map(&path).unwrap();
        assert_eq!(back.map, map);
        assert_eq!(back.null_vertices, 5);
        // overwriting works and leaves no temporary file behind
        write_map(&map[..2], 5, &path).unwrap();
        assert_eq!(read_map(&path).unwrap().map, &map[..2]);
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn empty_map_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("e.map");
        write_map(&[], 0, &path).unwrap();
        assert_eq!(read_map(&path).unwrap().map, vec![]);
    }

    #[test]
    fn tolerant_of_crlf_blank_lines_and_comments() {
        let text = "# keycomp-map v1 transformed=2 null=3\r\n\r\n# a note\r\n 2 \r\n-1\r\n\r\n";
        let m = parse_map(text, Path::new("x.map")).unwrap();
        assert_eq!(m.map, vec![Some(2), None]);
    }

    fn error_of(text: &str) -> (usize, String) {
        match parse_map(text, Path::new("bad.map")) {
            Err(e @ BenchError::MapFormat { line, .. }) => {
                let msg = e.to_string();
                assert!(msg.starts_with("bad.map: line "), "{msg}");
                (line, msg)
            }
            other => panic!("expected a format error, got {other:?}"),
        }
    }

    #[test]
    fn malformed_files_name_the_line() {
        let h = "# keycomp-map v1 transformed=2 null=3\n";
        assert_eq!(error_of("").0, 1);
        assert!(
            error_of("3\n")
                .1
                .contains("not a keycomp correspondence file")
        );
        assert!(
            error_of("# keycomp-map v2 transformed=1 null=1\n0\n")
                .1
                .contains("v2")
        );
        assert!(
            error_of("# keycomp-map v1 null=1\n")
                .1
                .contains("transformed=")
        );
        assert!(
            error_of("# keycomp-map v1 transformed=x null=1\n")
                .1
                .contains("not a count")
        );
        let (line, msg) = error_of(&format!("{h}1\nabc\n"));
        assert_eq!(line, 3);
        assert!(msg.contains("'abc'"));
        let (line, msg) = error_of(&format!("{h}1\n3\n"));
        assert_eq!(line, 3);
        assert!(msg.contains("out of range"));
        assert_eq!(error_of(&format!("{h}-2\n0\n")).0, 2);
        let (line, msg) = error_of(&format!("{h}1\n"));
        assert_eq!(line, 3);
        assert!(msg.contains("truncated"));
        assert_eq!(error_of(&format!("{h}1\n2\n0\n")).0, 4);
    }

    #[test]
    fn write_refuses_out_of_range_ids_and_reports_io_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.map");
        assert!(matches!(
            write_map(&[Some(0), Some(7)], 5, &path),
            Err(BenchError::MapOutOfRange {
                index: 1,
                target: 7,
                ..
            })
        ));
        assert!(!path.exists());
        let missing = dir.path().join("no/such/dir/a.map");
        let e = write_map(&[Some(0)], 5, &missing).unwrap_err();
        assert!(matches!(e, BenchError::Io { .. }));
        assert!(e.to_string().contains("a.map"));
        assert!(matches!(read_map(&missing), Err(BenchError::Io { .. })));
    }
}
