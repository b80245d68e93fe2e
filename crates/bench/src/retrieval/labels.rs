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
    /// A malformed line of a ground-truth file.
    #[error("{}:{line}: expected 'query,source' or 'query,source,class', found '{text}'", path.display())]
    BadTruthLine {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The line.
        text: String,
    },
    /// A name in a ground-truth file that no file (or more than one) answers to.
    #[error("{}:{line}: {what}", path.display())]
    Unresolved {
        /// The ground-truth file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong with the name.
        what: String,
    },
    /// A ground-truth file without any query.
    #[error("{}: no query (expected lines 'query,source[,class]')", path.display())]
    NoTruth {
        /// The file.
        path: PathBuf,
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
    let text = read_csv(csv)?;
    let mut map: HashMap<String, String> = HashMap::new();
    for (i, t) in data_lines(&text, |t| t.eq_ignore_ascii_case("file,class")) {
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
            names_of(f, root)
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

/// One external query and what it should find ([`truth_from_csv`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Truth {
    /// The query file.
    pub query: PathBuf,
    /// Its source: an index into the collection's files.
    pub source: usize,
    /// Its class, when the file gives one (otherwise the source's).
    pub class: Option<String>,
}

/// The names a file answers to: its path relative to `root`, its file name and its stem.
fn names_of(f: &Path, root: &Path) -> [String; 3] {
    let rel = f
        .strip_prefix(root)
        .map(|r| r.to_string_lossy().into_owned())
        .unwrap_or_default();
    let file_name = f
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    [rel, file_name, stem(f)]
}

/// The files answering to each name, by kind of name ([`names_of`]), built once per list.
struct Names(Vec<HashMap<String, Vec<usize>>>);

impl Names {
    fn new(files: &[PathBuf], root: &Path) -> Names {
        let mut by_kind = vec![HashMap::<String, Vec<usize>>::new(); 3];
        for (i, f) in files.iter().enumerate() {
            for (k, name) in names_of(f, root).into_iter().enumerate() {
                if !name.is_empty() {
                    by_kind[k].entry(name).or_default().push(i);
                }
            }
        }
        Names(by_kind)
    }

    /// The files (indices) that `name` names: the most specific kind of name (relative path,
    /// file name, stem) that any file answers to decides.
    fn resolve(&self, name: &str) -> &[usize] {
        self.0
            .iter()
            .find_map(|m| m.get(name))
            .map_or(&[], Vec::as_slice)
    }
}

/// The text of a CSV file.
fn read_csv(csv: &Path) -> Result<String, LabelError> {
    keycomp_mesh::io::output::read_input_text(csv).map_err(|source| LabelError::Io {
        path: csv.to_path_buf(),
        source,
    })
}

/// The lines of a CSV text that hold data, with their 0-based numbers, trimmed: blank lines,
/// lines starting with `#` and a first line that `header` accepts are skipped.
fn data_lines<'a>(
    text: &'a str,
    header: impl Fn(&str) -> bool + 'a,
) -> impl Iterator<Item = (usize, &'a str)> + 'a {
    text.lines()
        .map(str::trim)
        .enumerate()
        .filter(move |&(i, t)| !(t.is_empty() || t.starts_with('#') || (i == 0 && header(t))))
}

/// External queries and their ground truth from a CSV file of `query,source[,class]` lines
/// (blank lines and lines starting with `#` are skipped, as is a first line starting with
/// `query,`). `query` names a file of `queries` by its path relative to `query_root`, file name
/// or stem; `source` names a collection file of `files` the same way relative to `root`; the
/// optional class overrides the source's. Each line is one query, in the file's order.
///
/// Errors: [`LabelError::Io`], [`LabelError::BadTruthLine`], [`LabelError::Unresolved`] (a name
/// no file or several files answer to), [`LabelError::NoTruth`].
pub fn truth_from_csv(
    queries: &[PathBuf],
    query_root: &Path,
    files: &[PathBuf],
    root: &Path,
    csv: &Path,
) -> Result<Vec<Truth>, LabelError> {
    let text = read_csv(csv)?;
    let (query_names, file_names) = (Names::new(queries, query_root), Names::new(files, root));
    let mut out = Vec::new();
    for (i, t) in data_lines(&text, |t| t.starts_with("query,")) {
        let fields: Vec<&str> = t.split(',').map(str::trim).collect();
        if !(2..=3).contains(&fields.len()) || fields.iter().any(|f| f.is_empty()) {
            return Err(LabelError::BadTruthLine {
                path: csv.to_path_buf(),
                line: i + 1,
                text: t.to_string(),
            });
        }
        let one = |name: &str, names: &Names, among: &[PathBuf], root: &Path, what: &str| {
            let unresolved = |w: String| LabelError::Unresolved {
                path: csv.to_path_buf(),
                line: i + 1,
                what: w,
            };
            match *names.resolve(name) {
                [f] => Ok(f),
                [] => Err(unresolved(format!(
                    "no {what} named '{name}' under {} (name it by file name, stem or path \
                     relative to the folder)",
                    root.display()
                ))),
                [a, b, ..] => Err(unresolved(format!(
                    "'{name}' names more than one {what} ({} and {}): give the path relative \
                     to {}",
                    among[a].display(),
                    among[b].display(),
                    root.display()
                ))),
            }
        };
        let query = one(fields[0], &query_names, queries, query_root, "query file")?;
        let source = one(fields[1], &file_names, files, root, "collection file")?;
        out.push(Truth {
            query: queries[query].clone(),
            source,
            class: fields.get(2).map(|c| c.to_string()),
        });
    }
    if out.is_empty() {
        return Err(LabelError::NoTruth {
            path: csv.to_path_buf(),
        });
    }
    Ok(out)
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

    #[test]
    fn truth_names_queries_and_sources_or_says_why_not() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("truth.csv");
        let root = Path::new("/c");
        let files = vec![
            root.join("bunny.ply"),
            root.join("sub/cat.off"),
            root.join("dog.off"),
        ];
        let qroot = Path::new("/q");
        let queries = vec![
            qroot.join("scan1.ply"),
            qroot.join("scan1.xyz"),
            qroot.join("b/cat-half.off"),
        ];
        let truth = |text: &str| {
            std::fs::write(&csv, text).unwrap();
            truth_from_csv(&queries, qroot, &files, root, &csv)
        };
        let t = truth("query,source,class\n# c\nscan1.ply,bunny\nscan1.xyz, bunny.ply ,rabbit\ncat-half,sub/cat.off\n")
            .unwrap();
        assert_eq!(
            t,
            vec![
                Truth {
                    query: queries[0].clone(),
                    source: 0,
                    class: None
                },
                Truth {
                    query: queries[1].clone(),
                    source: 0,
                    class: Some("rabbit".into())
                },
                Truth {
                    query: queries[2].clone(),
                    source: 1,
                    class: None
                },
            ]
        );
        // a stem two query files share is ambiguous; unknown names and bad lines are refused
        for (text, needle) in [
            ("scan1,bunny\n", "more than one query file"),
            ("scan2.ply,bunny\n", "no query file named 'scan2.ply'"),
            ("scan1.ply,horse\n", "no collection file named 'horse'"),
            ("scan1.ply\n", ":1: expected 'query,source'"),
            ("scan1.ply,bunny,a,b\n", ":1: expected"),
            ("scan1.ply,,x\n", ":1: expected"),
            ("# nothing\n", "no query"),
        ] {
            let e = truth(text).unwrap_err().to_string();
            assert!(e.contains(needle), "{text:?}: {e}");
            assert!(e.contains("truth.csv"), "{e}");
        }
    }
}
