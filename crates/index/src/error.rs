//! The index's error type.
//!
//! Every variant names the file (or directory) it is about and its message ends with what the
//! user can do about it. Errors are split so that callers (and tests) can tell apart:
//! a damaged file ([`IndexError::Corrupt`]), a file written by another format version or
//! descriptor length ([`IndexError::Incompatible`], [`IndexError::DimensionMismatch`]), a
//! segment that the manifest lists but that is gone ([`IndexError::MissingSegment`]), a
//! directory that holds no index ([`IndexError::NotAnIndex`]), plain I/O failures
//! ([`IndexError::Io`]) and bad input from the caller ([`IndexError::InvalidRecord`],
//! [`IndexError::InvalidQuery`]).

use std::fmt;
use std::io;
use std::path::PathBuf;

/// What exactly is wrong with a corrupt file. Carried by [`IndexError::Corrupt`].
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum CorruptKind {
    /// The file has zero bytes.
    Empty,
    /// The file is shorter than the fixed-size footer.
    TooShort {
        /// Length of the file in bytes.
        len: u64,
    },
    /// The last 8 bytes are not the footer magic: the file was cut short, overwritten, or is
    /// not a keycomp index file.
    BadMagic,
    /// The checksum stored in the footer does not match the file's bytes.
    ChecksumMismatch {
        /// Checksum stored in the footer.
        stored: u64,
        /// Checksum computed from the file.
        computed: u64,
    },
    /// The file's length differs from the length recorded for it (in its own footer, or for a
    /// segment, in the manifest).
    LengthMismatch {
        /// Length recorded in the footer or manifest.
        expected: u64,
        /// Actual length of the file.
        actual: u64,
    },
    /// The file is intact as far as its checksum goes, but it is not the file the manifest
    /// refers to (its checksum differs from the one recorded in the manifest).
    NotTheListedFile {
        /// Checksum recorded for this segment in the manifest.
        expected: u64,
        /// Checksum found in the file's footer.
        found: u64,
    },
    /// The footer names a different kind of file (e.g. a segment where the manifest belongs).
    WrongKind {
        /// Kind expected here.
        expected: &'static str,
        /// Kind code found in the footer.
        found: u32,
    },
    /// The checksum is right but the contents do not decode or are inconsistent.
    Malformed(String),
    /// `MANIFEST` is missing although the directory holds segment files (a writer refuses to
    /// start a new, empty index over them).
    MissingManifest {
        /// Number of segment files found.
        segments: usize,
    },
}

impl fmt::Display for CorruptKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CorruptKind::Empty => write!(f, "the file is empty"),
            CorruptKind::TooShort { len } => {
                write!(
                    f,
                    "the file is {len} bytes long, too short to hold a footer"
                )
            }
            CorruptKind::BadMagic => write!(
                f,
                "no keycomp footer at the end of the file (truncated, overwritten or not an index file)"
            ),
            CorruptKind::ChecksumMismatch { stored, computed } => write!(
                f,
                "checksum mismatch (footer says {stored:016x}, contents give {computed:016x})"
            ),
            CorruptKind::LengthMismatch { expected, actual } => write!(
                f,
                "truncated or extended: expected {expected} bytes, the file has {actual}"
            ),
            CorruptKind::NotTheListedFile { expected, found } => write!(
                f,
                "not the file the manifest lists (manifest checksum {expected:016x}, file checksum {found:016x})"
            ),
            CorruptKind::WrongKind { expected, found } => {
                write!(
                    f,
                    "expected a {expected} file, the footer says kind {found}"
                )
            }
            CorruptKind::Malformed(msg) => write!(f, "malformed contents: {msg}"),
            CorruptKind::MissingManifest { segments } => write!(
                f,
                "the file is missing although the directory holds {segments} segment files"
            ),
        }
    }
}

/// Errors returned by the index.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IndexError {
    /// An I/O operation on a file of the index failed.
    #[error("{action} {}: {source}", path.display())]
    Io {
        /// What was being done, e.g. "could not read".
        action: &'static str,
        /// The file or directory.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: io::Error,
    },
    /// The directory does not exist or holds no `MANIFEST`.
    #[error(
        "{} is not a keycomp index (no MANIFEST file): check the --index path, or create an index with `keycomp index add`",
        dir.display()
    )]
    NotAnIndex {
        /// The directory that was opened.
        dir: PathBuf,
    },
    /// A file of the index is damaged. Nothing from it is used.
    #[error(
        "index file {} is corrupt: {kind}; run `keycomp index verify` to list the damage, then restore the index from a backup or rebuild it with `keycomp index add`",
        path.display()
    )]
    Corrupt {
        /// The damaged file.
        path: PathBuf,
        /// What is wrong with it.
        kind: CorruptKind,
    },
    /// A file was written in a format version this build cannot read.
    #[error(
        "index file {} is incompatible: format version {found}, this keycomp reads versions {} to {supported}; {}",
        path.display(),
        crate::version::OLDEST_READABLE_VERSION,
        if *found > *supported {
            "upgrade keycomp, or rebuild the index with this version (`keycomp index add` into a new directory)"
        } else {
            "rebuild the index with this version (`keycomp index add` into a new directory)"
        }
    )]
    Incompatible {
        /// The file.
        path: PathBuf,
        /// Format version found in the file.
        found: u32,
        /// Newest format version this build reads (and the one it writes).
        supported: u32,
    },
    /// The index holds descriptors of another length than this build uses.
    #[error(
        "index file {} is incompatible: its descriptors have {found} values, this keycomp uses {expected}; rebuild the index with this version (`keycomp index add` into a new directory)",
        path.display()
    )]
    DimensionMismatch {
        /// The file.
        path: PathBuf,
        /// Descriptor length found in the file.
        found: u32,
        /// Descriptor length of this build.
        expected: u32,
    },
    /// The manifest lists a segment file that does not exist.
    #[error(
        "index segment {} is missing (listed in {}): the index is incomplete; restore the file from a backup or rebuild the index with `keycomp index add`",
        segment.display(),
        manifest.display()
    )]
    MissingSegment {
        /// The manifest that lists the segment.
        manifest: PathBuf,
        /// The missing segment file.
        segment: PathBuf,
    },
    /// Another process holds the index's write lock.
    #[error(
        "index {} is locked by another writer (lock file {}): wait for the other `keycomp index` command to finish",
        dir.display(),
        lock.display()
    )]
    Locked {
        /// The index directory.
        dir: PathBuf,
        /// The lock file.
        lock: PathBuf,
    },
    /// A record given to [`crate::IndexWriter::add_batch`] cannot be stored.
    #[error("cannot index {}: {reason}", path.display())]
    InvalidRecord {
        /// The record's source path.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// The index's descriptors were made another way than the caller's (see
    /// [`crate::IndexWriter::ensure_profile`]).
    #[error(
        "index {} holds descriptors made another way ({}); this keycomp makes them as: {requested}. Rebuild the index (delete the directory and `keycomp index add` again) or use another --index directory",
        dir.display(),
        if found.is_empty() { "no profile: written by an older keycomp, format 1".to_string() } else { format!("index profile: {found}") }
    )]
    ProfileMismatch {
        /// The index directory.
        dir: PathBuf,
        /// The index's profile (empty: none recorded).
        found: String,
        /// The caller's profile.
        requested: String,
    },
    /// Two indexes being merged hold the same shape path with different contents.
    #[error(
        "{} is in {} and in {} with different contents (content hashes {first_hash} and {second_hash}); remove it from one of them, or re-index it, before merging",
        path.display(),
        first.display(),
        second.display()
    )]
    MergeConflict {
        /// The shape's canonical path.
        path: PathBuf,
        /// The index (destination or an earlier source) that holds it first.
        first: PathBuf,
        /// Its content hash there.
        first_hash: String,
        /// The source index that holds it with other contents.
        second: PathBuf,
        /// Its content hash there.
        second_hash: String,
    },
    /// Indexes to merge were made with different profiles.
    #[error(
        "index {} was made another way than {} (profiles differ: {detail}); only indexes made with the same parameters can be merged",
        source_dir.display(),
        dest.display()
    )]
    MergeProfile {
        /// The source index whose profile differs.
        source_dir: PathBuf,
        /// The index whose profile it was compared with (destination or first source).
        dest: PathBuf,
        /// The two profiles, or where they differ.
        detail: String,
    },
    /// A query vector cannot be searched for.
    #[error("invalid query: {reason}")]
    InvalidQuery {
        /// What is wrong with it.
        reason: String,
    },
}

impl IndexError {
    /// Shorthand for [`IndexError::Io`].
    pub(crate) fn io(action: &'static str, path: impl Into<PathBuf>, source: io::Error) -> Self {
        IndexError::Io {
            action,
            path: path.into(),
            source,
        }
    }

    /// Shorthand for [`IndexError::Corrupt`].
    pub(crate) fn corrupt(path: impl Into<PathBuf>, kind: CorruptKind) -> Self {
        IndexError::Corrupt {
            path: path.into(),
            kind,
        }
    }

    /// The file or directory this error is about, if any.
    pub fn path(&self) -> Option<&std::path::Path> {
        match self {
            IndexError::Io { path, .. }
            | IndexError::Corrupt { path, .. }
            | IndexError::Incompatible { path, .. }
            | IndexError::DimensionMismatch { path, .. }
            | IndexError::InvalidRecord { path, .. } => Some(path),
            IndexError::NotAnIndex { dir }
            | IndexError::Locked { dir, .. }
            | IndexError::ProfileMismatch { dir, .. } => Some(dir),
            IndexError::MissingSegment { segment, .. } => Some(segment),
            IndexError::MergeConflict { second, .. } => Some(second),
            IndexError::MergeProfile { source_dir, .. } => Some(source_dir),
            IndexError::InvalidQuery { .. } => None,
        }
    }
}

/// Result alias for this crate.
pub type Result<T, E = IndexError> = std::result::Result<T, E>;
