//! The folder rule of every output: keycomp creates the folder it is told to fill (an index,
//! a report, a benchmark's output) but never the folders above it, and checks that it can
//! before doing any work. A folder that is rebuilt whole (a report, a benchmark's fresh index)
//! is replaced by [`replace_folder`]: built beside it, then swapped in, so a failure leaves the
//! previous one as it was. Files are written atomically by [`keycomp_mesh::io::output`].

use std::path::{Path, PathBuf};

use crate::Error;

/// Creates the output folder `dir` if it does not exist. Its parent must exist: keycomp
/// creates the folder it is given, never the folders above it.
pub fn create_output_folder(dir: &Path) -> Result<(), Error> {
    check_output_folder(dir)?;
    if dir.is_dir() {
        return Ok(());
    }
    std::fs::create_dir(dir).map_err(|e| Error::Path {
        path: dir.to_path_buf(),
        reason: format!("cannot create the folder: {e}"),
    })
}

/// Checks, before any work, that the folder `dir` exists or can be created by
/// [`create_output_folder`] (its parent exists, nothing else is in its place).
pub fn check_output_folder(dir: &Path) -> Result<(), Error> {
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(_) => Err(Error::Path {
            path: dir.to_path_buf(),
            reason: "exists and is not a folder".into(),
        }),
        Err(_) => {
            let parent = match dir.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            };
            if parent.is_dir() {
                Ok(())
            } else {
                Err(Error::Path {
                    path: dir.to_path_buf(),
                    reason: format!(
                        "cannot create the folder: {} does not exist (keycomp does not create \
                         parent folders)",
                        parent.display()
                    ),
                })
            }
        }
    }
}

/// Replaces the folder `dir` by one that `build` fills: `build` writes into a temporary folder
/// beside `dir` (`.NAME.tmp-PID`), which then takes `dir`'s place; the previous folder is moved
/// aside first and removed once the new one is in place. If `build` fails, its temporary folder
/// is removed and `dir` is left as it was. `dir`'s parent must exist ([`check_output_folder`]);
/// a stale temporary folder of this process is removed first.
pub fn replace_folder<T, E: From<Error>>(
    dir: &Path,
    build: impl FnOnce(&Path) -> Result<T, E>,
) -> Result<T, E> {
    check_output_folder(dir)?;
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let pid = std::process::id();
    let tmp = parent.join(format!(".{name}.tmp-{pid}"));
    let failed = |path: &Path, what: &str, e: std::io::Error| Error::Path {
        path: path.to_path_buf(),
        reason: format!("{what}: {e}"),
    };
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp)
            .map_err(|e| failed(&tmp, "cannot remove a stale temporary folder", e))?;
    }
    std::fs::create_dir(&tmp).map_err(|e| failed(&tmp, "cannot create the folder", e))?;
    let built = match build(&tmp) {
        Ok(v) => v,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            return Err(e);
        }
    };
    let old = parent.join(format!(".{name}.old-{pid}"));
    if dir.exists()
        && let Err(e) = std::fs::rename(dir, &old)
    {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(failed(dir, "cannot move the old folder aside", e).into());
    }
    std::fs::rename(&tmp, dir)
        .map_err(|e| failed(dir, "cannot move the new folder into place", e))?;
    if old.exists() {
        // Best effort: the old folder is no longer referenced.
        let _ = std::fs::remove_dir_all(&old);
    }
    Ok(built)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn creates_the_folder_never_its_parents() {
        let dir = tempfile::tempdir().expect("tempdir");
        let one = dir.path().join("one");
        create_output_folder(&one).expect("parent exists");
        assert!(one.is_dir());
        create_output_folder(&one).expect("an existing folder is fine");
        let deep = dir.path().join("missing").join("two");
        let e = create_output_folder(&deep).unwrap_err().to_string();
        assert!(e.contains("does not create parent folders"), "{e}");
        assert!(!dir.path().join("missing").exists());
        let file = dir.path().join("file");
        std::fs::write(&file, b"x").expect("write");
        let e = check_output_folder(&file).unwrap_err().to_string();
        assert!(e.contains("not a folder"), "{e}");
    }

    #[test]
    fn a_replaced_folder_is_whole_or_untouched() {
        let dir = tempfile::tempdir().expect("tempdir");
        let out = dir.path().join("out");
        std::fs::create_dir(&out).expect("mkdir");
        std::fs::write(out.join("old.txt"), b"old").expect("write");
        // a failing build leaves the previous folder and no temporary behind
        let e = replace_folder(&out, |tmp| -> Result<(), Error> {
            std::fs::write(tmp.join("half.txt"), b"half").expect("write");
            Err(Error::Path {
                path: tmp.to_path_buf(),
                reason: "failed".into(),
            })
        });
        assert!(e.is_err());
        assert!(out.join("old.txt").is_file());
        assert!(!out.join("half.txt").exists());
        let names = |d: &Path| -> Vec<String> {
            let mut v: Vec<String> = std::fs::read_dir(d)
                .expect("read_dir")
                .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
                .collect();
            v.sort();
            v
        };
        assert_eq!(names(dir.path()), vec!["out"]);
        // a successful build replaces the folder whole
        let n = replace_folder(&out, |tmp| -> Result<usize, Error> {
            std::fs::write(tmp.join("new.txt"), b"new").expect("write");
            Ok(7)
        })
        .expect("replace");
        assert_eq!(n, 7);
        assert_eq!(names(&out), vec!["new.txt"]);
        assert_eq!(names(dir.path()), vec!["out"]);
        // a missing parent is refused before anything is built
        let deep = dir.path().join("missing").join("out");
        assert!(replace_folder(&deep, |_| -> Result<(), Error> { unreachable!() }).is_err());
    }
}
