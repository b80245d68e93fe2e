//! [`IndexReader`]: a consistent, read-only snapshot of an index, with a search over every
//! live component descriptor.
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
//!   only (32 bytes per shape: 4 ms at 100,000 shapes against 4.9 s for reading them whole,
//!   56 ms at a million; BENCHMARKS.md, "A million shapes"); the search reads descriptors in
//!   place from the maps, and each record is decoded and checked when asked for, on each
//!   call (what a process answering queries wants: it holds the tables, the search structure
//!   and the records its callers hold).
//!
//! Search, built on the first search (or [`IndexReader::prepare_search`]) so that listing or
//! looking up shapes does not pay for it:
//! - below [`IVF_MIN_COMPONENTS`] components, exact:
//!   [`kiddo::immutable::float::kdtree::ImmutableKdTree`] (bucket 128, `u32` items) over all
//!   live descriptors. Bucket 128 measured 3× faster than kiddo's default 32 for 32-value
//!   descriptors. Building costs O(n log n); a query is O(log n) on well-clustered data and
//!   degrades towards a linear scan for high-dimensional data — which 64-value descriptors
//!   are: at 84,000 components the tree took 280 ms for a query's 84 searches;
//! - from there, approximate: an inverted file with a two-level k-means quantiser and
//!   residuals coded in two bytes per value (`ivf`): about 12 cells of 512 codes scanned per
//!   search by their first bytes, the nearest ranked again by their whole codes, no descriptor
//!   read (BENCHMARKS.md, "Candidate search").
//!   [`SearchMode`] chooses otherwise; an exact search of more than [`EXACT_TREE_MAX`]
//!   components scans every descriptor in place instead of copying them into a tree.
//!
//! Neither structure is part of the index on disk: each spans all segments, so every add would
//! rewrite it whole. The inverted file is cached instead ([`SEARCH_CACHE_NAME`]): the reader
//! that builds it writes it, with each record's cells and codes by segment; later readers of
//! the same snapshot read it, and readers of a later snapshot (after an add or a remove) update
//! it — new records' parts go to their nearest cells, removed ones are left out — until the
//! collection has doubled or halved ([`SearchSource`]; `index/README.md`, "Search cache").
//! Distances are squared Euclidean: recomputed from the stored descriptors for the exact
//! search, as the codes give them for the approximate one ([`ComponentMatch::distance_sq`]).

use std::borrow::Cow;
use std::num::NonZero;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;

use crate::dir::{SEARCH_CACHE_NAME, segment_file_name};
use crate::error::{IndexError, Result};
use crate::ivf::{Ivf, Origin, SearchEffort};
use crate::manifest::Manifest;
use crate::record::{ShapeId, ShapeRecord, canonical_path};
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

/// One result of a component search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComponentMatch {
    /// The shape the component belongs to.
    pub shape: ShapeId,
    /// Index of the component in the shape's `components`.
    pub component: usize,
    /// Squared Euclidean distance between the query and the component's descriptor; with an
    /// approximate search ([`IndexReader::search_is_approximate`]), the distance to the
    /// descriptor as the inverted file's code of it stands for (its square root within
    /// [`IndexReader::code_error`] of the true one), so that descriptors are read only for
    /// the few components whose codes are too close to the `k`-th place to tell whether they
    /// are among the `k` nearest; theirs is the true distance.
    pub distance_sq: f32,
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

type Tree<const D: usize> = ImmutableKdTree<f32, u32, D, 128>;

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
    origins: Vec<Origin>,
    search: OnceLock<Search<D>>,
    mode: SearchMode,
    effort: SearchEffort,
    load_time: Duration,
}

/// Components from which [`SearchMode::Auto`] searches an inverted file instead of the exact
/// KD-tree (about 390 shapes of 84 parts).
pub const IVF_MIN_COMPONENTS: usize = 32_768;

/// Components above which the exact search ([`SearchMode::Exact`]) scans the descriptors in
/// place, every query part of a batch in one pass, instead of building a KD-tree over a copy
/// of them (`4·D + 4` bytes per component: 1 GiB at 64 values); at that size the tree is near
/// a linear scan anyway for 64-value descriptors (BENCHMARKS.md, "Candidate search").
pub const EXACT_TREE_MAX: usize = 1 << 22;

/// The live descriptors of a snapshot, in item order, read in place.
struct Live<'a, const D: usize>(&'a IndexReader<D>);

impl<const D: usize> crate::ivf::Points for Live<'_, D> {
    fn len(&self) -> usize {
        self.0.component_count()
    }
    fn point(&self, i: u32) -> &[f32] {
        // Items below `len()` always have a descriptor (see `IndexReader::descriptor_slice`).
        self.0.descriptor_slice(i as usize).unwrap_or(&[])
    }
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

/// How [`IndexReader::nearest_components`] searches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SearchMode {
    /// Exact below [`IVF_MIN_COMPONENTS`] components, approximate from there (the default).
    #[default]
    Auto,
    /// Always exact (the KD-tree).
    Exact,
    /// Always the inverted file (approximate; see `ivf`).
    Approximate,
}

/// Where a snapshot's search structure came from ([`IndexReader::search_source`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SearchSource {
    /// Built from the descriptors: the exact KD-tree, or an inverted file without a usable
    /// search cache.
    Built,
    /// The inverted file read from the search cache written for this very snapshot.
    Cache,
    /// The inverted file read from a search cache written for an earlier snapshot: the
    /// `assigned` components of shapes added since were put in their nearest cells (no new
    /// k-means), those of shapes removed since left out. The cache is rewritten for this
    /// snapshot.
    CacheUpdated {
        /// Components put in their nearest cells.
        assigned: usize,
    },
}

/// The search structure, built on first use.
struct Search<const D: usize> {
    /// `None` when there is no component, when the inverted file is used, or when building the
    /// tree failed (then searches scan linearly).
    tree: Option<Tree<D>>,
    /// The inverted file, when the mode asks for it.
    ivf: Option<Ivf>,
    /// Where the structure came from.
    source: SearchSource,
    build_time: Duration,
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

    /// This snapshot searching as `mode` says (the search structure is built again on the next
    /// search).
    pub fn with_search_mode(mut self, mode: SearchMode) -> Self {
        self.mode = mode;
        self.search = OnceLock::new();
        self
    }

    /// This snapshot searching its inverted file with `effort` (no effect on the exact
    /// search; the search structure is kept).
    pub fn with_search_effort(mut self, effort: SearchEffort) -> Self {
        self.effort = effort;
        self
    }

    /// How much of the inverted file an approximate search reads.
    pub fn search_effort(&self) -> SearchEffort {
        self.effort
    }

    /// Whether searches are approximate (the inverted file) for this snapshot and mode.
    pub fn search_is_approximate(&self) -> bool {
        match self.mode {
            SearchMode::Auto => self.component_count() >= IVF_MIN_COMPONENTS,
            SearchMode::Exact => false,
            SearchMode::Approximate => self.component_count() > 0,
        }
    }

    /// Builds the search structure now if it is not built yet (searches build it on first
    /// use). Returns the time the build took (once built, always the same value).
    pub fn prepare_search(&self) -> Duration {
        self.search().build_time
    }

    /// Whether the search structure (building it if needed) was read from the index's search
    /// cache ([`SEARCH_CACHE_NAME`]), as it was or updated, instead of being built.
    pub fn search_was_cached(&self) -> bool {
        self.search_source() != SearchSource::Built
    }

    /// Where the search structure (building it if needed) came from.
    pub fn search_source(&self) -> SearchSource {
        self.search().source
    }

    /// What identifies the live descriptors of this snapshot: a hash of the descriptor length,
    /// every listed segment's number, length and checksum (segments are immutable, and their
    /// checksums were verified on open) and the tombstones.
    fn snapshot_key(&self) -> u64 {
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

    /// The inverted file of the live descriptors: read from the search cache when it fits this
    /// snapshot (records of segments added since put in their nearest cells, those removed
    /// since left out; the cache is then rewritten for this snapshot), else built and written
    /// there for the next reader (best effort: a read-only index folder, a damaged or stale
    /// cache only cost a build).
    fn inverted_file(&self) -> (Ivf, SearchSource) {
        let live = Live(self);
        let key = self.snapshot_key();
        let path = self.dir.join(SEARCH_CACHE_NAME);
        let mapped = crate::file::open_regular(&path)
            .ok()
            .and_then(|f| crate::file::map(&f, &path).ok());
        if let Some(bytes) = mapped
            && let Some(c) = Ivf::from_cache(&path, &bytes, key, &live, D, &self.origins)
        {
            drop(bytes);
            if c.exact {
                return (c.ivf, SearchSource::Cache);
            }
            let _ = c
                .ivf
                .write_cache(&self.dir, SEARCH_CACHE_NAME, key, &self.origins);
            return (
                c.ivf,
                SearchSource::CacheUpdated {
                    assigned: c.assigned,
                },
            );
        }
        let ivf = Ivf::build(&live, D);
        let _ = ivf.write_cache(&self.dir, SEARCH_CACHE_NAME, key, &self.origins);
        (ivf, SearchSource::Built)
    }

    /// How far the square root of an approximate search's distance may be from the true
    /// distance, for descriptors within the ranges its quantiser was fitted on (building the
    /// search structure if needed); 0 for the exact search.
    pub fn code_error(&self) -> f32 {
        self.search().ivf.as_ref().map_or(0.0, Ivf::code_error)
    }

    /// Bytes held by the search structure (building it if needed): the inverted file's, or
    /// an estimate of the KD-tree's (its copy of the descriptors and item ids).
    pub fn search_bytes(&self) -> usize {
        let s = self.search();
        match (&s.ivf, &s.tree) {
            (Some(ivf), _) => ivf.bytes(),
            (None, Some(_)) => self.component_count() * (4 * D + 4),
            (None, None) => 0,
        }
    }

    fn search(&self) -> &Search<D> {
        self.search.get_or_init(|| {
            let start = Instant::now();
            if self.search_is_approximate() {
                let (ivf, source) = self.inverted_file();
                return Search {
                    tree: None,
                    ivf: Some(ivf),
                    source,
                    build_time: start.elapsed(),
                };
            }
            if self.component_count() > EXACT_TREE_MAX {
                // exact searches scan the descriptors in place (`scan`)
                return Search {
                    tree: None,
                    ivf: None,
                    source: SearchSource::Built,
                    build_time: start.elapsed(),
                };
            }
            let points: Vec<[f32; D]> = (0..self.component_count())
                .filter_map(|i| self.descriptor(i).map(|(_, _, d)| *d))
                .collect();
            let tree = if points.is_empty() {
                None
            } else {
                // kiddo documents no panic for ImmutableKdTree construction, but it is
                // third-party code fed with data from disk: if it ever panics, fall back to
                // linear scans rather than taking the process down.
                std::panic::catch_unwind(|| Tree::<D>::new_from_slice(&points)).ok()
            };
            Search {
                tree,
                ivf: None,
                source: SearchSource::Built,
                build_time: start.elapsed(),
            }
        })
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
    fn descriptor_slice(&self, item: usize) -> Option<&[f32]> {
        let (slot, c) = self.owner(item)?;
        let s = self.slots[slot];
        match self.mapped.get(s.segment as usize) {
            Some(m) => m
                .descriptors(s.position as usize, D)?
                .get(c * D..(c + 1) * D),
            None => Some(&self.records[slot].as_ref()?.components.get(c)?.descriptor),
        }
    }

    fn descriptor(&self, item: usize) -> Option<(ShapeId, usize, &[f32; D])> {
        let (slot, c) = self.owner(item)?;
        let d = self.descriptor_slice(item)?;
        Some((self.slots[slot].id, c, d.try_into().ok()?))
    }

    /// The `k` live components nearest to `query` (squared Euclidean distance), closest first;
    /// ties are ordered by shape id then component index. Fewer if the index has fewer. The
    /// approximate search ranks by, and returns, the distances the inverted file's codes give
    /// (see [`ComponentMatch::distance_sq`]).
    ///
    /// Errors with [`IndexError::InvalidQuery`] if `query` holds a NaN or infinity.
    pub fn nearest_components(&self, query: &[f32; D], k: usize) -> Result<Vec<ComponentMatch>> {
        check_finite(std::slice::from_ref(query))?;
        let Some(qty) = NonZero::new(k) else {
            return Ok(Vec::new());
        };
        let search = self.search();
        let items: Vec<usize> = match (&search.ivf, &search.tree) {
            (Some(ivf), _) => {
                let mut out = self.ivf_nearest(ivf, std::slice::from_ref(query), qty.get());
                return Ok(out.pop().unwrap_or_default());
            }
            (None, Some(tree)) => tree
                .nearest_n::<SquaredEuclidean>(query, qty)
                .into_iter()
                .map(|n| n.item as usize)
                .collect(),
            (None, None) => return Ok(self.nearest_linear(query, k)),
        };
        let mut out: Vec<ComponentMatch> = items
            .into_iter()
            .filter_map(|i| self.descriptor(i))
            .map(|(shape, component, d)| ComponentMatch {
                shape,
                component,
                distance_sq: squared_distance(query, d),
            })
            .collect();
        sort_matches(&mut out);
        Ok(out)
    }

    /// [`IndexReader::nearest_components`] for several query descriptors (e.g. all components
    /// of a query shape); one result list per query, in order. Queries run in parallel
    /// (rayon).
    pub fn nearest_components_batch(
        &self,
        queries: &[[f32; D]],
        k: usize,
    ) -> Result<Vec<Vec<ComponentMatch>>> {
        check_finite(queries)?;
        let search = self.search();
        match (&search.ivf, &search.tree) {
            (Some(ivf), _) => Ok(self.ivf_nearest(ivf, queries, k)),
            (None, None) => Ok(self.scan(queries, k)),
            (None, Some(_)) => queries
                .par_iter()
                .map(|q| self.nearest_components(q, k))
                .collect(),
        }
    }

    /// The approximate search of `queries` (finite), in parallel: distances as the codes give
    /// them, except for the codes too close to the `k`-th place to tell whether they are
    /// among the `k` nearest, whose descriptors are read (asked of the disk all at once, for
    /// all queries, before any is read).
    fn ivf_nearest(&self, ivf: &Ivf, queries: &[[f32; D]], k: usize) -> Vec<Vec<ComponentMatch>> {
        let found: Vec<Vec<(u32, f32, f32)>> = queries
            .par_iter()
            .map(|q| ivf.search_bounded(q, k, self.effort))
            .collect();
        let settled: Vec<crate::ivf::Settle> = found
            .iter()
            .map(|f| crate::ivf::Settle::new(f, k))
            .collect();
        for &i in settled.iter().flat_map(|s| s.open()) {
            if let Some((slot, component)) = self.owner(i as usize) {
                let s = self.slots[slot];
                if let Some(m) = self.mapped.get(s.segment as usize) {
                    m.prefetch_descriptor(s.position as usize, component, D);
                }
            }
        }
        queries
            .par_iter()
            .zip(settled)
            .map(|(query, settle)| {
                let exact = |i: u32| {
                    self.descriptor_slice(i as usize)
                        .map(|d| crate::ivf::distance_sq(query, d))
                };
                let mut out: Vec<ComponentMatch> = settle
                    .finish(exact)
                    .into_iter()
                    .filter_map(|(i, distance_sq)| {
                        let (slot, component) = self.owner(i as usize)?;
                        Some(ComponentMatch {
                            shape: self.slots[slot].id,
                            component,
                            distance_sq,
                        })
                    })
                    .collect();
                sort_matches(&mut out);
                out
            })
            .collect()
    }

    /// Exact `k` nearest components by scanning every descriptor (the oracle the KD-tree is
    /// tested against, and the fallback if the tree could not be built).
    pub fn nearest_linear(&self, query: &[f32; D], k: usize) -> Vec<ComponentMatch> {
        self.scan(std::slice::from_ref(query), k)
            .pop()
            .unwrap_or_default()
    }

    /// The exact `k` nearest components of each of `queries`, by one parallel pass over every
    /// descriptor (read in place): what the exact search does above [`EXACT_TREE_MAX`]
    /// components. The descriptors are taken a block at a time, and the block's squared
    /// distances to every query as `‖x‖² + ‖q‖² − 2 x·q`, the products as one matrix product
    /// (faer); a block's distances that cannot enter a query's kept ones are skipped eight at a
    /// time. The `2k` nearest so ranked are measured again in kiddo's summation order (the
    /// expansion loses digits to cancellation) and the `k` best kept, ordered as
    /// [`IndexReader::nearest_components`] orders them. Batching many queries into one call
    /// reads the descriptors once for all of them.
    fn scan(&self, queries: &[[f32; D]], k: usize) -> Vec<Vec<ComponentMatch>> {
        if k == 0 || queries.is_empty() {
            return vec![Vec::new(); queries.len()];
        }
        let keep = k.saturating_mul(2);
        let nq = queries.len();
        let q_flat: Vec<f32> = queries.iter().flatten().copied().collect();
        let q_norm: Vec<f32> = queries.iter().map(|q| norm_sq::<D>(q)).collect();
        // descriptors per block: the block's distance matrix stays within 4M values
        let block = ((1usize << 22) / nq).clamp(64, 4096);
        /// Per query: the kept (distance, item) pairs and the distance they must beat.
        struct Kept {
            found: Vec<Vec<(f32, u32)>>,
            bound: Vec<f32>,
        }
        let prune = |v: &mut Vec<(f32, u32)>| -> f32 {
            if v.len() >= keep {
                v.select_nth_unstable_by(keep - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                v.truncate(keep);
                v.iter().map(|x| x.0).fold(f32::NEG_INFINITY, f32::max)
            } else {
                f32::INFINITY
            }
        };
        let new_kept = || Kept {
            found: vec![Vec::new(); nq],
            bound: vec![f32::INFINITY; nq],
        };
        let n = self.component_count();
        let kept = (0..n.div_ceil(block))
            .into_par_iter()
            .fold(new_kept, |mut acc, chunk| {
                let items = chunk * block..((chunk + 1) * block).min(n);
                let mut x = Vec::with_capacity(items.len() * D);
                let mut ids = Vec::with_capacity(items.len());
                for i in items {
                    if let Some(d) = self.descriptor_slice(i) {
                        x.extend_from_slice(d);
                        ids.push(i as u32);
                    }
                }
                let b = ids.len();
                if b == 0 {
                    return acc;
                }
                let x_norm: Vec<f32> = x.chunks_exact(D).map(norm_sq::<D>).collect();
                let mut g = faer::Mat::<f32>::zeros(b, nq);
                faer::linalg::matmul::matmul(
                    g.as_mut(),
                    faer::Accum::Replace,
                    faer::MatRef::from_row_major_slice(&x, b, D),
                    faer::MatRef::from_row_major_slice(&q_flat, nq, D).transpose(),
                    -2.0f32,
                    faer::Par::Seq,
                );
                let mut dist = vec![0f32; b];
                for (q, &qn) in q_norm.iter().enumerate() {
                    let col = g.col(q);
                    for (r, (out, xn)) in dist.iter_mut().zip(&x_norm).enumerate() {
                        *out = xn + col[r];
                    }
                    // compared with the bound less the query's norm, eight at a time
                    let beat = acc.bound[q] - qn;
                    for (c, eight) in dist.chunks(8).enumerate() {
                        if eight.iter().copied().fold(f32::INFINITY, f32::min) >= beat {
                            continue;
                        }
                        for (r, &v) in eight.iter().enumerate() {
                            if v < beat {
                                let at = c * 8 + r;
                                acc.found[q].push((v + qn, ids[at]));
                            }
                        }
                    }
                    if acc.found[q].len() >= 2 * keep.max(64) {
                        acc.bound[q] = prune(&mut acc.found[q]);
                    }
                }
                acc
            })
            .reduce(new_kept, |mut a, b| {
                for (q, v) in b.found.into_iter().enumerate() {
                    a.found[q].extend(v);
                    prune(&mut a.found[q]);
                }
                a
            });
        kept.found
            .into_iter()
            .zip(queries)
            .map(|(mut v, q)| {
                prune(&mut v);
                let mut out: Vec<ComponentMatch> = v
                    .into_iter()
                    .filter_map(|(_, i)| self.descriptor(i as usize))
                    .map(|(shape, component, d)| ComponentMatch {
                        shape,
                        component,
                        distance_sq: squared_distance(q, d),
                    })
                    .collect();
                sort_matches(&mut out);
                out.truncate(k);
                out
            })
            .collect()
    }
}

/// Squared norm of `v`: its vectorised squared distance to the origin.
fn norm_sq<const D: usize>(v: &[f32]) -> f32 {
    crate::ivf::distance_sq(v, &[0.0; D])
}

/// [`IndexError::InvalidQuery`] naming the first value of `queries` that is NaN or infinite.
fn check_finite<const D: usize>(queries: &[[f32; D]]) -> Result<()> {
    match queries.iter().flatten().position(|v| !v.is_finite()) {
        Some(i) => Err(IndexError::InvalidQuery {
            reason: format!("descriptor value {} is not finite", i % D.max(1)),
        }),
        None => Ok(()),
    }
}

fn sort_matches(v: &mut [ComponentMatch]) {
    v.sort_by(|a, b| {
        a.distance_sq
            .total_cmp(&b.distance_sq)
            .then(a.shape.cmp(&b.shape))
            .then(a.component.cmp(&b.component))
    });
}

/// Squared Euclidean distance, summed in the same order as kiddo's `SquaredEuclidean`.
pub fn squared_distance<const D: usize>(a: &[f32; D], b: &[f32; D]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            let d = x - y;
            d * d
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{IndexWriter, synthetic};

    /// One pass for several queries finds, for each, what the KD-tree finds.
    #[test]
    fn a_batched_scan_equals_the_tree() {
        const D: usize = 6;
        let dir = tempfile::tempdir().unwrap();
        let mut w = IndexWriter::<D>::create_or_open(dir.path()).unwrap();
        w.add_batch(synthetic::records::<D>(5, 0..300)).unwrap();
        w.add_batch(synthetic::records::<D>(5, 300..450)).unwrap();
        drop(w);
        let r = IndexReader::<D>::open_mapped(dir.path()).unwrap();
        let queries: Vec<[f32; D]> = (0..7)
            .map(|i| {
                let s = &r.shapes().unwrap()[i * 31];
                let mut q = s.record.components[0].descriptor;
                q[0] += 0.01 * i as f32;
                q
            })
            .collect();
        for k in [1, 5, 64] {
            let scanned = r.scan(&queries, k);
            for (q, got) in queries.iter().zip(&scanned) {
                assert_eq!(got, &r.nearest_components(q, k).unwrap(), "k {k}");
            }
        }
        assert!(r.scan(&queries, 0).iter().all(Vec::is_empty));
    }
}
