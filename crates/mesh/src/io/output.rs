//! Output files: written whole or not at all, and never replacing what should not be replaced.
//!
//! What [`Output`] does with the path it is given:
//!
//! - a **symbolic link** is followed (through chains of links, relative ones resolved against
//!   the link's folder) and its final target is written, so the link stays a link;
//! - a **regular file** or a **path that does not exist yet** is written atomically: the data
//!   goes to a temporary file beside the target (`.NAME.PID.N.tmp`), which is flushed, synced
//!   and renamed over the target. A replaced file keeps its permissions. On any error the
//!   temporary file is removed and the target is left as it was;
//! - an existing **FIFO, device or socket** is written in place (opened for writing, neither
//!   created nor truncated nor replaced), as a shell redirection would: `--ply /dev/null`
//!   discards the output and leaves `/dev/null` alone;
//! - a **directory** is an error, and so is a path whose folder does not exist (outputs do not
//!   create folders).

use std::fs::{self, File, OpenOptions, Permissions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// How many symbolic links are followed before giving up (as Linux's `ELOOP` limit).
const MAX_LINKS: usize = 40;

/// Makes temporary names unique within the process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// An output path, resolved and checked before anything is computed or written.
#[derive(Debug, Clone)]
pub struct Output {
    target: PathBuf,
    kind: TargetKind,
}

#[derive(Debug, Clone)]
enum TargetKind {
    /// Nothing there yet.
    New,
    /// A regular file, replaced atomically; its permissions are kept.
    Regular(Permissions),
    /// A FIFO, device or socket: written in place.
    Special,
}

impl Output {
    /// Resolves `path` (following symbolic links) and checks that it can be written: not a
    /// directory, in a folder that exists.
    pub fn new(path: &Path) -> io::Result<Output> {
        if path.file_name().is_none() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "the path does not name a file",
            ));
        }
        let target = follow_links(path)?;
        let kind = match fs::metadata(&target) {
            Ok(m) if m.is_dir() => {
                return Err(io::Error::new(
                    io::ErrorKind::IsADirectory,
                    "is a directory; give a file name",
                ));
            }
            Ok(m) if m.is_file() => TargetKind::Regular(m.permissions()),
            Ok(_) => TargetKind::Special,
            Err(e) if e.kind() == io::ErrorKind::NotFound => {
                let folder = folder_of(&target);
                if !folder.is_dir() {
                    return Err(io::Error::new(
                        io::ErrorKind::NotFound,
                        format!("the folder {} does not exist", folder.display()),
                    ));
                }
                TargetKind::New
            }
            Err(e) => return Err(e),
        };
        Ok(Output { target, kind })
    }

    /// The file that is written: the given path with symbolic links followed.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Writes what `body` produces to the output (see the module documentation for how).
    pub fn write(&self, body: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> io::Result<()> {
        self.stage(body)?.commit()
    }

    /// Produces the output's contents without making them visible yet: into a temporary file
    /// beside a regular target, or into memory for a FIFO or device. [`Staged::commit`] then
    /// puts them in place; dropping the [`Staged`] instead discards them. Lets a command that
    /// writes several files show all of them or none.
    pub fn stage(&self, body: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> io::Result<Staged> {
        match &self.kind {
            TargetKind::Special => {
                let mut bytes = Vec::new();
                body(&mut bytes)?;
                Ok(Staged {
                    target: self.target.clone(),
                    pending: Pending::InPlace(bytes),
                })
            }
            TargetKind::New | TargetKind::Regular(_) => {
                let tmp = temp_path(&self.target);
                let file = OpenOptions::new().write(true).create_new(true).open(&tmp)?;
                // From here on, dropping `staged` removes the temporary file.
                let staged = Staged {
                    target: self.target.clone(),
                    pending: Pending::Temp(tmp),
                };
                let mut w = BufWriter::new(file);
                body(&mut w)?;
                let file = w.into_inner().map_err(io::IntoInnerError::into_error)?;
                if let TargetKind::Regular(perms) = &self.kind {
                    file.set_permissions(perms.clone())?;
                }
                file.sync_data()?;
                Ok(staged)
            }
        }
    }
}

/// Contents produced by [`Output::stage`], not yet visible at the target.
#[derive(Debug)]
pub struct Staged {
    target: PathBuf,
    pending: Pending,
}

#[derive(Debug)]
enum Pending {
    Temp(PathBuf),
    InPlace(Vec<u8>),
    Done,
}

impl Staged {
    /// Makes the contents visible: renames the temporary file over the target, or writes the
    /// bytes into the FIFO or device.
    pub fn commit(mut self) -> io::Result<()> {
        match std::mem::replace(&mut self.pending, Pending::Done) {
            Pending::Temp(tmp) => {
                let renamed = fs::rename(&tmp, &self.target);
                if renamed.is_err() {
                    let _ = fs::remove_file(&tmp);
                }
                renamed
            }
            Pending::InPlace(bytes) => {
                let mut f = OpenOptions::new().write(true).open(&self.target)?;
                f.write_all(&bytes)?;
                f.flush()
            }
            Pending::Done => Ok(()),
        }
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        if let Pending::Temp(tmp) = &self.pending {
            // Best effort: the temporary file is ours and useless once abandoned.
            let _ = fs::remove_file(tmp);
        }
    }
}

/// Writes what `body` produces to `path` as [`Output`] describes: symbolic links followed,
/// regular files replaced atomically, FIFOs and devices written in place, directories refused.
pub fn write_file(
    path: &Path,
    body: impl FnOnce(&mut dyn Write) -> io::Result<()>,
) -> io::Result<()> {
    Output::new(path)?.write(body)
}

/// `path` with symbolic links followed to the final target (which need not exist). Chains of
/// links are followed (up to 40), relative ones resolved against the folder holding the link.
pub fn follow_links(path: &Path) -> io::Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let link = fs::read_link(&p)?;
                // `join` keeps an absolute link as it is and resolves a relative one against
                // the folder holding the link.
                p = folder_of(&p).join(link);
            }
            _ => return Ok(p),
        }
    }
    Err(io::Error::other(format!(
        "more than {MAX_LINKS} symbolic links to follow"
    )))
}

/// The folder holding `path` (`.` for a bare file name).
fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// A fresh temporary name beside `target`.
fn temp_path(target: &Path) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    folder_of(target).join(format!(
        ".{name}.{}.{}.tmp",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ))
}

/// Opens `path` for reading if it is a regular file (symbolic links followed); refuses a
/// FIFO (which would block until a writer comes), a device, a socket or a directory without
/// opening it.
pub fn open_input(path: &Path) -> io::Result<File> {
    let meta = fs::metadata(path)?;
    if !meta.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("not a regular file but {}", kind_name(&meta.file_type())),
        ));
    }
    File::open(path)
}

/// Reads the whole of a regular file (see [`open_input`]).
pub fn read_input(path: &Path) -> io::Result<Vec<u8>> {
    let mut f = open_input(path)?;
    let mut bytes = Vec::new();
    io::Read::read_to_end(&mut f, &mut bytes)?;
    Ok(bytes)
}

/// Reads the whole of a regular file (see [`open_input`]) as UTF-8 text.
pub fn read_input_text(path: &Path) -> io::Result<String> {
    String::from_utf8(read_input(path)?).map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))
}

/// "a FIFO", "a device", … for messages.
fn kind_name(kind: &fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            return "a FIFO";
        }
        if kind.is_char_device() || kind.is_block_device() {
            return "a device";
        }
        if kind.is_socket() {
            return "a socket";
        }
    }
    if kind.is_dir() {
        "a directory"
    } else {
        "a special file"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(path: &Path) -> String {
        fs::read_to_string(path).unwrap()
    }

    fn hello(w: &mut dyn Write) -> io::Result<()> {
        w.write_all(b"hello")
    }

    #[test]
    fn new_and_regular_files_are_replaced_whole() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        write_file(&p, hello).unwrap();
        assert_eq!(text(&p), "hello");
        let e = write_file(&p, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("failed half way"))
        })
        .unwrap_err();
        assert!(e.to_string().contains("half way"));
        assert_eq!(text(&p), "hello", "a failed write leaves the old file");
        let names: Vec<_> = fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "no temporary file is left");
    }

    #[cfg(unix)]
    #[test]
    fn permissions_of_a_replaced_file_are_kept() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        fs::write(&p, "old").unwrap();
        fs::set_permissions(&p, Permissions::from_mode(0o640)).unwrap();
        write_file(&p, hello).unwrap();
        assert_eq!(
            fs::metadata(&p).unwrap().permissions().mode() & 0o777,
            0o640
        );
    }

    #[cfg(unix)]
    #[test]
    fn symbolic_links_are_followed_and_kept() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("sub/real.txt");
        fs::create_dir(dir.path().join("sub")).unwrap();
        fs::write(&real, "old").unwrap();
        // A relative link to a relative link.
        std::os::unix::fs::symlink("sub/real.txt", dir.path().join("l1")).unwrap();
        std::os::unix::fs::symlink("l1", dir.path().join("l2")).unwrap();
        write_file(&dir.path().join("l2"), hello).unwrap();
        assert_eq!(text(&real), "hello");
        assert!(
            fs::symlink_metadata(dir.path().join("l2"))
                .unwrap()
                .file_type()
                .is_symlink()
        );
        // A dangling link creates its target.
        std::os::unix::fs::symlink("sub/new.txt", dir.path().join("l3")).unwrap();
        write_file(&dir.path().join("l3"), hello).unwrap();
        assert_eq!(text(&dir.path().join("sub/new.txt")), "hello");
        // A loop is an error, not a hang.
        std::os::unix::fs::symlink("loop", dir.path().join("loop")).unwrap();
        assert!(write_file(&dir.path().join("loop"), hello).is_err());
    }

    #[cfg(unix)]
    #[test]
    fn devices_are_written_in_place() {
        let null = Path::new("/dev/null");
        if !null.exists() {
            eprintln!("skipping: no /dev/null");
            return;
        }
        let before = fs::metadata(null).unwrap();
        write_file(null, hello).unwrap();
        let after = fs::metadata(null).unwrap();
        use std::os::unix::fs::MetadataExt;
        assert_eq!(before.ino(), after.ino(), "/dev/null was replaced");
        assert!(!after.is_file());
    }

    /// A FIFO is written in place (a reader at the other end gets the bytes, the FIFO stays)
    /// and refused as an input instead of blocking.
    #[cfg(unix)]
    #[test]
    fn fifos_are_written_in_place_and_refused_as_inputs() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        match std::process::Command::new("mkfifo").arg(&fifo).status() {
            Ok(s) if s.success() => {}
            _ => {
                eprintln!("skipping: mkfifo is not available");
                return;
            }
        }
        let e = read_input(&fifo).unwrap_err();
        assert!(e.to_string().contains("a FIFO"), "{e}");
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || fs::read_to_string(fifo).unwrap())
        };
        write_file(&fifo, hello).unwrap();
        assert_eq!(reader.join().unwrap(), "hello");
        use std::os::unix::fs::FileTypeExt;
        assert!(fs::metadata(&fifo).unwrap().file_type().is_fifo());
    }

    #[test]
    fn directories_and_missing_folders_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let e = write_file(dir.path(), hello).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::IsADirectory, "{e}");
        let e = write_file(&dir.path().join("no/such/a.txt"), hello).unwrap_err();
        assert!(e.to_string().contains("does not exist"), "{e}");
        assert!(open_input(dir.path()).is_err());
    }

    #[test]
    fn a_dropped_stage_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        let staged = Output::new(&p).unwrap().stage(hello).unwrap();
        drop(staged);
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
        Output::new(&p)
            .unwrap()
            .stage(hello)
            .unwrap()
            .commit()
            .unwrap();
        assert_eq!(text(&p), "hello");
    }
}
