//! Segment files (`seg-NNNNNN.kcs`): an immutable batch of shape records, written once and
//! never changed.
//!
//! A segment's payload starts with its [`SegmentHead`] (descriptor length, segment number, and
//! a catalogue of id, canonical path and content hash per shape). This build writes format 5
//! ([`payload`]): a fixed-width table and a block of descriptors that a reader uses in place
//! from a memory map ([`MappedSegment`]), then the records, each with its own checksum. Formats
//! 1 to 4 ([`legacy`]) hold one bincode `Vec` of records after the head; they are read,
//! never written. Every segment read is checked against the manifest entry that lists it
//! ([`check`]). The byte layout is in `index/README.md` at the workspace root, *Segment files*.

mod check;
mod head;
mod legacy;
mod mapped;
mod payload;

use std::path::{Path, PathBuf};

pub(crate) use head::{CatalogueEntry, SegmentHead, dim_u32};
pub(crate) use mapped::MappedSegment;

use crate::dir::{MANIFEST_NAME, segment_file_name};
use crate::error::{CorruptKind, IndexError, Result};
use crate::file::{self, KIND_SEGMENT};
use crate::manifest::{Manifest, SegmentEntry};
use crate::record::{ShapeId, ShapeRecord};
use crate::version::FORMAT_VERSION;

use check::{check_head, check_listed, check_records, length_mismatch};

/// A fully decoded segment.
#[derive(Debug)]
pub struct Segment<const D: usize> {
    /// The head.
    pub head: SegmentHead,
    /// Records, in catalogue order.
    pub records: Vec<ShapeRecord<D>>,
}

/// Encodes a segment; returns the sealed bytes and their checksum.
pub fn encode<const D: usize>(
    number: u64,
    ids: &[ShapeId],
    records: &[ShapeRecord<D>],
) -> Result<(Vec<u8>, u64)> {
    let head = SegmentHead {
        dim: dim_u32::<D>(),
        number,
        catalogue: ids
            .iter()
            .zip(records)
            .map(|(&id, r)| CatalogueEntry {
                id,
                canonical_path: r.canonical_path.to_string_lossy().into_owned(),
                content_hash: r.content_hash,
            })
            .collect(),
    };
    let payload =
        payload::encode::<D>(&head, records).map_err(|reason| IndexError::InvalidRecord {
            path: PathBuf::from(segment_file_name(number)),
            reason,
        })?;
    Ok(file::seal(payload, KIND_SEGMENT, FORMAT_VERSION))
}

/// Where the records of a checked segment are.
pub(crate) enum Rest {
    /// Formats 1 to 4: one bincode `Vec` of records from this payload offset on.
    Bincode(usize),
    /// Format 5: the table ([`payload`]).
    Table(payload::Table),
}

/// Reads a segment file listed in `manifest`, checks it against `entry` and its own footer,
/// and returns its bytes (footer checked), its decoded head and where its records are.
fn open_checked(
    dir: &Path,
    manifest: &Manifest,
    entry: &SegmentEntry,
) -> Result<(file::Opened, SegmentHead, Rest, PathBuf)> {
    let path = dir.join(segment_file_name(entry.number));
    let bytes = match file::read_all(&path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(IndexError::MissingSegment {
                manifest: dir.join(MANIFEST_NAME),
                segment: path,
            });
        }
        Err(e) => return Err(IndexError::io("could not read", path, e)),
    };
    let actual = bytes.len() as u64;
    if actual != entry.len {
        return Err(length_mismatch(&path, &bytes, entry));
    }
    let opened = file::unseal(&path, bytes, KIND_SEGMENT, FORMAT_VERSION)?;
    check_listed(&path, opened.checksum, entry)?;
    let (head, rest) = head_of(&path, opened.payload(), opened.version, manifest, entry)?;
    Ok((opened, head, rest, path))
}

/// Decodes the head of a segment `payload` of format `version` and checks it against the
/// manifest and the segment's entry; returns it and where the records are.
pub(crate) fn head_of(
    path: &Path,
    payload: &[u8],
    version: u32,
    manifest: &Manifest,
    entry: &SegmentEntry,
) -> Result<(SegmentHead, Rest)> {
    let malformed = |msg: String| IndexError::corrupt(path, CorruptKind::Malformed(msg));
    if version >= 5 {
        let table = payload::parse(payload).map_err(malformed)?;
        let head = payload::head(payload, &table).map_err(malformed)?;
        check_head(path, &head, manifest, entry)?;
        table
            .check_block(manifest.dim as usize)
            .map_err(malformed)?;
        return Ok((head, Rest::Table(table)));
    }
    let (head, used) = legacy::head(payload).map_err(malformed)?;
    check_head(path, &head, manifest, entry)?;
    Ok((head, Rest::Bincode(used)))
}

/// Reads only the head of a segment listed in `manifest` (all checksums are still verified).
pub fn read_head(dir: &Path, manifest: &Manifest, entry: &SegmentEntry) -> Result<SegmentHead> {
    open_checked(dir, manifest, entry).map(|(_, head, _, _)| head)
}

/// Reads and fully decodes a segment listed in `manifest`, validating every record.
pub fn read<const D: usize>(
    dir: &Path,
    manifest: &Manifest,
    entry: &SegmentEntry,
) -> Result<Segment<D>> {
    if manifest.dim != dim_u32::<D>() {
        return Err(IndexError::DimensionMismatch {
            path: dir.join(MANIFEST_NAME),
            found: manifest.dim,
            expected: dim_u32::<D>(),
        });
    }
    let (opened, head, rest, path) = open_checked(dir, manifest, entry)?;
    let records = decode_records::<D>(
        &path,
        opened.payload(),
        rest,
        &head,
        Some(entry.components),
        opened.version,
    )?;
    Ok(Segment { head, records })
}

/// Decodes the records of a segment `payload` (where `rest` says) and checks them against the
/// head and the component count `expected` (the segment's entry's; `None` when there is no
/// entry to check against), as format `version` stores them (formats 1 and 2 without the
/// parts' centre positions, 1 to 3 without the surface sample, 5 record by record).
fn decode_records<const D: usize>(
    path: &Path,
    payload: &[u8],
    rest: Rest,
    head: &SegmentHead,
    expected: Option<u64>,
    version: u32,
) -> Result<Vec<ShapeRecord<D>>> {
    let malformed = |msg: String| IndexError::corrupt(path, CorruptKind::Malformed(msg));
    let rest = match rest {
        Rest::Table(table) => {
            let records = (0..table.entries.len())
                .map(|i| payload::record::<D>(payload, &table, i))
                .collect::<std::result::Result<Vec<_>, String>>()
                .map_err(malformed)?;
            return check_records(path, records, head, expected);
        }
        Rest::Bincode(used) => &payload[used..],
    };
    let records = legacy::records::<D>(rest, version).map_err(malformed)?;
    check_records(path, records, head, expected)
}

/// Decodes and checks a whole segment payload (the file without its footer, whose checksum is
/// not looked at) as a reader would, against a manifest made up from the head itself (its
/// descriptor length, shape count and largest id): the entry point of the segment decoder's
/// fuzz target, which reaches every check after the checksum.
pub fn decode_unsealed<const D: usize>(payload: &[u8]) -> Result<Segment<D>> {
    let path = Path::new("fuzzed-segment");
    let malformed = |msg: String| IndexError::corrupt(path, CorruptKind::Malformed(msg));
    let table = payload::parse(payload).map_err(malformed)?;
    let head = payload::head(payload, &table).map_err(malformed)?;
    let mut manifest = Manifest::empty(dim_u32::<D>());
    manifest.next_shape_id = head
        .catalogue
        .last()
        .map_or(0, |c| c.id.0.saturating_add(1));
    let entry = SegmentEntry {
        number: head.number,
        len: payload.len() as u64,
        checksum: 0,
        shapes: head.catalogue.len() as u64,
        components: 0,
    };
    let (head, rest) = head_of(path, payload, FORMAT_VERSION, &manifest, &entry)?;
    // The component count is the one thing the head does not tell: not checked.
    let records = decode_records::<D>(path, payload, rest, &head, None, FORMAT_VERSION)?;
    Ok(Segment { head, records })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic;

    /// Writes segment 0 of `recs` with its payload changed by `patch` (and sealed again, so
    /// the checksums hold), and the manifest listing it; returns the manifest.
    fn write_patched<const D: usize>(
        dir: &Path,
        recs: &[ShapeRecord<D>],
        patch: impl FnOnce(&mut Vec<u8>),
    ) -> Manifest {
        let ids: Vec<ShapeId> = (0..recs.len() as u64).map(ShapeId).collect();
        let (bytes, _) = encode::<D>(0, &ids, recs).unwrap();
        let mut payload = bytes[..bytes.len() - file::FOOTER_LEN].to_vec();
        patch(&mut payload);
        let (bytes, checksum) = file::seal(payload, KIND_SEGMENT, FORMAT_VERSION);
        std::fs::write(dir.join(segment_file_name(0)), &bytes).unwrap();
        let mut m = Manifest::empty(D as u32);
        m.next_segment = 1;
        m.next_shape_id = recs.len() as u64;
        m.segments.push(SegmentEntry {
            number: 0,
            len: bytes.len() as u64,
            checksum,
            shapes: recs.len() as u64,
            components: recs.iter().map(|r| r.components.len() as u64).sum(),
        });
        m
    }

    /// A length field made huge inside a segment whose checksums hold (a buggy writer, a
    /// crafted file) is an error, never an allocation of that size or a panic: every 8-byte
    /// window of the payload is overwritten in turn with huge values.
    #[test]
    fn huge_lengths_are_errors_not_allocations() {
        const D: usize = 3;
        let recs = synthetic::records::<D>(1, 0..2);
        let dir = tempfile::tempdir().unwrap();
        let (bytes, _) = encode::<D>(0, &[ShapeId(0), ShapeId(1)], &recs).unwrap();
        let n = bytes.len() - file::FOOTER_LEN;
        let mut failed = 0;
        for at in 0..n - 8 {
            for huge in [u64::MAX, 1 << 40, 1 << 33] {
                let m = write_patched::<D>(dir.path(), &recs, |p| {
                    p[at..at + 8].copy_from_slice(&huge.to_le_bytes());
                    payload::refresh_checksums(p, D);
                });
                // Some windows fall on values any bytes can hold (descriptor floats): those
                // decode. What matters is that none panics or allocates its length.
                let _ = read_head(dir.path(), &m, &m.segments[0]);
                failed += usize::from(read::<D>(dir.path(), &m, &m.segments[0]).is_err());
            }
        }
        assert!(
            failed > n,
            "only {failed} of {} patched files failed",
            3 * n
        );
        // The catalogue's first path length (after the prefix, the table, then dim, number,
        // count and id): named in the message as a limit, not a failed allocation.
        let at = payload::PREFIX_LEN + 2 * payload::ENTRY_LEN + 28;
        let m = write_patched::<D>(dir.path(), &recs, |p| {
            p[at..at + 8].copy_from_slice(&(1u64 << 50).to_le_bytes());
            payload::refresh_checksums(p, D);
        });
        let e = read::<D>(dir.path(), &m, &m.segments[0]).unwrap_err();
        assert!(matches!(e, IndexError::Corrupt { .. }), "{e}");
        assert!(e.to_string().contains("segment head"), "{e}");
    }

    /// The fuzzing entry point decodes what the writer encodes, and refuses the same bytes cut
    /// short.
    #[test]
    fn unsealed_payloads_decode() {
        const D: usize = 3;
        let recs = synthetic::records::<D>(4, 0..3);
        let ids = [ShapeId(7), ShapeId(8), ShapeId(9)];
        let (bytes, _) = encode::<D>(2, &ids, &recs).unwrap();
        let payload = &bytes[..bytes.len() - file::FOOTER_LEN];
        let seg = decode_unsealed::<D>(payload).unwrap();
        assert_eq!(seg.records, recs);
        assert_eq!(seg.head.number, 2);
        assert!(decode_unsealed::<D>(&payload[..payload.len() - 1]).is_err());
        assert!(
            decode_unsealed::<4>(payload).is_err(),
            "another descriptor length"
        );
    }

    /// Records that decode but are inconsistent (an id beyond the manifest's counter, a
    /// component with more keypoints than the mesh has vertices, an area fraction above 1) are
    /// refused with the reason.
    #[test]
    fn inconsistent_records_are_refused() {
        const D: usize = 3;
        let dir = tempfile::tempdir().unwrap();
        let recs = synthetic::records::<D>(1, 0..2);
        let mut m = write_patched::<D>(dir.path(), &recs, |_| {});
        assert!(read::<D>(dir.path(), &m, &m.segments[0]).is_ok());
        m.next_shape_id = 1;
        let e = read::<D>(dir.path(), &m, &m.segments[0]).unwrap_err();
        assert!(
            e.to_string().contains("beyond the manifest's counter"),
            "{e}"
        );
        let mut bad = recs.clone();
        bad[1].components[0].keypoint_count = bad[1].vertex_count + 1;
        let m = write_patched::<D>(dir.path(), &bad, |_| {});
        let e = read::<D>(dir.path(), &m, &m.segments[0]).unwrap_err();
        assert!(e.to_string().contains("keypoints, the mesh"), "{e}");
        let mut bad = recs.clone();
        bad[0].components[1].area_fraction = 1.5;
        let m = write_patched::<D>(dir.path(), &bad, |_| {});
        let e = read::<D>(dir.path(), &m, &m.segments[0]).unwrap_err();
        assert!(e.to_string().contains("not between 0 and 1"), "{e}");
    }

    /// The segment size follows the byte layout documented in index/README.md at the workspace
    /// root exactly.
    #[test]
    fn size_matches_documented_layout() {
        const D: usize = 5;
        let mut recs = synthetic::records::<D>(9, 0..3);
        // one layout that is not symmetric, stored whole; the others as triangles
        recs[2].layout[1] += 1.0;
        let ids = [ShapeId(4), ShapeId(5), ShapeId(6)];
        let (bytes, _) = encode::<D>(7, &ids, &recs).unwrap();
        let string = |s: &std::path::Path| 8 + s.to_str().unwrap().len();
        let mut want = payload::PREFIX_LEN + 3 * payload::ENTRY_LEN;
        want += 4 + 8 + 8; // head: dim, number, catalogue count
        for r in &recs {
            want += 8 + string(&r.canonical_path) + 16;
        }
        want = want.next_multiple_of(8); // zeros up to the descriptor block
        let head_end = want;
        for r in &recs {
            want += 4 * D * r.components.len();
        }
        for (i, r) in recs.iter().enumerate() {
            want += string(&r.path) + string(&r.canonical_path) + 16 + 4 + 4 + 8;
            // part count, then per part: centre vertex, area fraction, keypoints, then the
            // centre, a tag byte and, when present, three f32
            want += 8;
            for c in &r.components {
                want += 4 + 4 + 4 + 1 + c.centre.map_or(0, |_| 12);
            }
            // the layout: variant (u32), count, values (the triangle of the first two)
            let m = r.components.len();
            want += 4 + 8 + 4 * if i < 2 { m * (m - 1) / 2 } else { m * m };
            want += 8 + 12 * r.sample.len(); // the surface sample: count, then three f32 each
            want += 4; // boundary vertices
        }
        assert_eq!(bytes.len(), want + file::FOOTER_LEN);
        // The prefix: shapes, head offset (after the table), descriptor block offset.
        assert_eq!(&bytes[0..8], &3u64.to_le_bytes());
        assert_eq!(&bytes[8..16], &(64u64 + 96).to_le_bytes());
        assert_eq!(&bytes[24..32], &(head_end as u64).to_le_bytes());
        // The table's first entry: the first id; the head: dim and segment number.
        assert_eq!(&bytes[64..72], &4u64.to_le_bytes());
        assert_eq!(&bytes[160..164], &5u32.to_le_bytes());
        assert_eq!(&bytes[164..172], &7u64.to_le_bytes());
    }
}
