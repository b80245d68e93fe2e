//! The folder rule of every output: keycomp creates the folder it is told to fill (an index,
//! a report, a benchmark's output) but never the folders above it, and checks that it can
//! before doing any work.

use std::path::Path;

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
}
