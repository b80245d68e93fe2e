//! The checks a segment passes against the manifest that lists it: its length and checksum
//! are the entry's, its head's descriptor length and number are the manifest's and the file
//! name's, its ids are increasing and below the manifest's counter, and its records match their
//! catalogue entries and are valid.

use std::path::Path;

use crate::error::{CorruptKind, IndexError, Result};
use crate::file::{self, KIND_SEGMENT};
use crate::manifest::{Manifest, SegmentEntry};
use crate::record::{ShapeId, ShapeRecord};
use crate::version::FORMAT_VERSION;

use super::head::SegmentHead;

/// The error for a segment file of another length than its manifest entry's: a damaged
/// footer if there is one, a length mismatch otherwise.
pub(crate) fn length_mismatch(path: &Path, bytes: &[u8], entry: &SegmentEntry) -> IndexError {
    match file::check_footer(path, bytes, KIND_SEGMENT, FORMAT_VERSION, true) {
        Err(e) => e,
        Ok(_) => IndexError::corrupt(
            path,
            CorruptKind::LengthMismatch {
                expected: entry.len,
                actual: bytes.len() as u64,
            },
        ),
    }
}

/// Checks that the footer's `checksum` is the one the manifest lists for the segment.
pub(crate) fn check_listed(path: &Path, checksum: u64, entry: &SegmentEntry) -> Result<()> {
    if checksum != entry.checksum {
        return Err(IndexError::corrupt(
            path,
            CorruptKind::NotTheListedFile {
                expected: entry.checksum,
                found: checksum,
            },
        ));
    }
    Ok(())
}

/// Checks a segment's head against the manifest and the segment's entry.
pub(crate) fn check_head(
    path: &Path,
    head: &SegmentHead,
    manifest: &Manifest,
    entry: &SegmentEntry,
) -> Result<()> {
    let malformed = |msg: String| IndexError::corrupt(path, CorruptKind::Malformed(msg));
    if head.dim != manifest.dim {
        return Err(IndexError::DimensionMismatch {
            path: path.to_path_buf(),
            found: head.dim,
            expected: manifest.dim,
        });
    }
    if head.number != entry.number {
        return Err(malformed(format!(
            "the head says segment {}, the file name says {}",
            head.number, entry.number
        )));
    }
    check_ids(path, head.catalogue.iter().map(|c| c.id), manifest, entry)
}

/// Checks the ids a segment lists: as many as its entry says, at least one, increasing, below
/// the manifest's counter.
pub(crate) fn check_ids(
    path: &Path,
    ids: impl ExactSizeIterator<Item = ShapeId>,
    manifest: &Manifest,
    entry: &SegmentEntry,
) -> Result<()> {
    let malformed = |msg: String| IndexError::corrupt(path, CorruptKind::Malformed(msg));
    if ids.len() as u64 != entry.shapes {
        return Err(malformed(format!(
            "{} shapes in the file, the manifest says {}",
            ids.len(),
            entry.shapes
        )));
    }
    let mut last: Option<ShapeId> = None;
    for id in ids {
        if last.is_some_and(|l| l >= id) {
            return Err(malformed("shape ids are not increasing".into()));
        }
        last = Some(id);
    }
    match last {
        None => Err(malformed("the segment holds no shape".into())),
        Some(id) if id.0 >= manifest.next_shape_id => Err(malformed(format!(
            "shape id {id} is beyond the manifest's counter {}",
            manifest.next_shape_id
        ))),
        Some(_) => Ok(()),
    }
}

/// Checks decoded records against their segment's head (one per catalogue entry, with its
/// path and hash, each valid) and the component count `expected`.
pub(crate) fn check_records<const D: usize>(
    path: &Path,
    records: Vec<ShapeRecord<D>>,
    head: &SegmentHead,
    expected: Option<u64>,
) -> Result<Vec<ShapeRecord<D>>> {
    let malformed = |msg: String| IndexError::corrupt(path, CorruptKind::Malformed(msg));
    if records.len() != head.catalogue.len() {
        return Err(malformed(format!(
            "{} records for {} catalogue entries",
            records.len(),
            head.catalogue.len()
        )));
    }
    let mut components = 0u64;
    for (r, c) in records.iter().zip(&head.catalogue) {
        if r.canonical_path.to_str() != Some(c.canonical_path.as_str())
            || r.content_hash != c.content_hash
        {
            return Err(malformed(format!(
                "record of shape {} does not match its catalogue entry",
                c.id
            )));
        }
        r.validate()
            .map_err(|e| malformed(format!("shape {}: {e}", c.id)))?;
        components += r.components.len() as u64;
    }
    if let Some(listed) = expected
        && components != listed
    {
        return Err(malformed(format!(
            "{components} components in the file, the manifest says {listed}"
        )));
    }
    Ok(records)
}
