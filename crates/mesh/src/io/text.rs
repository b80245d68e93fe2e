//! Helpers shared by the text readers (OFF, OBJ, ascii STL): numbered lines and whitespace
//! tokens over a byte buffer, and number parsing without allocating.
//!
//! Conventions: lines are split at `\n` (a trailing `\r` is removed), numbered from 1; a comment
//! character, when given, removes everything from it to the end of the line. Tokens are runs of
//! non-whitespace bytes. Numbers are parsed from the token bytes in place; a token that is not
//! valid UTF-8 is simply not a number.

use crate::{ErrorKind, Location, MeshError};

/// Iterator over `(line number, line content)`, comments removed, blank lines kept (callers
/// skip them with [`is_blank`]).
pub(crate) struct Lines<'a> {
    rest: &'a [u8],
    line: u64,
    comment: Option<u8>,
    done: bool,
}

impl<'a> Lines<'a> {
    /// Lines of `bytes`; `comment` starts a comment that runs to the end of the line.
    pub(crate) fn new(bytes: &'a [u8], comment: Option<u8>) -> Self {
        Lines {
            rest: bytes,
            line: 0,
            comment,
            done: bytes.is_empty(),
        }
    }

    /// The number of the last line returned (0 before the first). After the iterator is
    /// exhausted this is the file's last line.
    pub(crate) fn line(&self) -> u64 {
        self.line
    }

    /// The next line that is not blank (after comment removal), or `None` at the end.
    pub(crate) fn next_nonblank(&mut self) -> Option<(u64, &'a [u8])> {
        self.find(|(_, l)| !is_blank(l))
    }
}

impl<'a> Iterator for Lines<'a> {
    type Item = (u64, &'a [u8]);

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let (mut line, rest) = match self.rest.iter().position(|&b| b == b'\n') {
            Some(i) => (&self.rest[..i], &self.rest[i + 1..]),
            None => {
                self.done = true;
                (self.rest, &self.rest[self.rest.len()..])
            }
        };
        if rest.is_empty() {
            // A final newline does not start another line.
            self.done = true;
        }
        self.rest = rest;
        self.line += 1;
        if let Some(&b'\r') = line.last() {
            line = &line[..line.len() - 1];
        }
        if let Some(c) = self.comment
            && let Some(i) = line.iter().position(|&b| b == c)
        {
            line = &line[..i];
        }
        Some((self.line, line))
    }
}

/// True when the line holds only whitespace.
pub(crate) fn is_blank(line: &[u8]) -> bool {
    line.iter().all(|b| b.is_ascii_whitespace())
}

/// The whitespace-separated tokens of a line.
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

/// A token shown in an error message (lossy, shortened).
pub(crate) fn show(token: &[u8]) -> String {
    const MAX: usize = 40;
    let s = String::from_utf8_lossy(token);
    if s.chars().count() > MAX {
        let short: String = s.chars().take(MAX).collect();
        format!("{short}…")
    } else {
        s.into_owned()
    }
}

/// Parses a floating-point token (Rust syntax, which includes `nan` and `inf`).
pub(crate) fn parse_f64(token: &[u8]) -> Option<f64> {
    std::str::from_utf8(token).ok()?.parse().ok()
}

/// Parses an integer token with an optional sign; `None` if it is not an integer or does not
/// fit in an `i64`.
pub(crate) fn parse_i64(token: &[u8]) -> Option<i64> {
    std::str::from_utf8(token).ok()?.parse().ok()
}

/// Reads three coordinates from `tokens` (more are ignored), with errors at `line`: fewer than
/// three, a token that is not a number, or a non-finite value.
pub(crate) fn parse_xyz<'a>(
    mut tokens: impl Iterator<Item = &'a [u8]>,
    line: u64,
    what: &str,
) -> Result<[f64; 3], MeshError> {
    let mut xyz = [0.0; 3];
    for (k, c) in xyz.iter_mut().enumerate() {
        let Some(t) = tokens.next() else {
            return Err(syntax(
                line,
                format!("{what} needs 3 coordinates but has only {k}"),
            ));
        };
        *c = parse_f64(t).ok_or_else(|| {
            syntax(
                line,
                format!("{what}: coordinate '{}' is not a number", show(t)),
            )
        })?;
        if !c.is_finite() {
            return Err(MeshError::new(ErrorKind::NonFiniteCoordinate).at(Location::Line(line)));
        }
    }
    Ok(xyz)
}

/// A syntax error at a line.
pub(crate) fn syntax(line: u64, message: String) -> MeshError {
    MeshError::new(ErrorKind::Syntax(message)).at(Location::Line(line))
}

/// Upper bound for preallocating `declared` items of at least `min_bytes` bytes each from a
/// buffer of `available` bytes: headers can declare absurd counts.
pub(crate) fn capped(declared: u64, available: usize, min_bytes: usize) -> usize {
    let fit = available / min_bytes.max(1);
    usize::try_from(declared).unwrap_or(usize::MAX).min(fit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_numbered_and_stripped() {
        let text = b"a # c\r\n\nb\n";
        let v: Vec<_> = Lines::new(text, Some(b'#')).collect();
        assert_eq!(v, vec![(1, &b"a "[..]), (2, &b""[..]), (3, &b"b"[..])]);
        let v: Vec<_> = Lines::new(b"x\ny", None).collect();
        assert_eq!(v, vec![(1, &b"x"[..]), (2, &b"y"[..])]);
        assert_eq!(Lines::new(b"", None).count(), 0);
    }

    #[test]
    fn numbers() {
        assert_eq!(parse_f64(b"1e3"), Some(1000.0));
        assert!(parse_f64(b"nan").is_some_and(f64::is_nan));
        assert_eq!(parse_f64(b"x"), None);
        assert_eq!(parse_i64(b"-3"), Some(-3));
        assert_eq!(parse_i64(b"99999999999999999999"), None);
        assert_eq!(parse_i64(b"1.5"), None);
        assert_eq!(capped(1_000_000_000_000, 100, 2), 50);
        assert_eq!(capped(3, 100, 2), 3);
    }
}
