//! On-disk index of key-component descriptors (keycomp's retrieval store).
//!
//! An index is a directory (default [`DEFAULT_INDEX_DIR`]) holding:
//! - `MANIFEST`: the list of live segment files, the tombstones of removed or replaced shapes,
//!   id counters and a generation number; replaced atomically on every change;
//! - `seg-NNNNNN.kcs`: immutable segments, each a batch of [`ShapeRecord`]s;
//! - `LOCK`: the writers' advisory lock file (empty).
//!
//! Every file ends with a 32-byte footer (payload length, kind, format version, XXH3-64
//! checksum, magic). The byte-level format is in `index/README.md` at the workspace root.
//!
//! Writing: [`IndexWriter`] (one at a time per directory, enforced with the lock file) adds
//! batches of records, replaces changed shapes, removes shapes, compacts. Every change is a
//! new segment written atomically and then a new manifest renamed into place, so a process
//! killed at any point leaves the index as it was before or after the change.
//!
//! Reading: [`IndexReader`] is a snapshot (one manifest, immutable segments), read whole
//! ([`IndexReader::open`]) or memory-mapped with records decoded on use
//! ([`IndexReader::open_mapped`]), with a search over all live component descriptors for
//! [`IndexReader::nearest_components`] (a KD-tree, `kiddo`, on small indexes; an inverted file
//! with quantised residuals on large ones). Readers need no lock and may run while a
//! writer works.
//!
//! Checking: [`verify`] reports every damaged, missing or incompatible file without changing
//! anything. Errors ([`IndexError`]) say which file, whether it is corrupt or incompatible, and
//! what to do.
//!
//! ```
//! use keycomp_index::{IndexReader, IndexWriter, synthetic};
//! # let dir = tempfile::tempdir().unwrap();
//! # let dir = dir.path().join("index");
//! let mut w = IndexWriter::<8>::create_or_open(&dir)?;
//! let summary = w.add_batch(synthetic::records::<8>(1, 0..10))?;
//! assert_eq!(summary.added, 10);
//! drop(w);
//! let r = IndexReader::<8>::open(&dir)?;
//! let q = r.shapes()?[3].record.components[0].descriptor;
//! let hits = r.nearest_components(&q, 5)?;
//! assert_eq!(hits[0].shape, r.shapes()?[3].id);
//! # Ok::<(), keycomp_index::IndexError>(())
//! ```

mod codec;
mod dir;
mod distance;
mod error;
mod file;
pub mod fuzzing;
mod ivf;
pub mod kmeans;
mod manifest;
mod reader;
mod record;
mod search;
mod search_structure;
mod segment;
#[cfg(any(test, feature = "synthetic"))]
pub mod synthetic;
mod verify;
mod version;
mod writer;

pub use dir::{DEFAULT_INDEX_DIR, LOCK_NAME, MANIFEST_NAME, SEARCH_CACHE_NAME};
pub use distance::{squared_distance, squared_distance_fast};
pub use error::{CorruptKind, IndexError, Result};
pub use file::{FOOTER_LEN, MAGIC as FOOTER_MAGIC};
pub use ivf::{COARSE_PROBES, FINE_PROBES, FINE_SHARE, MIN_FINE_PROBES, RERANK, SearchEffort};
pub use reader::{IndexReader, IndexStats, IndexedShape};
pub use record::{
    ComponentRecord, ContentHash, MAX_SAMPLE_POINTS, ShapeId, ShapeRecord, canonical_path,
};
pub use search::ComponentMatch;
pub use search_structure::{EXACT_TREE_MAX, IVF_MIN_COMPONENTS, SearchMode, SearchSource};
pub use verify::{VerifyReport, verify};
pub use version::{FORMAT_VERSION, OLDEST_READABLE_VERSION};
pub use writer::{AddOutcome, AddSummary, IndexWriter, MergeSummary};
