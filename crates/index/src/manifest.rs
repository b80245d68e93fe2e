//! The `MANIFEST` file: which segments are live, which shapes in them are removed, and the
//! counters for new ids.
//!
//! The manifest is small (O(segments + tombstones)) and is rewritten whole, atomically, on
//! every change; its `generation` goes up by one each time. Readers read it once per open and
//! then only the immutable segments it lists.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::codec::{bincode_config, decode_bounded};
use crate::dir::MANIFEST_NAME;
use crate::error::{CorruptKind, IndexError, Result};
use crate::file::{self, KIND_MANIFEST};
use crate::record::ShapeId;
use crate::version::FORMAT_VERSION;

/// One live segment as the manifest records it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SegmentEntry {
    /// Segment number; the file is [`crate::dir::segment_file_name`]`(number)`.
    pub number: u64,
    /// Exact length of the segment file in bytes.
    pub len: u64,
    /// The checksum in the segment file's footer.
    pub checksum: u64,
    /// Number of shapes stored in the segment (tombstoned ones included).
    pub shapes: u64,
    /// Number of components stored in the segment (tombstoned ones included).
    pub components: u64,
}

/// Decoded contents of `MANIFEST`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Manifest {
    /// Incremented on every rewrite; 0 for a freshly created index.
    pub generation: u64,
    /// Descriptor length `D` of every segment.
    pub dim: u32,
    /// The next shape id to hand out.
    pub next_shape_id: u64,
    /// The next segment number to use.
    pub next_segment: u64,
    /// Live segments, in the order they were added.
    pub segments: Vec<SegmentEntry>,
    /// Ids of removed or replaced shapes that still sit in a live segment; sorted, unique.
    pub tombstones: Vec<ShapeId>,
    /// How the descriptors were made (from format 2 on): free text set by the program that
    /// fills the index, compared before adding or querying so that descriptors computed
    /// differently are never mixed or compared. Empty for an index without a profile yet, and for every
    /// format-1 index.
    pub profile: String,
}

/// The manifest payload of format version 1 (no profile).
#[derive(Deserialize)]
struct ManifestV1 {
    generation: u64,
    dim: u32,
    next_shape_id: u64,
    next_segment: u64,
    segments: Vec<SegmentEntry>,
    tombstones: Vec<ShapeId>,
}

impl From<ManifestV1> for Manifest {
    fn from(m: ManifestV1) -> Self {
        Manifest {
            generation: m.generation,
            dim: m.dim,
            next_shape_id: m.next_shape_id,
            next_segment: m.next_segment,
            segments: m.segments,
            tombstones: m.tombstones,
            profile: String::new(),
        }
    }
}

impl Manifest {
    /// An empty manifest for descriptors of length `dim`.
    pub fn empty(dim: u32) -> Self {
        Manifest {
            generation: 0,
            dim,
            next_shape_id: 0,
            next_segment: 0,
            segments: Vec::new(),
            tombstones: Vec::new(),
            profile: String::new(),
        }
    }

    /// Encodes and seals the manifest.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let payload = bincode::serde::encode_to_vec(self, bincode_config()).map_err(|e| {
            IndexError::InvalidRecord {
                path: MANIFEST_NAME.into(),
                reason: format!("could not encode the manifest: {e}"),
            }
        })?;
        Ok(file::seal(payload, KIND_MANIFEST, FORMAT_VERSION).0)
    }

    /// Reads `dir/MANIFEST`, checking footer, version, consistency and (if given) the
    /// descriptor length.
    pub fn read(dir: &Path, expected_dim: Option<u32>) -> Result<Self> {
        let path = dir.join(MANIFEST_NAME);
        let bytes = match file::read_all(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(IndexError::NotAnIndex {
                    dir: dir.to_path_buf(),
                });
            }
            Err(e) => return Err(IndexError::io("could not read", path, e)),
        };
        Self::from_bytes(&path, bytes, expected_dim)
    }

    /// Decodes manifest file bytes read from `path`.
    pub fn from_bytes(path: &Path, bytes: Vec<u8>, expected_dim: Option<u32>) -> Result<Self> {
        let opened = file::unseal(path, bytes, KIND_MANIFEST, FORMAT_VERSION)?;
        Self::from_payload(path, opened.version, opened.payload(), expected_dim)
    }

    /// Decodes and checks a manifest payload (the file without its footer) of format
    /// `version`, whose footer was checked already.
    pub fn from_payload(
        path: &Path,
        version: u32,
        payload: &[u8],
        expected_dim: Option<u32>,
    ) -> Result<Self> {
        let malformed = |msg: String| IndexError::corrupt(path, CorruptKind::Malformed(msg));
        let (m, used): (Manifest, usize) = if version == 1 {
            let (m, used): (ManifestV1, usize) =
                decode_bounded(payload).map_err(|e| malformed(e.to_string()))?;
            (m.into(), used)
        } else {
            decode_bounded(payload).map_err(|e| malformed(e.to_string()))?
        };
        if used != payload.len() {
            return Err(malformed(format!(
                "{} unexpected bytes after the manifest",
                payload.len() - used
            )));
        }
        if let Some(d) = expected_dim
            && d != m.dim
        {
            return Err(IndexError::DimensionMismatch {
                path: path.to_path_buf(),
                found: m.dim,
                expected: d,
            });
        }
        if !m.tombstones.windows(2).all(|w| w[0] < w[1]) {
            return Err(malformed("tombstones are not sorted".into()));
        }
        if !m.segments.windows(2).all(|w| w[0].number < w[1].number) {
            return Err(malformed("segment numbers are not increasing".into()));
        }
        if m.segments.iter().any(|s| s.number >= m.next_segment) {
            return Err(malformed("a segment number is beyond the counter".into()));
        }
        if m.tombstones.iter().any(|t| t.0 >= m.next_shape_id) {
            return Err(malformed(
                "a tombstone is beyond the shape id counter".into(),
            ));
        }
        Ok(m)
    }

    /// Atomically replaces `dir/MANIFEST` with this manifest.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let bytes = self.to_bytes()?;
        file::write_atomic(dir, MANIFEST_NAME, &bytes)?;
        Ok(())
    }

    /// Whether shape `id` is tombstoned.
    pub fn is_tombstoned(&self, id: ShapeId) -> bool {
        self.tombstones.binary_search(&id).is_ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The manifest bytes are exactly the layout documented in index/README.md at the workspace root.
    #[test]
    fn bytes_match_documented_layout() {
        let mut m = Manifest::empty(32);
        m.generation = 2;
        m.next_shape_id = 9;
        m.next_segment = 4;
        m.segments.push(SegmentEntry {
            number: 3,
            len: 1000,
            checksum: 0xabcd,
            shapes: 9,
            components: 50,
        });
        m.tombstones = vec![ShapeId(5)];
        m.profile = "kc1".into();
        let b = m.to_bytes().unwrap();
        let mut want = Vec::new();
        want.extend_from_slice(&2u64.to_le_bytes());
        want.extend_from_slice(&32u32.to_le_bytes());
        want.extend_from_slice(&9u64.to_le_bytes());
        want.extend_from_slice(&4u64.to_le_bytes());
        want.extend_from_slice(&1u64.to_le_bytes());
        for v in [3u64, 1000, 0xabcd, 9, 50] {
            want.extend_from_slice(&v.to_le_bytes());
        }
        want.extend_from_slice(&1u64.to_le_bytes());
        want.extend_from_slice(&5u64.to_le_bytes());
        want.extend_from_slice(&3u64.to_le_bytes());
        want.extend_from_slice(b"kc1");
        assert_eq!(&b[..b.len() - crate::file::FOOTER_LEN], &want[..]);
        let f = &b[want.len()..];
        assert_eq!(&f[0..8], &(want.len() as u64).to_le_bytes());
        assert_eq!(&f[8..12], &1u32.to_le_bytes());
        assert_eq!(&f[12..16], &FORMAT_VERSION.to_le_bytes());
        let sum = xxhash_rust::xxh3::xxh3_64(&b[..want.len() + 16]);
        assert_eq!(&f[16..24], &sum.to_le_bytes());
        assert_eq!(&f[24..32], b"KCIDXEND");
    }

    /// Every 8-byte window of a manifest payload overwritten with a huge value, sealed again:
    /// decoding gives a value or an error, never a panic or a huge allocation; a huge profile
    /// length is reported as malformed.
    #[test]
    fn huge_lengths_are_errors_not_allocations() {
        let mut m = Manifest::empty(8);
        m.next_segment = 2;
        m.next_shape_id = 5;
        m.segments.push(SegmentEntry {
            number: 1,
            len: 100,
            checksum: 5,
            shapes: 4,
            components: 20,
        });
        m.tombstones = vec![ShapeId(2)];
        m.profile = "profile".into();
        let b = m.to_bytes().unwrap();
        let n = b.len() - crate::file::FOOTER_LEN;
        let path = Path::new("MANIFEST");
        for at in 0..n - 8 {
            for huge in [u64::MAX, 1 << 40] {
                let mut p = b[..n].to_vec();
                p[at..at + 8].copy_from_slice(&huge.to_le_bytes());
                let (sealed, _) = file::seal(p, KIND_MANIFEST, FORMAT_VERSION);
                let _ = Manifest::from_bytes(path, sealed, None);
            }
        }
        let mut p = b[..n].to_vec();
        let at = n - m.profile.len() - 8;
        p[at..at + 8].copy_from_slice(&(1u64 << 45).to_le_bytes());
        let (sealed, _) = file::seal(p, KIND_MANIFEST, FORMAT_VERSION);
        let e = Manifest::from_bytes(path, sealed, None).unwrap_err();
        assert!(
            matches!(
                e,
                IndexError::Corrupt {
                    kind: CorruptKind::Malformed(_),
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn manifest_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = Manifest::empty(32);
        m.next_segment = 3;
        m.next_shape_id = 10;
        m.segments.push(SegmentEntry {
            number: 2,
            len: 100,
            checksum: 5,
            shapes: 4,
            components: 20,
        });
        m.tombstones = vec![ShapeId(1), ShapeId(7)];
        m.profile = "descriptors made some way".into();
        m.write(dir.path()).unwrap();
        assert_eq!(Manifest::read(dir.path(), Some(32)).unwrap(), m);
        assert!(matches!(
            Manifest::read(dir.path(), Some(16)),
            Err(IndexError::DimensionMismatch {
                found: 32,
                expected: 16,
                ..
            })
        ));
    }
}
