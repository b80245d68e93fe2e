//! The on-disk format's version numbers: the one this build writes and the oldest it reads.
//!
//! Every index file records its format version in its footer (`file`); a file of a version
//! outside [`OLDEST_READABLE_VERSION`]`..=`[`FORMAT_VERSION`] is refused as incompatible.
//! What each version changed is in `index/README.md` at the workspace root, *Versions*.

/// The on-disk format version this build writes. Bumped on any incompatible change; files of a
/// version outside [`OLDEST_READABLE_VERSION`]`..=FORMAT_VERSION` are refused with
/// [`crate::IndexError::Incompatible`].
pub const FORMAT_VERSION: u32 = 5;

/// Oldest format version this build still reads (version 1 has no manifest profile; see
/// `index/README.md`, *Versions*).
pub const OLDEST_READABLE_VERSION: u32 = 1;
