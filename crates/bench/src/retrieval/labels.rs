//! Class labels of a collection's shapes: from the file names by a regular expression, or from
//! a CSV file.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use regex::Regex;

/// The default of `--class-from-name`: the file stem's leading run of non-digits (`cat` from
/// `cat3.off`, `centaur` from `centaur0.off`).
pub const DEFAULT_CLASS_REGEX: &str = r"^(\D+)";

/// Why labels cannot be assigned.
#[derive(Debug, thiserror::Error)]
pub enum LabelError {
    /// The regular expression does not compile.
    #[error("--class-from-name: invalid regular expression '{pattern}': {message}")]
    BadRegex {
        /// The pattern.
        pattern: String,
        /// The compiler's message.
        message: String,
    },
    /// A file name the expression does not match.
    #[error(
        "--class-from-name: '{pattern}' does not match the file name '{name}' (it is applied to \
         the file stem; its first capture group, or the whole match, is the class)"
    )]
    NoMatch {
        /// The pattern.
        pattern: String,
        /// The file stem.
        name: String,
    },
    /// The labels file cannot be read.
    #[error("{}: cannot read the labels file: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// A malformed line of the labels file.
    #[error("{}:{line}: expected 'file,class', found '{text}'", path.display())]
    BadLine {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The line.
        text: String,
    },
    /// A collection file the labels file does not name.
    #[error(
        "{}: no class for '{name}' (name it by file name, stem or path relative to the collection)",
        path.display()
    )]
    Missing {
        /// The labels file.
        path: PathBuf,
        /// The collection file.
        name: String,
    },
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The class of each file: `pattern` is searched in the file stem; the first capture group (or
/// the whole match when the pattern has none) is the class.
///
/// Errors: [`LabelError::BadRegex`], [`LabelError::NoMatch`] naming the first file that does
/// not match.
pub fn classes_from_names(files: &[PathBuf], pattern: &str) -> Result<Vec<String>, LabelError> {
    let re = Regex::new(pattern).map_err(|e| LabelError::BadRegex {
        pattern: pattern.to_string(),
        message: e.to_string(),
    })?;
    files
        .iter()
        .map(|f| {
            let name = stem(f);
            re.captures(&name)
                .and_then(|c| c.get(1).or_else(|| c.get(0)))
                .map(|m| m.as_str().to_string())
                .ok_or_else(|| LabelError::NoMatch {
                    pattern: pattern.to_string(),
                    name: name.clone(),
                })
        })
        .collect()
}

/// The class of each file from a CSV file of `file,class` lines (blank lines and lines starting
/// with `#` are skipped, as is a first line `file,class`). `file` may be the file name, its stem
/// or its path relative to `root`. Every file must be named.
///
/// Errors: [`LabelError::Io`], [`LabelError::BadLine`], [`LabelError::Missing`].
pub fn classes_from_csv(
    files: &[PathBuf],
    root: &Path,
    csv: &Path,
) -> Result<Vec<String>, LabelError> {
    let text = keycomp_mesh::io::output::read_input_text(csv).map_err(|source| LabelError::Io {
        path: csv.to_path_buf(),
        source,
    })?;
    let mut map: HashMap<String, String> = HashMap::new();
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') || (i == 0 && t.eq_ignore_ascii_case("file,class")) {
            continue;
        }
        let bad = || LabelError::BadLine {
            path: csv.to_path_buf(),
            line: i + 1,
            text: t.to_string(),
        };
        let (name, class) = t.split_once(',').ok_or_else(bad)?;
        let (name, class) = (name.trim(), class.trim());
        if name.is_empty() || class.is_empty() {
            return Err(bad());
        }
        map.insert(name.to_string(), class.to_string());
    }
    files
        .iter()
        .map(|f| {
            let rel = f
                .strip_prefix(root)
                .map(|r| r.to_string_lossy().into_owned())
                .unwrap_or_default();
            let file_name = f
                .file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            [rel, file_name, stem(f)]
                .iter()
                .find_map(|k| map.get(k))
                .cloned()
                .ok_or_else(|| LabelError::Missing {
                    path: csv.to_path_buf(),
                    name: f.display().to_string(),
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn files(names: &[&str]) -> Vec<PathBuf> {
        names.iter().map(|n| Path::new("/c").join(n)).collect()
    }

    #[test]
    fn default_regex_takes_the_name_prefix() {
        let f = files(&["cat3.off", "centaur0.off", "wolf12.ply"]);
        let c = classes_from_names(&f, DEFAULT_CLASS_REGEX).unwrap();
        assert_eq!(c, ["cat", "centaur", "wolf"]);
    }

    #[test]
    fn faust_subject_and_pose() {
        let f = files(&["tr_reg_000.ply", "tr_reg_047.ply", "tr_reg_099.ply"]);
        let subject = classes_from_names(&f, r"tr_reg_\d(\d)\d").unwrap();
        assert_eq!(subject, ["0", "4", "9"]);
        let pose = classes_from_names(&f, r"tr_reg_\d\d(\d)").unwrap();
        assert_eq!(pose, ["0", "7", "9"]);
        // no group: the whole match
        assert_eq!(classes_from_names(&f, r"reg").unwrap(), ["reg"; 3]);
    }

    #[test]
    fn regex_errors_name_the_problem() {
        let f = files(&["cat3.off", "123.off"]);
        let e = classes_from_names(&f, r"^(\D+)").unwrap_err();
        assert!(e.to_string().contains("'123'"), "{e}");
        let e = classes_from_names(&f, r"(").unwrap_err();
        assert!(matches!(e, LabelError::BadRegex { .. }), "{e}");
    }

    #[test]
    fn csv_by_name_stem_or_relative_path() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("labels.csv");
        std::fs::write(
            &csv,
            "file,class\n# comment\n\na.off, x\nb,y\nsub/c.ply,z\n",
        )
        .unwrap();
        let root = Path::new("/c");
        let f = vec![
            root.join("a.off"),
            root.join("b.off"),
            root.join("sub/c.ply"),
        ];
        assert_eq!(classes_from_csv(&f, root, &csv).unwrap(), ["x", "y", "z"]);
        let missing = vec![root.join("d.off")];
        let e = classes_from_csv(&missing, root, &csv).unwrap_err();
        assert!(e.to_string().contains("d.off"), "{e}");
        std::fs::write(&csv, "a.off x\n").unwrap();
        let e = classes_from_csv(&f, root, &csv).unwrap_err();
        assert!(e.to_string().contains(":1:"), "{e}");
        let e = classes_from_csv(&f, root, &dir.path().join("none.csv")).unwrap_err();
        assert!(e.to_string().contains("none.csv"), "{e}");
    }
}
