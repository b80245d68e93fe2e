//! The payload of a format-5 segment: a fixed-width table and a block of descriptors that a
//! reader uses in place from a memory map, then the records, each decoded on its own and
//! checked by its own checksum. Opening an index thus costs the tables, not the records
//! (`index/README.md` at the workspace root, *Segment files*).
//!
//! Layout (integers little endian):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | shapes `n` |
//! | 8 | 8 | head offset (= 64 + 32 `n`) |
//! | 16 | 8 | head length |
//! | 24 | 8 | descriptor block offset (a multiple of 8) |
//! | 32 | 8 | descriptors in the block (the records' components, record after record) |
//! | 40 | 8 | records offset (= block offset + 4 `D` × descriptors) |
//! | 48 | 8 | XXH3-64 of the head |
//! | 56 | 8 | XXH3-64 of bytes 0..56 followed by the table |
//! | 64 | 32 `n` | table, per shape: id (u64), record offset (u64), record length (u32), components (u32), XXH3-64 of the record's bytes followed by its descriptors' |
//!
//! Then the head ([`SegmentHead`], bincode), zeros up to the block, the block (`f32`), and the
//! records ([`Body`], bincode: a [`ShapeRecord`] without its descriptors, its layout stored
//! as the upper triangle when it is symmetric with a zero diagonal).

use std::ops::Range;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};
use xxhash_rust::xxh3::{Xxh3Default, xxh3_64};

use crate::codec::{bincode_config, decode_bounded, le_u32, le_u64, put_u64};
use crate::record::{ComponentRecord, ContentHash, ShapeId, ShapeRecord};

use super::head::SegmentHead;

/// Bytes before the table.
pub(crate) const PREFIX_LEN: usize = 64;
/// Bytes per table entry.
pub(crate) const ENTRY_LEN: usize = 32;

/// One shape of the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Entry {
    /// The shape's id.
    pub id: ShapeId,
    /// Where its record's bytes are in the payload.
    pub offset: u64,
    /// Their length.
    pub len: u32,
    /// Its components (descriptors in the block).
    pub components: u32,
    /// XXH3-64 of the record's bytes followed by its descriptors' bytes.
    pub checksum: u64,
    /// Index in the block of its first descriptor.
    pub first: u64,
}

/// The parsed fixed part of a payload.
#[derive(Debug, Clone)]
pub(crate) struct Table {
    /// One entry per shape, ids increasing.
    pub entries: Vec<Entry>,
    /// The head's bytes.
    pub head: Range<usize>,
    /// The head's checksum.
    pub head_checksum: u64,
    /// The descriptor block's bytes.
    pub block: Range<usize>,
    /// Descriptors in the block.
    pub count: u64,
}

impl Table {
    /// Checks that the descriptor block holds `count` descriptors of `dim` values (to be
    /// called once the head has told `dim` matches the index's).
    pub(crate) fn check_block(&self, dim: usize) -> Result<(), String> {
        if self.count.checked_mul(4 * dim as u64) != Some(self.block.len() as u64) {
            return Err(format!(
                "a descriptor block of {} bytes for {} descriptors of {dim} values",
                self.block.len(),
                self.count
            ));
        }
        Ok(())
    }
}

/// One part of a record, without its descriptor.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Part {
    centre_vertex: u32,
    area_fraction: f32,
    keypoint_count: u32,
    centre: Option<[f32; 3]>,
}

/// The layout as stored.
#[derive(Debug, Clone, Serialize, Deserialize)]
enum Layout {
    /// Row-major m × m.
    Full(Vec<f32>),
    /// Row-major strict upper triangle of a symmetric layout with a zero diagonal.
    Symmetric(Vec<f32>),
}

/// A record as stored: [`ShapeRecord`] without its descriptors.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Body {
    path: PathBuf,
    canonical_path: PathBuf,
    content_hash: ContentHash,
    vertex_count: u32,
    face_count: u32,
    surface_area: f64,
    parts: Vec<Part>,
    layout: Layout,
    sample: Vec<[f32; 3]>,
    boundary_vertices: u32,
}

/// The upper triangle of `layout` (m × m) if it is symmetric bit for bit with a `+0.0`
/// diagonal (so that expanding it gives the same bits back).
fn triangle(layout: &[f32], m: usize) -> Option<Vec<f32>> {
    if layout.len() != m * m {
        return None;
    }
    let mut t = Vec::with_capacity(m * m.saturating_sub(1) / 2);
    for i in 0..m {
        if layout[i * m + i].to_bits() != 0 {
            return None;
        }
        for j in i + 1..m {
            let v = layout[i * m + j];
            if v.to_bits() != layout[j * m + i].to_bits() {
                return None;
            }
            t.push(v);
        }
    }
    Some(t)
}

/// The m × m layout of a stored one, or why it cannot be.
fn expand(layout: Layout, m: usize) -> Result<Vec<f32>, String> {
    match layout {
        Layout::Full(v) => Ok(v),
        Layout::Symmetric(t) => {
            // The triangle was decoded from the record's bytes, so m × m is bounded by them.
            if t.len() != m * m.saturating_sub(1) / 2 {
                return Err(format!(
                    "a layout triangle of {} values for {m} components",
                    t.len()
                ));
            }
            let mut full = vec![0f32; m * m];
            let mut k = 0;
            for i in 0..m {
                for j in i + 1..m {
                    full[i * m + j] = t[k];
                    full[j * m + i] = t[k];
                    k += 1;
                }
            }
            Ok(full)
        }
    }
}

/// The checksum of a record: its bytes, then its descriptors' bytes.
fn record_checksum(body: &[u8], descriptors: &[u8]) -> u64 {
    let mut h = Xxh3Default::new();
    h.update(body);
    h.update(descriptors);
    h.digest()
}

/// Encodes `head` and `records` (in catalogue order) as a format-5 payload.
pub(crate) fn encode<const D: usize>(
    head: &SegmentHead,
    records: &[ShapeRecord<D>],
) -> Result<Vec<u8>, String> {
    let enc = |e: bincode::error::EncodeError| format!("could not encode the segment: {e}");
    let head_bytes = bincode::serde::encode_to_vec(head, bincode_config()).map_err(enc)?;
    let n = records.len();
    let table_end = PREFIX_LEN + ENTRY_LEN * n;
    let block_start = (table_end + head_bytes.len()).next_multiple_of(8);
    let descriptors: usize = records.iter().map(|r| r.components.len()).sum();
    let records_start = block_start + 4 * D * descriptors;
    let mut out = vec![0u8; records_start];
    out[table_end..table_end + head_bytes.len()].copy_from_slice(&head_bytes);
    let mut first = 0usize;
    for (i, (r, c)) in records.iter().zip(&head.catalogue).enumerate() {
        let m = r.components.len();
        let layout = match triangle(&r.layout, m) {
            Some(t) => Layout::Symmetric(t),
            None => Layout::Full(r.layout.clone()),
        };
        let body = Body {
            path: r.path.clone(),
            canonical_path: r.canonical_path.clone(),
            content_hash: r.content_hash,
            vertex_count: r.vertex_count,
            face_count: r.face_count,
            surface_area: r.surface_area,
            parts: r
                .components
                .iter()
                .map(|p| Part {
                    centre_vertex: p.centre_vertex,
                    area_fraction: p.area_fraction,
                    keypoint_count: p.keypoint_count,
                    centre: p.centre,
                })
                .collect(),
            layout,
            sample: r.sample.clone(),
            boundary_vertices: r.boundary_vertices,
        };
        let bytes = bincode::serde::encode_to_vec(&body, bincode_config()).map_err(enc)?;
        let desc_range = block_start + 4 * D * first..block_start + 4 * D * (first + m);
        for (k, comp) in r.components.iter().enumerate() {
            for (l, v) in comp.descriptor.iter().enumerate() {
                let at = desc_range.start + 4 * (k * D + l);
                out[at..at + 4].copy_from_slice(&v.to_le_bytes());
            }
        }
        let checksum = record_checksum(&bytes, &out[desc_range]);
        let len = u32::try_from(bytes.len())
            .map_err(|_| format!("record {i} takes {} bytes (at most 4 GiB)", bytes.len()))?;
        let components = u32::try_from(m).map_err(|_| format!("record {i} has {m} components"))?;
        let e = PREFIX_LEN + ENTRY_LEN * i;
        let offset = out.len() as u64;
        put_u64(&mut out, e, c.id.0);
        put_u64(&mut out, e + 8, offset);
        out[e + 16..e + 20].copy_from_slice(&len.to_le_bytes());
        out[e + 20..e + 24].copy_from_slice(&components.to_le_bytes());
        put_u64(&mut out, e + 24, checksum);
        out.extend_from_slice(&bytes);
        first += m;
    }
    put_u64(&mut out, 0, n as u64);
    put_u64(&mut out, 8, table_end as u64);
    put_u64(&mut out, 16, head_bytes.len() as u64);
    put_u64(&mut out, 24, block_start as u64);
    put_u64(&mut out, 32, descriptors as u64);
    put_u64(&mut out, 40, records_start as u64);
    put_u64(&mut out, 48, xxh3_64(&head_bytes));
    let mut h = Xxh3Default::new();
    h.update(&out[..56]);
    h.update(&out[PREFIX_LEN..table_end]);
    put_u64(&mut out, 56, h.digest());
    Ok(out)
}

/// Parses and checks the fixed part of a format-5 `payload`: the prefix's checksum, every
/// offset within the payload, ids increasing, the records in their region (the block's size
/// is checked against the descriptor length by [`Table::check_block`]). Reads `64 + 32 n`
/// bytes.
pub(crate) fn parse(payload: &[u8]) -> Result<Table, String> {
    if payload.len() < PREFIX_LEN {
        return Err(format!(
            "{} bytes, shorter than the segment's prefix",
            payload.len()
        ));
    }
    let field = |at: usize| le_u64(&payload[at..]);
    let n = field(0);
    let fits = |v: u64| usize::try_from(v).ok().filter(|&v| v <= payload.len());
    let table_end = n
        .checked_mul(ENTRY_LEN as u64)
        .and_then(|t| t.checked_add(PREFIX_LEN as u64))
        .and_then(fits)
        .ok_or_else(|| format!("a table of {n} shapes does not fit the file"))?;
    let mut h = Xxh3Default::new();
    h.update(&payload[..56]);
    h.update(&payload[PREFIX_LEN..table_end]);
    if h.digest() != field(56) {
        return Err("the checksum of the segment's table does not match".into());
    }
    let head_start = fits(field(8)).ok_or("the head offset is beyond the file")?;
    let head_end = field(8)
        .checked_add(field(16))
        .and_then(fits)
        .ok_or("the head is beyond the file")?;
    let block_start = fits(field(24)).ok_or("the descriptor block is beyond the file")?;
    let count = field(32);
    let records_start = fits(field(40)).ok_or("the records are beyond the file")?;
    if head_start != table_end
        || head_end > block_start
        || block_start % 8 != 0
        || block_start > records_start
    {
        return Err("the segment's regions overlap or leave gaps".into());
    }
    let mut entries = Vec::with_capacity(n as usize);
    let mut first = 0u64;
    let mut last: Option<u64> = None;
    for i in 0..n as usize {
        let e = &payload[PREFIX_LEN + ENTRY_LEN * i..];
        let id = le_u64(e);
        let offset = le_u64(&e[8..]);
        let len = le_u32(&e[16..]);
        let components = le_u32(&e[20..]);
        if last.is_some_and(|l| l >= id) {
            return Err("shape ids are not increasing".into());
        }
        last = Some(id);
        let end = offset.checked_add(u64::from(len));
        if offset < records_start as u64 || end.is_none_or(|e| e > payload.len() as u64) {
            return Err(format!("the record of shape {id} is outside the records"));
        }
        entries.push(Entry {
            id: ShapeId(id),
            offset,
            len,
            components,
            checksum: le_u64(&e[24..]),
            first,
        });
        first += u64::from(components);
    }
    if first != count {
        return Err(format!(
            "the table lists {first} components, the descriptor block holds {count}"
        ));
    }
    Ok(Table {
        entries,
        head: head_start..head_end,
        head_checksum: field(48),
        block: block_start..records_start,
        count,
    })
}

/// Decodes and checks the head of a parsed payload (its checksum, its encoding, and that its
/// catalogue lists the table's ids).
pub(crate) fn head(payload: &[u8], table: &Table) -> Result<SegmentHead, String> {
    let bytes = &payload[table.head.clone()];
    if xxh3_64(bytes) != table.head_checksum {
        return Err("the checksum of the segment head does not match".into());
    }
    let (head, used): (SegmentHead, usize) =
        decode_bounded(bytes).map_err(|e| format!("segment head: {e}"))?;
    if used != bytes.len() {
        return Err(format!(
            "{} unexpected bytes after the segment head",
            bytes.len() - used
        ));
    }
    if head.catalogue.len() != table.entries.len()
        || head
            .catalogue
            .iter()
            .zip(&table.entries)
            .any(|(c, e)| c.id != e.id)
    {
        return Err("the segment head and its table list different shapes".into());
    }
    Ok(head)
}

/// The descriptor block of a parsed payload as floats, in place: `None` when the bytes are not
/// aligned for `f32` or the machine is not little endian (then [`record`] decodes them).
pub(crate) fn block<'a>(payload: &'a [u8], table: &Table) -> Option<&'a [f32]> {
    if cfg!(target_endian = "big") {
        return None;
    }
    bytemuck::try_cast_slice(&payload[table.block.clone()]).ok()
}

/// Decodes record `i` of a parsed payload: checks its checksum, decodes it, puts its
/// descriptors back and validates it.
pub(crate) fn record<const D: usize>(
    payload: &[u8],
    table: &Table,
    i: usize,
) -> Result<ShapeRecord<D>, String> {
    let e = table.entries[i];
    // parse() checked that the record and the block lie within the payload
    let body = &payload[e.offset as usize..e.offset as usize + e.len as usize];
    let start = table.block.start + 4 * D * e.first as usize;
    let end = start + 4 * D * e.components as usize;
    if end > table.block.end {
        return Err(format!(
            "the descriptors of shape {} are beyond the descriptor block",
            e.id
        ));
    }
    let desc = &payload[start..end];
    if record_checksum(body, desc) != e.checksum {
        return Err(format!(
            "the checksum of the record of shape {} does not match",
            e.id
        ));
    }
    let (b, used): (Body, usize) =
        decode_bounded(body).map_err(|err| format!("record of shape {}: {err}", e.id))?;
    if used != body.len() {
        return Err(format!(
            "{} unexpected bytes after the record of shape {}",
            body.len() - used,
            e.id
        ));
    }
    let m = b.parts.len();
    if m != e.components as usize {
        return Err(format!(
            "the record of shape {} has {m} components, the table says {}",
            e.id, e.components
        ));
    }
    let layout = expand(b.layout, m).map_err(|r| format!("shape {}: {r}", e.id))?;
    let components = b
        .parts
        .into_iter()
        .zip(desc.chunks_exact(4 * D))
        .map(|(p, d)| {
            let mut descriptor = [0f32; D];
            for (v, b) in descriptor.iter_mut().zip(d.chunks_exact(4)) {
                *v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
            ComponentRecord {
                descriptor,
                centre_vertex: p.centre_vertex,
                area_fraction: p.area_fraction,
                keypoint_count: p.keypoint_count,
                centre: p.centre,
            }
        })
        .collect();
    let r = ShapeRecord {
        path: b.path,
        canonical_path: b.canonical_path,
        content_hash: b.content_hash,
        vertex_count: b.vertex_count,
        face_count: b.face_count,
        surface_area: b.surface_area,
        components,
        layout,
        sample: b.sample,
        boundary_vertices: b.boundary_vertices,
    };
    r.validate()
        .map_err(|err| format!("shape {}: {err}", e.id))?;
    Ok(r)
}

/// Recomputes the inner checksums of a format-5 `payload` (the head's, every record's, the
/// prefix and table's) after a test changed its bytes, so that the decoders behind them run;
/// leaves the payload as it is where its offsets do not fit.
#[cfg(test)]
pub(crate) fn refresh_checksums(payload: &mut [u8], dim: usize) {
    let Ok(table) = parse_unchecked(payload) else {
        return;
    };
    if let Some(head) = payload.get(table.head.clone()) {
        let sum = xxh3_64(head);
        put_u64(payload, 48, sum);
    }
    for (i, e) in table.entries.iter().enumerate() {
        let start = table.block.start + 4 * dim * e.first as usize;
        let end = start + 4 * dim * e.components as usize;
        let body = payload.get(e.offset as usize..e.offset as usize + e.len as usize);
        if let (Some(body), Some(desc)) = (body, payload.get(start..end)) {
            let sum = record_checksum(body, desc);
            put_u64(payload, PREFIX_LEN + ENTRY_LEN * i + 24, sum);
        }
    }
    let table_end = PREFIX_LEN + ENTRY_LEN * table.entries.len();
    let mut h = Xxh3Default::new();
    h.update(&payload[..56]);
    h.update(&payload[PREFIX_LEN..table_end]);
    let sum = h.digest();
    put_u64(payload, 56, sum);
}

/// [`parse`] with the prefix's checksum made to hold first (for [`refresh_checksums`]).
#[cfg(test)]
fn parse_unchecked(payload: &mut [u8]) -> Result<Table, String> {
    if payload.len() < PREFIX_LEN {
        return Err(String::new());
    }
    let n = usize::try_from(le_u64(payload)).map_err(|e| e.to_string())?;
    let table_end = n
        .checked_mul(ENTRY_LEN)
        .and_then(|t| t.checked_add(PREFIX_LEN))
        .filter(|&t| t <= payload.len())
        .ok_or_else(String::new)?;
    let mut h = Xxh3Default::new();
    h.update(&payload[..56]);
    h.update(&payload[PREFIX_LEN..table_end]);
    let sum = h.digest();
    put_u64(payload, 56, sum);
    parse(payload)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::head::CatalogueEntry;
    use crate::synthetic;

    fn head_of<const D: usize>(recs: &[ShapeRecord<D>], first_id: u64) -> SegmentHead {
        SegmentHead {
            dim: D as u32,
            number: 3,
            catalogue: recs
                .iter()
                .enumerate()
                .map(|(i, r)| CatalogueEntry {
                    id: ShapeId(first_id + i as u64),
                    canonical_path: r.canonical_path.to_string_lossy().into_owned(),
                    content_hash: r.content_hash,
                })
                .collect(),
        }
    }

    /// Records come back bit for bit, symmetric layouts and others, and the block holds the
    /// descriptors in order.
    #[test]
    fn records_round_trip() {
        const D: usize = 5;
        let mut recs = synthetic::records::<D>(3, 0..6);
        // a symmetric layout with a zero diagonal, stored as its triangle
        let m = recs[1].components.len();
        for i in 0..m {
            for j in 0..m {
                recs[1].layout[i * m + j] = if i == j { 0.0 } else { (i + j) as f32 };
            }
        }
        assert!(triangle(&recs[1].layout, m).is_some());
        // and one that is not symmetric, stored whole
        let m0 = recs[0].components.len();
        recs[0].layout[1] = recs[0].layout[m0] + 1.0;
        assert!(triangle(&recs[0].layout, m0).is_none());
        let head = head_of(&recs, 10);
        let payload = encode::<D>(&head, &recs).unwrap();
        let table = parse(&payload).unwrap();
        table.check_block(D).unwrap();
        assert!(table.check_block(D + 1).is_err());
        assert_eq!(table.entries.len(), 6);
        assert_eq!(super::head(&payload, &table).unwrap(), head);
        for (i, r) in recs.iter().enumerate() {
            assert_eq!(&record::<D>(&payload, &table, i).unwrap(), r);
        }
        let block = block(&payload, &table).unwrap();
        let all: Vec<f32> = recs
            .iter()
            .flat_map(|r| r.components.iter().flat_map(|c| c.descriptor))
            .collect();
        assert_eq!(block, &all[..]);
    }

    /// A flipped bit anywhere is reported by the parse, the head or the record it falls in,
    /// or (in the zero padding before the block) changes nothing that is read.
    #[test]
    fn every_flip_is_caught_where_it_is_read() {
        const D: usize = 3;
        let recs = synthetic::records::<D>(5, 0..3);
        let head = head_of(&recs, 0);
        let payload = encode::<D>(&head, &recs).unwrap();
        for at in 0..payload.len() {
            let mut p = payload.clone();
            p[at] ^= 0x10;
            let caught = match parse(&p) {
                Err(_) => true,
                Ok(t) => {
                    t.check_block(D).is_err()
                        || super::head(&p, &t).is_err()
                        || (0..3).any(|i| record::<D>(&p, &t, i).is_err())
                }
            };
            let padding = {
                let t = parse(&payload).unwrap();
                (t.head.end..t.block.start).contains(&at)
            };
            assert!(caught || padding, "a flip at byte {at} went unnoticed");
        }
    }
}
