//! [`IndexReader`]: a consistent, read-only snapshot of an index, with a KD-tree over every
//! live component descriptor.
//!
//! Opening reads `MANIFEST` once, then the immutable segment files it lists, checking every
//! footer, checksum and length against the manifest. Writers never modify a file in place, so
//! the snapshot is consistent while an add runs. The one race left — a concurrent writer
//! deleting a segment (after a remove or compact) between our reading the manifest and the
//! segment — shows up as a missing segment; the reader then rereads the manifest and, if its
//! generation moved on, starts over (a few times), so only a segment missing from the
//! *current* manifest is reported as [`IndexError::MissingSegment`].
//!
//! Search, built on the first search (or [`IndexReader::prepare_search`]) so that listing or
//! looking up shapes does not pay for it:
//! - below [`IVF_MIN_COMPONENTS`] components, exact:
//!   [`kiddo::immutable::float::kdtree::ImmutableKdTree`] (bucket 128, `u32` items) over all
//!   live descriptors. Bucket 128 measured 3× faster than kiddo's default 32 for 32-value
//!   descriptors. Building costs O(n log n); a query is O(log n) on well-clustered data and
//!   degrades towards a linear scan for high-dimensional data — which 64-value descriptors
//!   are: at 84,000 components the tree took 280 ms for a query's 84 searches;
//! - from there, approximate: an inverted file with a two-level k-means quantiser (`ivf`),
//!   about 12 cells of 512 descriptors scanned per search (9 ms for the same searches, the
//!   top 10 of the ranking equal to the exact one's for 99 of 100 queries; BENCHMARKS.md,
//!   "Candidate search"). [`SearchMode`] chooses otherwise.
//!
//! Neither structure is part of the index on disk: each spans all segments, so every add would
//! rewrite it whole. The inverted file is cached instead ([`SEARCH_CACHE_NAME`]): the reader
//! that builds it writes it, with each record's cells by segment; later readers of the same
//! snapshot read it, and readers of a later snapshot (after an add or a remove) update it —
//! new records' parts go to their nearest cells, removed ones are left out — until the
//! collection has doubled or halved ([`SearchSource`]; `index/README.md`, "Search cache").
//! Distances are squared Euclidean, recomputed from the stored descriptors.

use std::num::NonZero;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use rayon::prelude::*;

use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;

use crate::FORMAT_VERSION;
use crate::error::{IndexError, Result};
use crate::ivf::{Ivf, Origin};
use crate::manifest::{Manifest, segment_file_name};
use crate::record::{ShapeId, ShapeRecord, canonical_path};
use crate::segment;

/// A live shape of a snapshot.
#[derive(Debug, Clone, PartialEq)]
pub struct IndexedShape<const D: usize> {
    /// Its id.
    pub id: ShapeId,
    /// Its record.
    pub record: ShapeRecord<D>,
}

/// One result of a component search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComponentMatch {
    /// The shape the component belongs to.
    pub shape: ShapeId,
    /// Index of the component in the shape's `components`.
    pub component: usize,
    /// Squared Euclidean distance between the query and the component's descriptor.
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
    shapes: Vec<IndexedShape<D>>,
    /// For tree item `i`: (position in `shapes`, component index).
    owners: Vec<(u32, u32)>,
    /// For each of `shapes`: its segment and position there (the search cache's key).
    origins: Vec<Origin>,
    search: OnceLock<Search<D>>,
    mode: SearchMode,
    load_time: Duration,
}

/// Components from which [`SearchMode::Auto`] searches an inverted file instead of the exact
/// KD-tree (about 390 shapes of 84 parts).
pub const IVF_MIN_COMPONENTS: usize = 32_768;

/// The live descriptors of a snapshot, in item order (as `owners` lists them), read in place.
struct Live<'a, const D: usize> {
    shapes: &'a [IndexedShape<D>],
    owners: &'a [(u32, u32)],
}

impl<const D: usize> crate::ivf::Points for Live<'_, D> {
    fn len(&self) -> usize {
        self.owners.len()
    }
    fn point(&self, i: u32) -> &[f32] {
        let (pos, ci) = self.owners[i as usize];
        &self.shapes[pos as usize].record.components[ci as usize].descriptor
    }
}

/// The file in an index folder that caches the inverted file of its current descriptors
/// (derived data: any reader may rewrite it; a damaged or stale one is rebuilt).
pub const SEARCH_CACHE_NAME: &str = "SEARCH-CACHE";

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
            .field("shapes", &self.shapes.len())
            .field("components", &self.owners.len())
            .finish_non_exhaustive()
    }
}

impl<const D: usize> IndexReader<D> {
    /// Opens a snapshot of the index at `dir`: reads the manifest and every listed segment,
    /// verifying all checksums and decoding every record. The KD-tree is built on the first
    /// search.
    ///
    /// Errors: [`IndexError::NotAnIndex`] if `dir` has no `MANIFEST`;
    /// [`IndexError::Corrupt`], [`IndexError::Incompatible`],
    /// [`IndexError::DimensionMismatch`] or [`IndexError::MissingSegment`] naming the file at
    /// fault. Never returns a partial snapshot.
    pub fn open(dir: impl AsRef<Path>) -> Result<Self> {
        let dir = dir.as_ref();
        let mut attempt = 0;
        loop {
            attempt += 1;
            let manifest = Manifest::read(dir, Some(segment::dim_u32::<D>()))?;
            match Self::load(dir, manifest) {
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

    fn load(dir: &Path, manifest: Manifest) -> Result<Self> {
        let start = Instant::now();
        // Segments are independent: read, check and decode them in parallel. The first error
        // in manifest order is reported, so the message does not depend on scheduling.
        let segments: Vec<Result<segment::Segment<D>>> = manifest
            .segments
            .par_iter()
            .map(|entry| segment::read::<D>(dir, &manifest, entry))
            .collect();
        let mut live = Vec::new();
        let mut bytes = 0u64;
        for (entry, seg) in manifest.segments.iter().zip(segments) {
            let seg = seg?;
            bytes += entry.len;
            for (position, (c, record)) in
                seg.head.catalogue.into_iter().zip(seg.records).enumerate()
            {
                if !manifest.is_tombstoned(c.id) {
                    let origin = Origin {
                        segment: (entry.number, entry.len, entry.checksum),
                        position: position as u32,
                        components: record.components.len() as u32,
                    };
                    live.push((IndexedShape { id: c.id, record }, origin));
                }
            }
        }
        bytes += manifest.to_bytes().map(|b| b.len() as u64).unwrap_or(0);
        live.sort_by_key(|s| s.0.id);
        let (shapes, origins): (Vec<IndexedShape<D>>, Vec<Origin>) = live.into_iter().unzip();
        let total: usize = shapes.iter().map(|s| s.record.components.len()).sum();
        if u32::try_from(total).is_err() || u32::try_from(shapes.len()).is_err() {
            return Err(IndexError::InvalidQuery {
                reason: format!("{total} components are more than one index can search"),
            });
        }
        let mut owners = Vec::with_capacity(total);
        for (pos, s) in shapes.iter().enumerate() {
            for ci in 0..s.record.components.len() {
                owners.push((pos as u32, ci as u32));
            }
        }
        Ok(IndexReader {
            dir: dir.to_path_buf(),
            manifest,
            bytes,
            shapes,
            owners,
            origins,
            search: OnceLock::new(),
            mode: SearchMode::Auto,
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

    /// Whether searches are approximate (the inverted file) for this snapshot and mode.
    pub fn search_is_approximate(&self) -> bool {
        match self.mode {
            SearchMode::Auto => self.owners.len() >= IVF_MIN_COMPONENTS,
            SearchMode::Exact => false,
            SearchMode::Approximate => !self.owners.is_empty(),
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
        let live = Live {
            shapes: &self.shapes,
            owners: &self.owners,
        };
        let key = self.snapshot_key();
        let path = self.dir.join(SEARCH_CACHE_NAME);
        if let Ok(bytes) = crate::file::read_all(&path)
            && let Some(c) = Ivf::from_cache(&path, bytes, key, &live, D, &self.origins)
        {
            if c.exact {
                return (c.ivf, SearchSource::Cache);
            }
            let _ = crate::file::write_atomic(
                &self.dir,
                SEARCH_CACHE_NAME,
                &c.ivf.to_cache(key, &self.origins),
            );
            return (
                c.ivf,
                SearchSource::CacheUpdated {
                    assigned: c.assigned,
                },
            );
        }
        let ivf = Ivf::build(&live, D);
        let _ = crate::file::write_atomic(
            &self.dir,
            SEARCH_CACHE_NAME,
            &ivf.to_cache(key, &self.origins),
        );
        (ivf, SearchSource::Built)
    }

    /// Bytes held by the search structure (building it if needed): the inverted file's, or
    /// an estimate of the KD-tree's (its copy of the descriptors and item ids).
    pub fn search_bytes(&self) -> usize {
        let s = self.search();
        match (&s.ivf, &s.tree) {
            (Some(ivf), _) => ivf.bytes(),
            (None, Some(_)) => self.owners.len() * (4 * D + 4),
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
            let points: Vec<[f32; D]> = self
                .shapes
                .iter()
                .flat_map(|s| s.record.components.iter().map(|c| c.descriptor))
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

    /// All live shapes, by increasing id.
    pub fn shapes(&self) -> &[IndexedShape<D>] {
        &self.shapes
    }

    /// The record of shape `id`, if it is live in this snapshot.
    pub fn get(&self, id: ShapeId) -> Option<&ShapeRecord<D>> {
        self.shapes
            .binary_search_by_key(&id, |s| s.id)
            .ok()
            .map(|i| &self.shapes[i].record)
    }

    /// The live shape whose canonical path is `path` (taken as given, then canonicalised).
    pub fn find_path(&self, path: &Path) -> Option<&IndexedShape<D>> {
        let canon = canonical_path(path);
        self.shapes
            .iter()
            .find(|s| s.record.canonical_path == path)
            .or_else(|| {
                self.shapes
                    .iter()
                    .find(|s| s.record.canonical_path == canon)
            })
    }

    /// Number of live components (the KD-tree's size).
    pub fn component_count(&self) -> usize {
        self.owners.len()
    }

    /// Summary numbers.
    pub fn stats(&self) -> IndexStats {
        IndexStats {
            dir: self.dir.clone(),
            format_version: FORMAT_VERSION,
            generation: self.manifest.generation,
            dim: D,
            shapes: self.shapes.len(),
            components: self.owners.len(),
            segments: self.manifest.segments.len(),
            tombstones: self.manifest.tombstones.len(),
            bytes: self.bytes,
        }
    }

    fn descriptor(&self, item: usize) -> Option<(ShapeId, usize, &[f32; D])> {
        let (pos, ci) = *self.owners.get(item)?;
        let s = self.shapes.get(pos as usize)?;
        let c = s.record.components.get(ci as usize)?;
        Some((s.id, ci as usize, &c.descriptor))
    }

    /// The `k` live components nearest to `query` (squared Euclidean distance), closest first;
    /// ties are ordered by shape id then component index. Fewer if the index has fewer.
    ///
    /// Errors with [`IndexError::InvalidQuery`] if `query` holds a NaN or infinity.
    pub fn nearest_components(&self, query: &[f32; D], k: usize) -> Result<Vec<ComponentMatch>> {
        if let Some(i) = query.iter().position(|v| !v.is_finite()) {
            return Err(IndexError::InvalidQuery {
                reason: format!("descriptor value {i} is not finite"),
            });
        }
        let Some(qty) = NonZero::new(k) else {
            return Ok(Vec::new());
        };
        let search = self.search();
        let items: Vec<usize> = match (&search.ivf, &search.tree) {
            (Some(ivf), _) => ivf
                .search(query, qty.get())
                .into_iter()
                .map(|(i, _)| i as usize)
                .collect(),
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
        self.search();
        queries
            .par_iter()
            .map(|q| self.nearest_components(q, k))
            .collect()
    }

    /// Exact `k` nearest components by scanning every descriptor (the oracle the KD-tree is
    /// tested against, and the fallback if the tree could not be built).
    pub fn nearest_linear(&self, query: &[f32; D], k: usize) -> Vec<ComponentMatch> {
        let mut all: Vec<ComponentMatch> = (0..self.owners.len())
            .filter_map(|i| self.descriptor(i))
            .map(|(shape, component, d)| ComponentMatch {
                shape,
                component,
                distance_sq: squared_distance(query, d),
            })
            .collect();
        sort_matches(&mut all);
        all.truncate(k);
        all
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
