//! The container every index file shares: payload, then a fixed 32-byte footer; atomic writes.
//!
//! Footer (last 32 bytes of every file, all integers little endian; see `index/README.md` at the workspace root):
//!
//! | offset from footer start | size | field |
//! |---|---|---|
//! | 0  | 8 | payload length in bytes (= file length − 32) |
//! | 8  | 4 | file kind: 1 = manifest, 2 = segment |
//! | 12 | 4 | format version |
//! | 16 | 8 | checksum: XXH3-64 (seed 0) of every byte before this field |
//! | 24 | 8 | magic `KCIDXEND` |
//!
//! The footer layout, the checksum algorithm and the magic are frozen across format versions,
//! so any keycomp can tell a damaged file ("corrupt") from a file of another version
//! ("incompatible"). Checks run in this order: length ≥ 32, magic, checksum, payload length,
//! version, kind. A bit flip anywhere (payload or footer) therefore fails the checksum (or the
//! magic), never the version check.
//!
//! Atomic write ([`write_atomic`]): write to `NAME.tmp-PID-N` in the same directory, `sync_all`,
//! rename over `NAME`, fsync the directory. A reader opening `NAME` sees the old file or the
//! new one, never a partial one; a crash leaves at most a stray temp file that no manifest
//! references.

use std::fs::{self, File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use xxhash_rust::xxh3::xxh3_64;

use crate::codec::{le_u32, le_u64};
use crate::error::{CorruptKind, IndexError, Result};
use crate::version::OLDEST_READABLE_VERSION;

/// Size in bytes of the footer that closes every index file.
pub const FOOTER_LEN: usize = 32;
/// The magic number in the last 8 bytes of every index file.
pub const MAGIC: [u8; 8] = *b"KCIDXEND";
/// Footer kind code of the manifest.
pub const KIND_MANIFEST: u32 = 1;
/// Footer kind code of a segment.
pub const KIND_SEGMENT: u32 = 2;
/// Footer kind code of the search cache (`ivf`), derived data a reader may rewrite.
pub const KIND_SEARCH_CACHE: u32 = 3;
/// Infix of temporary files (`NAME.tmp-PID-N`); any file containing it is garbage unless a
/// write is in progress under the writer lock.
pub const TEMP_INFIX: &str = ".tmp-";

/// Human name of a kind code.
pub fn kind_name(kind: u32) -> &'static str {
    match kind {
        KIND_MANIFEST => "manifest",
        KIND_SEGMENT => "segment",
        KIND_SEARCH_CACHE => "search cache",
        _ => "unknown",
    }
}

/// Appends the footer to `payload`, returning the whole file and its checksum.
pub fn seal(mut payload: Vec<u8>, kind: u32, version: u32) -> (Vec<u8>, u64) {
    let len = payload.len() as u64;
    payload.extend_from_slice(&len.to_le_bytes());
    payload.extend_from_slice(&kind.to_le_bytes());
    payload.extend_from_slice(&version.to_le_bytes());
    let checksum = xxh3_64(&payload);
    payload.extend_from_slice(&checksum.to_le_bytes());
    payload.extend_from_slice(&MAGIC);
    (payload, checksum)
}

/// A file whose footer checked out.
#[derive(Debug)]
pub struct Opened {
    /// The whole file, footer included.
    pub bytes: Vec<u8>,
    /// The checksum from the footer.
    pub checksum: u64,
    /// The format version from the footer.
    pub version: u32,
}

impl Opened {
    /// The payload (everything before the footer).
    pub fn payload(&self) -> &[u8] {
        &self.bytes[..self.bytes.len() - FOOTER_LEN]
    }
}

/// Checks the footer of `bytes` (read from `path`): length, magic, checksum, payload length,
/// version (must be in [`OLDEST_READABLE_VERSION`]`..=newest`), kind (must be `kind`).
pub fn unseal(path: &Path, bytes: Vec<u8>, kind: u32, newest: u32) -> Result<Opened> {
    let (checksum, version) = check_footer(path, &bytes, kind, newest, true)?;
    Ok(Opened {
        bytes,
        checksum,
        version,
    })
}

/// The footer checks of [`unseal`] on `bytes` in place; the checksum over the payload is
/// computed only when `verify_checksum` is set (a memory-mapped segment, whose records carry
/// their own checksums, is not read whole to be opened). Returns the stored checksum and the
/// format version.
pub fn check_footer(
    path: &Path,
    bytes: &[u8],
    kind: u32,
    newest: u32,
    verify_checksum: bool,
) -> Result<(u64, u32)> {
    let len = bytes.len();
    if len == 0 {
        return Err(IndexError::corrupt(path, CorruptKind::Empty));
    }
    if len < FOOTER_LEN {
        return Err(IndexError::corrupt(
            path,
            CorruptKind::TooShort { len: len as u64 },
        ));
    }
    let footer = &bytes[len - FOOTER_LEN..];
    if footer[24..32] != MAGIC {
        return Err(IndexError::corrupt(path, CorruptKind::BadMagic));
    }
    let stored = le_u64(&footer[16..24]);
    if verify_checksum {
        let computed = xxh3_64(&bytes[..len - 16]);
        if stored != computed {
            return Err(IndexError::corrupt(
                path,
                CorruptKind::ChecksumMismatch { stored, computed },
            ));
        }
    }
    let payload_len = le_u64(&footer[0..8]);
    if payload_len != (len - FOOTER_LEN) as u64 {
        return Err(IndexError::corrupt(
            path,
            CorruptKind::LengthMismatch {
                expected: payload_len.saturating_add(FOOTER_LEN as u64),
                actual: len as u64,
            },
        ));
    }
    let found_version = le_u32(&footer[12..16]);
    if !(OLDEST_READABLE_VERSION..=newest).contains(&found_version) {
        return Err(IndexError::Incompatible {
            path: path.to_path_buf(),
            found: found_version,
            supported: newest,
        });
    }
    let found_kind = le_u32(&footer[8..12]);
    if found_kind != kind {
        return Err(IndexError::corrupt(
            path,
            CorruptKind::WrongKind {
                expected: kind_name(kind),
                found: found_kind,
            },
        ));
    }
    Ok((stored, found_version))
}

/// Reads a whole regular file. `NotFound` is returned as the raw `io::Error` so callers can
/// turn it into the right variant; anything but a regular file (a FIFO, which would block, a
/// device, a directory) is refused with `InvalidInput` before it is opened.
pub fn read_all(path: &Path) -> std::io::Result<Vec<u8>> {
    let mut f = open_regular(path)?;
    let mut buf = Vec::new();
    f.read_to_end(&mut buf)?;
    Ok(buf)
}

/// Opens `path` for reading if it is a regular file (following symlinks); refuses anything
/// else with `InvalidInput` without opening it, since opening a FIFO blocks until a writer
/// comes.
pub fn open_regular(path: &Path) -> std::io::Result<File> {
    if !fs::metadata(path)?.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file",
        ));
    }
    File::open(path)
}

/// Memory-maps the whole of `f` (opened from `path`), read-only.
///
/// Only files this crate never modifies once renamed into place are mapped: segments and the
/// search cache (writers write new files and rename them; deleting or replacing a mapped file
/// leaves the mapping on the old one valid). A program other than keycomp truncating a mapped
/// file makes the reading process fail with a bus error (index/README.md, *Reading*).
pub fn map(f: &File, path: &Path) -> Result<memmap2::Mmap> {
    // SAFETY: see above: the files mapped are immutable once written.
    #[allow(unsafe_code)]
    let map = unsafe { memmap2::Mmap::map(f) };
    map.map_err(|e| IndexError::io("could not memory-map", path, e))
}

static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// A writer that counts and hashes what goes through it (for [`write_atomic_sealed`]).
pub struct SealWriter<W: Write> {
    inner: W,
    len: u64,
    hash: xxhash_rust::xxh3::Xxh3Default,
}

impl<W: Write> Write for SealWriter<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash.update(&buf[..n]);
        self.len += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Writes the payload `write` produces, sealed with the footer of `kind` and `version` (as
/// [`seal`] would), to `dir/name` atomically like [`write_atomic`], without holding the
/// payload in memory.
pub fn write_atomic_sealed(
    dir: &Path,
    name: &str,
    kind: u32,
    version: u32,
    write: impl FnOnce(&mut SealWriter<std::io::BufWriter<File>>) -> std::io::Result<()>,
) -> Result<PathBuf> {
    write_atomic_with(dir, name, |f| {
        let mut w = SealWriter {
            inner: std::io::BufWriter::with_capacity(1 << 20, f),
            len: 0,
            hash: xxhash_rust::xxh3::Xxh3Default::new(),
        };
        write(&mut w)?;
        let len = w.len;
        w.write_all(&len.to_le_bytes())?;
        w.write_all(&kind.to_le_bytes())?;
        w.write_all(&version.to_le_bytes())?;
        let checksum = w.hash.digest();
        let mut inner = w.inner;
        inner.write_all(&checksum.to_le_bytes())?;
        inner.write_all(&MAGIC)?;
        inner.into_inner().map_err(|e| e.into_error())
    })
}

/// Writes `bytes` to `dir/name` atomically (temp file, fsync, rename, fsync directory).
pub fn write_atomic(dir: &Path, name: &str, bytes: &[u8]) -> Result<PathBuf> {
    write_atomic_with(dir, name, |mut f| {
        f.write_all(bytes)?;
        Ok(f)
    })
}

/// The atomic write of every index file: `write` fills a new temporary file `NAME.tmp-PID-N`
/// in `dir` and hands it back, which is synced, renamed over `dir/name`, and the directory
/// synced. On any error the temporary file is removed and `dir/name` is left as it was.
fn write_atomic_with(
    dir: &Path,
    name: &str,
    write: impl FnOnce(File) -> std::io::Result<File>,
) -> Result<PathBuf> {
    let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp = dir.join(format!("{name}{TEMP_INFIX}{}-{n}", std::process::id()));
    let target = dir.join(name);
    let result = (|| {
        let f = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(|e| IndexError::io("could not create", &tmp, e))?;
        let f = write(f).map_err(|e| IndexError::io("could not write", &tmp, e))?;
        f.sync_all()
            .map_err(|e| IndexError::io("could not sync", &tmp, e))?;
        drop(f);
        fs::rename(&tmp, &target).map_err(|e| IndexError::io("could not rename into", &target, e))
    })();
    if let Err(e) = result {
        // Best effort: the temp file is garbage either way and is also cleaned later.
        let _ = fs::remove_file(&tmp);
        return Err(e);
    }
    sync_dir(dir)?;
    Ok(target)
}

/// Makes directory entries (creations, renames, removals) in `dir` durable.
pub fn sync_dir(dir: &Path) -> Result<()> {
    #[cfg(unix)]
    {
        let d = File::open(dir).map_err(|e| IndexError::io("could not open directory", dir, e))?;
        d.sync_all()
            .map_err(|e| IndexError::io("could not sync directory", dir, e))?;
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seal_then_unseal() {
        let (bytes, sum) = seal(b"hello".to_vec(), KIND_SEGMENT, 7);
        assert_eq!(bytes.len(), 5 + FOOTER_LEN);
        let o = unseal(Path::new("x"), bytes, KIND_SEGMENT, 7).unwrap();
        assert_eq!(o.payload(), b"hello");
        assert_eq!(o.checksum, sum);
    }

    /// A payload written through [`write_atomic_sealed`] gives the bytes [`seal`] gives.
    #[test]
    fn streamed_sealing_equals_sealing() {
        let dir = tempfile::tempdir().unwrap();
        let payload: Vec<u8> = (0..3_000_000u32).map(|i| (i * 31 % 253) as u8).collect();
        let p = write_atomic_sealed(dir.path(), "f", KIND_SEARCH_CACHE, 5, |w| {
            for chunk in payload.chunks(77_777) {
                w.write_all(chunk)?;
            }
            Ok(())
        })
        .unwrap();
        assert_eq!(fs::read(p).unwrap(), seal(payload, KIND_SEARCH_CACHE, 5).0);
        assert_eq!(
            fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no temp file left"
        );
    }

    #[test]
    fn every_flip_is_detected_as_corrupt() {
        let (bytes, _) = seal(b"some payload".to_vec(), KIND_MANIFEST, 1);
        for i in 0..bytes.len() {
            for bit in [0x01u8, 0x80] {
                let mut b = bytes.clone();
                b[i] ^= bit;
                let e = unseal(Path::new("f"), b, KIND_MANIFEST, 1).unwrap_err();
                assert!(matches!(e, IndexError::Corrupt { .. }), "byte {i}: {e}");
            }
        }
    }

    #[test]
    fn other_version_is_incompatible() {
        let (bytes, _) = seal(b"p".to_vec(), KIND_MANIFEST, 3);
        let e = unseal(Path::new("f"), bytes, KIND_MANIFEST, 1).unwrap_err();
        assert!(matches!(
            e,
            IndexError::Incompatible {
                found: 3,
                supported: 1,
                ..
            }
        ));
        assert!(
            e.to_string()
                .contains("format version 3, this keycomp reads versions 1 to 1")
        );
    }
}
