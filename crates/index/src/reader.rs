//! [`IndexReader`]: a consistent, read-only snapshot of an index: its live shapes, their
//! records, and the search's items (every live component, shape after shape by increasing id).
//!
//! Opening reads `MANIFEST` once, then the immutable segment files it lists. Writers never
//! modify a file in place, so the snapshot is consistent while an add runs. The one race left —
//! a concurrent writer deleting a segment (after a remove or compact) between our reading the
//! manifest and the segment — shows up as a missing segment; the reader then rereads the
//! manifest and, if its generation moved on, starts over (a few times), so only a segment
//! missing from the *current* manifest is reported as [`IndexError::MissingSegment`].
//!
//! Two ways to open:
//! - [`IndexReader::open`] reads every segment whole, checking every footer, checksum, length
//!   and record, and keeps the records decoded (what listing, merging and checking want);
//! - [`IndexReader::open_mapped`] memory-maps segments of format 5 and checks their tables
//!   only (32 bytes per shape: milliseconds where reading whole takes seconds; BENCHMARKS.md,
//!   *A million shapes*); the search reads descriptors in place from the maps, and each
//!   record is decoded and checked when asked for, on each call (what a process answering
//!   queries wants: it holds the tables, the search structure and the records its callers
//!   hold).
//!
//! The search over a snapshot is in `search.rs`; the structure it builds, and the setting that
//! chooses it, in `search_structure.rs`.

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use crate::dir::segment_file_name;
use crate::error::{IndexError, Result};
use crate::ivf::{Origin, SearchEffort};
use crate::manifest::Manifest;
use crate::record::{ShapeId, ShapeRecord, canonical_path};
use crate::search_structure::{Search, SearchMode};
use crate::segment::{self, MappedSegment};
use crate::version::FORMAT_VERSION;

/// A live shape of a snapshot.
#[derive(Debug, Clone, PartialEq)]
pub struct IndexedShape<const D: usize> {
    /// Its id.
    pub id: ShapeId,
    /// Its record (shared with the snapshot when the snapshot holds it decoded).
    pub record: Arc<ShapeRecord<D>>,
}

/// Summary numbers of a snapshot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IndexStats {
    /// The index directory.
    pub dir: PathBuf,
    /// On-disk format version.
    pub format_version: u32,
    /// Manifest generation of the snapshot.
    pub generation: u64,
    /// Descriptor length.
    pub dim: usize,
    /// Live shapes.
    pub shapes: usize,
    /// Live components.
    pub components: usize,
    /// Segment files.
    pub segments: usize,
    /// Removed or replaced shapes still occupying space in segments (reclaimed by
    /// [`crate::IndexWriter::compact`]).
    pub tombstones: usize,
    /// Total bytes of the manifest and segment files.
    pub bytes: u64,
}

/// How many times [`IndexReader::open`] starts over when a concurrent writer deleted a
/// segment it was about to read.
pub(crate) const OPEN_ATTEMPTS: usize = 8;

/// Read-only snapshot of an index. Cheap to query from several threads (`&self`).
pub struct IndexReader<const D: usize> {
    dir: PathBuf,
    manifest: Manifest,
    bytes: u64,
    /// The live shapes by increasing id: where each record is.
    slots: Vec<Slot>,
    /// Each slot's record when its segment was read whole; `None` for a mapped segment, whose
    /// records are decoded on each use (so that a long-running reader of a large index holds
    /// no more records than its callers do).
    records: Vec<Option<Arc<ShapeRecord<D>>>>,
    /// `starts[i]`: the live components of the shapes before slot `i` (the search's item
    /// numbers), one more entry than `slots`.
    starts: Vec<u64>,
    /// The memory-mapped segments slots point into.
    mapped: Vec<MappedSegment>,
    /// For each slot: its segment and position there (the search cache's key).
    pub(crate) origins: Vec<Origin>,
    /// The search structure, built on the first search (`search.rs`).
    pub(crate) search: OnceLock<Search<D>>,
    /// Which search structure the search builds.
    pub(crate) mode: SearchMode,
    /// How much of the inverted file an approximate search reads.
    pub(crate) effort: SearchEffort,
    load_time: Duration,
}

/// Slot `segment` value of a shape whose segment was read whole (its record is decoded).
const DECODED: u32 = u32::MAX;

/// Where a live shape's record is.
#[derive(Debug, Clone, Copy)]
struct Slot {
    id: ShapeId,
    /// Index in `IndexReader::mapped`, or [`DECODED`].
    segment: u32,
    /// Position in its segment.
    position: u32,
}

impl<const D: usize> std::fmt::Debug for IndexReader<D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("IndexReader")
            .field("dir", &self.dir)
            .field("generation", &self.manifest.generation)
            .field("shapes", &self.slots.len())
            .field("components", &self.component_count())
            .finish_non_exhaustive()
    }
}

impl<const D: usize> IndexReader<D> {
    /// Opens a snapshot of the index at `dir`: reads the manifest and every listed segment,
    /// verifying all checksums and decoding every record. The search structure is built (or
    /// read from the search cache) on the first search.
    ///
    /// Errors: [`IndexError::NotAnIndex`] if `dir` has no `MANIFEST`;
    /// [`IndexError::Corrupt`], [`IndexError::Incompatible`],
    /// [`IndexError::DimensionMismatch`] or [`IndexError::MissingSegment`] naming the file at
    /// fault. Never returns a partial snapshot.
    pub fn open(dir: impl AsRef<Path>) -> Result<Self> {
        Self::open_with(dir.as_ref(), false)
    }

    /// Opens a snapshot of the index at `dir` without reading its records: segments of format
    /// 5 are memory-mapped, their footers, tables (ids, record places, component counts) and
    /// descriptor blocks checked, and each record is decoded and checked against its own
    /// checksum when first asked for ([`IndexReader::get`]); the search reads descriptors in
    /// place. Older segments are read whole, as [`IndexReader::open`] does. Opening thus
    /// costs the tables (32 bytes per shape), not the records: what a process that answers
    /// queries on a large index wants. A damaged record is reported, naming its file, by
    /// the call that reads it; [`crate::verify`] checks every byte.
    ///
    /// Errors: as [`IndexReader::open`], for what it reads.
    pub fn open_mapped(dir: impl AsRef<Path>) -> Result<Self> {
        Self::open_with(dir.as_ref(), true)
    }

    fn open_with(dir: &Path, lazy: bool) -> Result<Self> {
        let mut attempt = 0;
        loop {
            attempt += 1;
            let manifest = Manifest::read(dir, Some(segment::dim_u32::<D>()))?;
            match Self::load(dir, manifest, lazy) {
                Err(e @ IndexError::MissingSegment { .. }) if attempt < OPEN_ATTEMPTS => {
                    // A writer may have committed and deleted the segment meanwhile.
                    let again = Manifest::read(dir, Some(segment::dim_u32::<D>()))?;
                    if !Self::generation_moved(dir, &e, &again) {
                        return Err(e);
                    }
                }
                other => return other,
            }
        }
    }

    /// Whether `again` no longer lists the segment of the `MissingSegment` error `e`.
    fn generation_moved(dir: &Path, e: &IndexError, again: &Manifest) -> bool {
        let IndexError::MissingSegment { segment, .. } = e else {
            return false;
        };
        !again
            .segments
            .iter()
            .any(|s| dir.join(segment_file_name(s.number)) == *segment)
    }

    fn load(dir: &Path, manifest: Manifest, lazy: bool) -> Result<Self> {
        let start = Instant::now();
        /// A segment as opened: mapped, or read whole.
        enum Opened<const D: usize> {
            Mapped(MappedSegment),
            Read(segment::Segment<D>),
        }
        // Segments are independent: open them in parallel. The first error in manifest order
        // is reported, so the message does not depend on scheduling.
        let segments: Vec<Result<Opened<D>>> = manifest
            .segments
            .par_iter()
            .map(|entry| {
                if lazy && let Some(m) = MappedSegment::open::<D>(dir, &manifest, entry)? {
                    return Ok(Opened::Mapped(m));
                }
                segment::read::<D>(dir, &manifest, entry).map(Opened::Read)
            })
            .collect();
        // (slot, record if decoded, origin) of every live shape
        let mut live: Vec<(Slot, Option<ShapeRecord<D>>, Origin)> = Vec::new();
        let mut mapped = Vec::new();
        let mut bytes = 0u64;
        for (entry, seg) in manifest.segments.iter().zip(segments) {
            bytes += entry.len;
            let key = (entry.number, entry.len, entry.checksum);
            match seg? {
                Opened::Mapped(m) => {
                    let index = u32::try_from(mapped.len()).unwrap_or(DECODED - 1);
                    for (position, e) in m.entries().iter().enumerate() {
                        if !manifest.is_tombstoned(e.id) {
                            let slot = Slot {
                                id: e.id,
                                segment: index,
                                position: position as u32,
                            };
                            let origin = Origin {
                                segment: key,
                                position: position as u32,
                                components: e.components,
                            };
                            live.push((slot, None, origin));
                        }
                    }
                    mapped.push(m);
                }
                Opened::Read(seg) => {
                    for (position, (c, record)) in
                        seg.head.catalogue.into_iter().zip(seg.records).enumerate()
                    {
                        if !manifest.is_tombstoned(c.id) {
                            let slot = Slot {
                                id: c.id,
                                segment: DECODED,
                                position: position as u32,
                            };
                            let origin = Origin {
                                segment: key,
                                position: position as u32,
                                components: record.components.len() as u32,
                            };
                            live.push((slot, Some(record), origin));
                        }
                    }
                }
            }
        }
        bytes += manifest.to_bytes().map(|b| b.len() as u64).unwrap_or(0);
        live.sort_by_key(|s| s.0.id);
        let mut starts = Vec::with_capacity(live.len() + 1);
        let mut total = 0u64;
        starts.push(0);
        for (_, _, o) in &live {
            total += u64::from(o.components);
            starts.push(total);
        }
        if u32::try_from(total).is_err() || u32::try_from(live.len()).is_err() {
            return Err(IndexError::InvalidQuery {
                reason: format!("{total} components are more than one index can search"),
            });
        }
        let mut slots = Vec::with_capacity(live.len());
        let mut records = Vec::with_capacity(live.len());
        let mut origins = Vec::with_capacity(live.len());
        for (slot, record, origin) in live {
            slots.push(slot);
            records.push(record.map(Arc::new));
            origins.push(origin);
        }
        Ok(IndexReader {
            dir: dir.to_path_buf(),
            manifest,
            bytes,
            slots,
            records,
            starts,
            mapped,
            origins,
            search: OnceLock::new(),
            mode: SearchMode::Auto,
            effort: SearchEffort::default(),
            load_time: start.elapsed(),
        })
    }

    /// What identifies the live descriptors of this snapshot: a hash of the descriptor length,
    /// every listed segment's number, length and checksum (segments are immutable, and their
    /// checksums were verified on open) and the tombstones.
    pub(crate) fn snapshot_key(&self) -> u64 {
        let mut h = xxhash_rust::xxh3::Xxh3Default::new();
        h.update(&(D as u64).to_le_bytes());
        for s in &self.manifest.segments {
            for v in [s.number, s.len, s.checksum] {
                h.update(&v.to_le_bytes());
            }
        }
        h.update(&u64::MAX.to_le_bytes());
        for t in &self.manifest.tombstones {
            h.update(&t.0.to_le_bytes());
        }
        h.digest()
    }

    /// Time [`IndexReader::open`] spent reading, checking and decoding the files (the
    /// KD-tree is built later, see [`IndexReader::prepare_search`]).
    pub fn load_time(&self) -> Duration {
        self.load_time
    }

    /// The index directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// How the descriptors of this index were made (empty when no profile is recorded, as in
    /// every format-1 index; see [`crate::IndexWriter::ensure_profile`]).
    pub fn profile(&self) -> &str {
        &self.manifest.profile
    }

    /// Manifest generation of this snapshot.
    pub fn generation(&self) -> u64 {
        self.manifest.generation
    }

    /// Number of live shapes.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Whether the snapshot holds no live shape.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// The ids of the live shapes, increasing.
    pub fn ids(&self) -> impl ExactSizeIterator<Item = ShapeId> + '_ {
        self.slots.iter().map(|s| s.id)
    }

    /// The record of slot `i` (`i < len()`): the snapshot's, or decoded from its mapped
    /// segment.
    fn record_at(&self, i: usize) -> Result<Arc<ShapeRecord<D>>> {
        if let Some(r) = &self.records[i] {
            return Ok(Arc::clone(r));
        }
        let slot = self.slots[i];
        let m = self.mapped_of(slot)?;
        m.record::<D>(slot.position as usize).map(Arc::new)
    }

    /// The mapped segment of `slot`, a slot without a record (which points into one).
    fn mapped_of(&self, slot: Slot) -> Result<&MappedSegment> {
        self.mapped
            .get(slot.segment as usize)
            .ok_or_else(|| IndexError::InvalidQuery {
                reason: format!("shape {} has no record", slot.id),
            })
    }

    /// All live shapes, by increasing id (records of mapped segments decoded, in parallel).
    ///
    /// Errors: [`IndexError::Corrupt`] naming the segment of the first damaged record.
    pub fn shapes(&self) -> Result<Vec<IndexedShape<D>>> {
        (0..self.slots.len())
            .into_par_iter()
            .map(|i| {
                Ok(IndexedShape {
                    id: self.slots[i].id,
                    record: self.record_at(i)?,
                })
            })
            .collect()
    }

    /// The record of shape `id`, if it is live in this snapshot (decoded from a mapped
    /// segment on each call).
    ///
    /// Errors: [`IndexError::Corrupt`] if its record is damaged.
    pub fn get(&self, id: ShapeId) -> Result<Option<Arc<ShapeRecord<D>>>> {
        match self.slots.binary_search_by_key(&id, |s| s.id) {
            Ok(i) => self.record_at(i).map(Some),
            Err(_) => Ok(None),
        }
    }

    /// The component descriptors of shape `id`, if it is live in this snapshot, in component
    /// order: borrowed in place from a mapped segment's descriptor block without decoding the
    /// record (and so without its checksum, as the nearest-neighbour search reads them; a
    /// damaged record is still found by [`IndexReader::get`]).
    ///
    /// Errors: [`IndexError::Corrupt`] if the segment's table places them outside its block.
    pub fn descriptors(&self, id: ShapeId) -> Result<Option<Cow<'_, [[f32; D]]>>> {
        let Ok(i) = self.slots.binary_search_by_key(&id, |s| s.id) else {
            return Ok(None);
        };
        if let Some(r) = &self.records[i] {
            return Ok(Some(r.components.iter().map(|c| c.descriptor).collect()));
        }
        let slot = self.slots[i];
        let m = self.mapped_of(slot)?;
        let flat = m.descriptors(slot.position as usize, D).ok_or_else(|| {
            m.malformed(format!(
                "the descriptors of shape {id} are beyond the descriptor block"
            ))
        })?;
        // `descriptors` gives whole records' descriptors, `D` values each
        let (arrays, _) = flat.as_chunks::<D>();
        Ok(Some(Cow::Borrowed(arrays)))
    }

    /// Asks the system to start reading the records of `ids` that lie in memory-mapped
    /// segments (their bytes and descriptors), so that the [`IndexReader::get`] calls that
    /// follow wait on those reads together rather than one after another: on an index larger
    /// than memory, a query's candidates are read from the disk at once instead of in turn.
    /// A hint only: nothing is read or checked here; ids not live are skipped.
    pub fn prefetch(&self, ids: &[ShapeId]) {
        self.prefetch_parts(ids, true);
    }

    /// [`IndexReader::prefetch`] of the descriptors alone, for the
    /// [`IndexReader::descriptors`] calls that follow: a query that bounds many candidates by
    /// their descriptors before it reads the records of a few asks the disk for less.
    pub fn prefetch_descriptors(&self, ids: &[ShapeId]) {
        self.prefetch_parts(ids, false);
    }

    fn prefetch_parts(&self, ids: &[ShapeId], records: bool) {
        for id in ids {
            if let Ok(i) = self.slots.binary_search_by_key(id, |s| s.id) {
                let slot = self.slots[i];
                if let Some(m) = self.mapped.get(slot.segment as usize) {
                    m.prefetch(slot.position as usize, D, records);
                }
            }
        }
    }

    /// The canonical path of slot `i`, without decoding a mapped record.
    fn canonical_path_at(&self, i: usize) -> Result<&Path> {
        let slot = self.slots[i];
        match self.mapped.get(slot.segment as usize) {
            Some(m) => {
                let head = m.head()?;
                Ok(Path::new(
                    head.catalogue
                        .get(slot.position as usize)
                        .map_or("", |c| c.canonical_path.as_str()),
                ))
            }
            None => Ok(self.records[i]
                .as_ref()
                .map_or(Path::new(""), |r| r.canonical_path.as_path())),
        }
    }

    /// The live shape whose canonical path is `path` (taken as given, then canonicalised).
    ///
    /// Errors: [`IndexError::Corrupt`] if a segment head or that shape's record is damaged.
    pub fn find_path(&self, path: &Path) -> Result<Option<IndexedShape<D>>> {
        let canon = canonical_path(path);
        for want in [path, canon.as_path()] {
            for i in 0..self.slots.len() {
                if self.canonical_path_at(i)? == want {
                    return Ok(Some(IndexedShape {
                        id: self.slots[i].id,
                        record: self.record_at(i)?,
                    }));
                }
            }
        }
        Ok(None)
    }

    /// Number of live components (the search's items).
    pub fn component_count(&self) -> usize {
        self.starts.last().copied().unwrap_or(0) as usize
    }

    /// Summary numbers.
    pub fn stats(&self) -> IndexStats {
        IndexStats {
            dir: self.dir.clone(),
            format_version: FORMAT_VERSION,
            generation: self.manifest.generation,
            dim: D,
            shapes: self.slots.len(),
            components: self.component_count(),
            segments: self.manifest.segments.len(),
            tombstones: self.manifest.tombstones.len(),
            bytes: self.bytes,
        }
    }

    /// The slot and component of search item `item`.
    fn owner(&self, item: usize) -> Option<(usize, usize)> {
        if item >= self.component_count() {
            return None;
        }
        let slot = self.starts.partition_point(|&s| s <= item as u64) - 1;
        Some((slot, item - self.starts[slot] as usize))
    }

    /// The descriptor of search item `item`, in place (a mapped segment's block, or a decoded
    /// record).
    pub(crate) fn descriptor_slice(&self, item: usize) -> Option<&[f32]> {
        let (slot, c) = self.owner(item)?;
        let s = self.slots[slot];
        match self.mapped.get(s.segment as usize) {
            Some(m) => m
                .descriptors(s.position as usize, D)?
                .get(c * D..(c + 1) * D),
            None => Some(&self.records[slot].as_ref()?.components.get(c)?.descriptor),
        }
    }

    pub(crate) fn descriptor(&self, item: usize) -> Option<(ShapeId, usize, &[f32; D])> {
        let (slot, c) = self.owner(item)?;
        let d = self.descriptor_slice(item)?;
        Some((self.slots[slot].id, c, d.try_into().ok()?))
    }

    /// The shape and component of search item `item`.
    pub(crate) fn item_owner(&self, item: usize) -> Option<(ShapeId, usize)> {
        let (slot, c) = self.owner(item)?;
        Some((self.slots[slot].id, c))
    }

    /// Asks the system to start reading the descriptor of search item `item` when it lies in a
    /// memory-mapped segment (a hint: nothing is read or checked here).
    pub(crate) fn prefetch_item(&self, item: usize) {
        if let Some((slot, component)) = self.owner(item) {
            let s = self.slots[slot];
            if let Some(m) = self.mapped.get(s.segment as usize) {
                m.prefetch_descriptor(s.position as usize, component, D);
            }
        }
    }
}
