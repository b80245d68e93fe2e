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

mod error;
mod file;
mod ivf;
mod manifest;
mod mapped;
mod reader;
mod record;
mod segment;
pub mod synthetic;
mod verify;
mod writer;

pub use error::{CorruptKind, IndexError, Result};
pub use ivf::{
    COARSE_PROBES, FINE_PROBES, FINE_SHARE, MIN_FINE_PROBES, RERANK, SearchEffort,
    distance_sq as squared_distance_fast,
};
pub use reader::{
    ComponentMatch, EXACT_TREE_MAX, IVF_MIN_COMPONENTS, IndexReader, IndexStats, IndexedShape,
    SEARCH_CACHE_NAME, SearchMode, SearchSource, squared_distance,
};
pub use record::{
    ComponentRecord, ContentHash, MAX_SAMPLE_POINTS, ShapeId, ShapeRecord, canonical_path,
};
pub use verify::{VerifyReport, verify};
pub use writer::{AddOutcome, AddSummary, IndexWriter, MergeSummary};

/// The on-disk format version this build writes. Bumped on any incompatible change; files of a
/// version outside [`OLDEST_READABLE_VERSION`]`..=FORMAT_VERSION` are refused with
/// [`IndexError::Incompatible`].
pub const FORMAT_VERSION: u32 = 5;

/// Oldest format version this build still reads (version 1 has no manifest profile; see
/// `index/README.md`, *Versions*).
pub const OLDEST_READABLE_VERSION: u32 = 1;

/// Default index directory, relative to the working directory.
pub const DEFAULT_INDEX_DIR: &str = "index";

/// File name of the manifest.
pub const MANIFEST_NAME: &str = "MANIFEST";

/// File name of the writers' lock file.
pub const LOCK_NAME: &str = "LOCK";

/// Size in bytes of the footer that closes every index file.
pub const FOOTER_LEN: usize = file::FOOTER_LEN;

/// The magic number in the last 8 bytes of every index file.
pub const FOOTER_MAGIC: [u8; 8] = file::MAGIC;

/// The decoders of the index files without their footer and checksum, for fuzzing: every
/// check a reader makes after the checksum runs on the bytes given. A crafted or damaged file
/// whose checksum holds reaches exactly this code, so it must return an error, never panic or
/// allocate far beyond the bytes' size (the fuzz targets in `fuzz/` at the workspace root).
pub mod fuzzing {
    use std::path::Path;

    use crate::Result;

    /// Decodes a segment payload (a segment file without its 32-byte footer) with descriptors
    /// of length `D`, checking it as a reader does against a manifest made up from its head.
    pub fn decode_segment_payload<const D: usize>(payload: &[u8]) -> Result<()> {
        crate::segment::decode_unsealed::<D>(payload).map(|_| ())
    }

    /// The snapshot key of [`decode_search_cache_payload`]'s made-up snapshot.
    const CACHE_KEY: u64 = 0x5eed_cafe;

    /// The 64 descriptors of length 8 (a fixed pseudo-random set) that
    /// [`decode_search_cache_payload`] checks a search cache against.
    fn cache_points() -> Vec<f32> {
        (0..64 * 8u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 8) as f32 / 16_777_216.0)
            .collect()
    }

    /// Where [`cache_points`]'s descriptors come from: 8 shapes of 8 components, one segment.
    fn cache_origins() -> Vec<crate::ivf::Origin> {
        (0..8)
            .map(|position| crate::ivf::Origin {
                segment: (1, 4096, 0x5eed),
                position,
                components: 8,
            })
            .collect()
    }

    /// Decodes a search-cache payload (the `SEARCH-CACHE` file without its footer) as a reader
    /// does, for `cache_points`'s descriptors; whether it was accepted.
    pub fn decode_search_cache_payload(payload: &[u8]) -> bool {
        let points = cache_points();
        let flat = crate::ivf::Flat {
            data: &points,
            d: 8,
        };
        crate::ivf::Ivf::from_payload(payload, CACHE_KEY, &flat, 8, &cache_origins()).is_some()
    }

    /// A valid search-cache payload for [`decode_search_cache_payload`] (a fuzzing seed).
    pub fn search_cache_seed() -> Vec<u8> {
        let points = cache_points();
        let flat = crate::ivf::Flat {
            data: &points,
            d: 8,
        };
        let sealed = crate::ivf::Ivf::build(&flat, 8).to_cache(CACHE_KEY, &cache_origins());
        sealed[..sealed.len() - crate::file::FOOTER_LEN].to_vec()
    }

    /// Decodes a manifest payload (a MANIFEST without its footer) of format `version`.
    pub fn decode_manifest_payload(version: u32, payload: &[u8]) -> Result<()> {
        crate::manifest::Manifest::from_payload(
            Path::new("fuzzed-manifest"),
            version,
            payload,
            None,
        )
        .map(|_| ())
    }
}
