//! A format-5 segment read in place: the file memory-mapped, its footer's fields and its
//! table checked when opened (32 bytes per shape, not the records), its descriptor block used
//! where it lies, and each record decoded and checked against its own checksum when asked for.
//! What a reader of a large index opens ([`crate::IndexReader::open_mapped`]).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use crate::dir::{MANIFEST_NAME, segment_file_name};
use crate::error::{CorruptKind, IndexError, Result};
use crate::file::{self, KIND_SEGMENT};
use crate::manifest::{Manifest, SegmentEntry};
use crate::record::ShapeRecord;
use crate::version::FORMAT_VERSION;

use super::check::{check_ids, check_listed, length_mismatch};
use super::head::SegmentHead;
use super::payload::{self, Entry, Table};

/// A format-5 segment read in place from a memory map ([`payload`]): its table and
/// descriptor block were checked when opened, each record is checked when decoded.
pub(crate) struct MappedSegment {
    path: PathBuf,
    map: memmap2::Mmap,
    table: Table,
    /// The head (the shapes' paths), decoded on first use.
    head: OnceLock<SegmentHead>,
}

impl MappedSegment {
    /// The payload (the file without its footer).
    fn payload(&self) -> &[u8] {
        &self.map[..self.map.len() - file::FOOTER_LEN]
    }

    /// The error for damage found in this segment.
    pub(crate) fn malformed(&self, msg: String) -> IndexError {
        IndexError::corrupt(&self.path, CorruptKind::Malformed(msg))
    }

    /// Maps the segment of `entry` if it is of format 5 and its block can be read in place;
    /// `None` when it must be read whole instead (an older format, a big-endian machine).
    pub(crate) fn open<const D: usize>(
        dir: &Path,
        manifest: &Manifest,
        entry: &SegmentEntry,
    ) -> Result<Option<Self>> {
        let path = dir.join(segment_file_name(entry.number));
        let f = match file::open_regular(&path) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(IndexError::MissingSegment {
                    manifest: dir.join(MANIFEST_NAME),
                    segment: path,
                });
            }
            Err(e) => return Err(IndexError::io("could not open", path, e)),
        };
        let len = f
            .metadata()
            .map_err(|e| IndexError::io("could not read the size of", &path, e))?
            .len();
        if len != entry.len {
            let bytes =
                file::read_all(&path).map_err(|e| IndexError::io("could not read", &path, e))?;
            return Err(length_mismatch(&path, &bytes, entry));
        }
        let map = file::map(&f, &path)?;
        // The footer's fields without the checksum over the whole file; a field that fails
        // (a version, a kind) may be a damaged byte: the full check then tells which.
        let (checksum, version) =
            match file::check_footer(&path, &map, KIND_SEGMENT, FORMAT_VERSION, false) {
                Ok(v) => v,
                Err(e) => {
                    file::check_footer(&path, &map, KIND_SEGMENT, FORMAT_VERSION, true)?;
                    return Err(e);
                }
            };
        check_listed(&path, checksum, entry)?;
        if version < 5 {
            return Ok(None);
        }
        let payload = &map[..map.len() - file::FOOTER_LEN];
        let malformed = |msg: String| IndexError::corrupt(&path, CorruptKind::Malformed(msg));
        let table = payload::parse(payload).map_err(malformed)?;
        check_ids(&path, table.entries.iter().map(|e| e.id), manifest, entry)?;
        table.check_block(D).map_err(malformed)?;
        if table.count != entry.components {
            return Err(malformed(format!(
                "{} components in the file, the manifest says {}",
                table.count, entry.components
            )));
        }
        if payload::block(payload, &table).is_none() {
            return Ok(None);
        }
        Ok(Some(MappedSegment {
            path,
            map,
            table,
            head: OnceLock::new(),
        }))
    }

    /// The descriptors of the record at `position`, in place.
    pub(crate) fn descriptors(&self, position: usize, dim: usize) -> Option<&[f32]> {
        let e = self.table.entries.get(position)?;
        let block = payload::block(self.payload(), &self.table)?;
        let start = e.first as usize * dim;
        block.get(start..start + e.components as usize * dim)
    }

    /// Asks the system to start reading descriptor `component` of the record at `position`
    /// (a hint, as [`MappedSegment::prefetch`]).
    pub(crate) fn prefetch_descriptor(&self, position: usize, component: usize, dim: usize) {
        #[cfg(unix)]
        if let Some(e) = self.table.entries.get(position)
            && component < e.components as usize
        {
            let offset = self.table.block.start + 4 * dim * (e.first as usize + component);
            let _ = self
                .map
                .advise_range(memmap2::Advice::WillNeed, offset, 4 * dim);
        }
        #[cfg(not(unix))]
        let _ = (position, component, dim);
    }

    /// Asks the system to start reading the descriptors of the record at `position`, and its
    /// bytes if `record` (a hint: errors are of no consequence and ignored).
    pub(crate) fn prefetch(&self, position: usize, dim: usize, record: bool) {
        #[cfg(unix)]
        if let Some(e) = self.table.entries.get(position) {
            let advise = |offset: usize, len: usize| {
                if len > 0 {
                    let _ = self
                        .map
                        .advise_range(memmap2::Advice::WillNeed, offset, len);
                }
            };
            if record {
                advise(e.offset as usize, e.len as usize);
            }
            let first = 4 * dim * e.first as usize;
            advise(
                self.table.block.start + first,
                4 * dim * e.components as usize,
            );
        }
        #[cfg(not(unix))]
        let _ = (position, dim, record);
    }

    pub(crate) fn head(&self) -> Result<&SegmentHead> {
        if let Some(h) = self.head.get() {
            return Ok(h);
        }
        let h = payload::head(self.payload(), &self.table).map_err(|m| self.malformed(m))?;
        Ok(self.head.get_or_init(|| h))
    }

    /// The table's entries: one per shape, ids increasing.
    pub(crate) fn entries(&self) -> &[Entry] {
        &self.table.entries
    }

    /// Decodes the record at `position`, checking it against its own checksum.
    pub(crate) fn record<const D: usize>(&self, position: usize) -> Result<ShapeRecord<D>> {
        payload::record::<D>(self.payload(), &self.table, position)
            .map_err(|msg| self.malformed(msg))
    }
}
