//! The files of an index directory: their names, and which files are leftovers.
//!
//! An index directory holds `MANIFEST` ([`MANIFEST_NAME`]), the segments it lists
//! (`seg-NNNNNN.kcs`, [`segment_file_name`]), the writers' lock file ([`LOCK_NAME`]) and the
//! search cache ([`SEARCH_CACHE_NAME`]). A temporary file of an interrupted write, or a
//! segment no manifest lists, is a leftover ([`leftover_files`]): harmless, and deleted by the
//! next successful write.

use std::collections::HashSet;
use std::fs;
use std::path::{Path, PathBuf};

use crate::error::{IndexError, Result};
use crate::file::TEMP_INFIX;

/// Default index directory, relative to the working directory.
pub const DEFAULT_INDEX_DIR: &str = "index";

/// File name of the manifest.
pub const MANIFEST_NAME: &str = "MANIFEST";

/// File name of the writers' lock file.
pub const LOCK_NAME: &str = "LOCK";

/// The file in an index folder that caches the inverted file of its current descriptors
/// (derived data: any reader may rewrite it; a damaged or stale one is rebuilt).
pub const SEARCH_CACHE_NAME: &str = "SEARCH-CACHE";

/// File name of segment `number`: `seg-NNNNNN.kcs` (at least 6 digits).
pub fn segment_file_name(number: u64) -> String {
    format!("seg-{number:06}.kcs")
}

/// Parses a segment file name back into its number.
pub fn parse_segment_file_name(name: &str) -> Option<u64> {
    let digits = name.strip_prefix("seg-")?.strip_suffix(".kcs")?;
    if digits.len() < 6 || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// Files in `dir` that belong to the index's naming scheme but are not referenced: temp files
/// and segment files whose number is not in `listed`.
pub(crate) fn leftover_files(dir: &Path, listed: &HashSet<u64>) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    let rd = fs::read_dir(dir).map_err(|e| IndexError::io("could not list", dir, e))?;
    for ent in rd {
        let ent = ent.map_err(|e| IndexError::io("could not list", dir, e))?;
        let name = ent.file_name();
        let Some(name) = name.to_str() else { continue };
        let is_temp = name.contains(TEMP_INFIX)
            && (name.starts_with("seg-") || name.starts_with(MANIFEST_NAME));
        let unlisted_segment = parse_segment_file_name(name).is_some_and(|n| !listed.contains(&n));
        if is_temp || unlisted_segment {
            out.push(ent.path());
        }
    }
    out.sort();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_names_round_trip() {
        assert_eq!(segment_file_name(42), "seg-000042.kcs");
        assert_eq!(parse_segment_file_name("seg-000042.kcs"), Some(42));
        assert_eq!(parse_segment_file_name("seg-1234567.kcs"), Some(1_234_567));
        assert_eq!(parse_segment_file_name("seg-42.kcs"), None);
        assert_eq!(parse_segment_file_name("seg-000042.kcs.tmp-1-0"), None);
    }
}
