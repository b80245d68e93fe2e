//! The records of segments of formats 1 to 4, read by this build and never written: a bincode
//! `Vec` of records after the head. Format 4 stores [`ShapeRecord`] as it is; format 3 without
//! the surface sample and the boundary count; formats 1 and 2 also without the parts' centre
//! positions (`index/README.md` at the workspace root, *Versions*). Read records get the
//! missing fields empty ([`ShapeRecord::sample`], [`ComponentRecord::centre`]) or zero.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::codec::decode_bounded;
use crate::record::{ComponentRecord, ContentHash, ShapeRecord, array_serde};

use super::head::SegmentHead;

/// Decodes the head at the start of a segment payload of format 1 to 4; returns it and the
/// bytes it took (the records follow).
pub(crate) fn head(payload: &[u8]) -> Result<(SegmentHead, usize), String> {
    decode_bounded(payload).map_err(|e| format!("segment head: {e}"))
}

/// Decodes the records `rest` holds (the bytes after the head) as format `version` (1 to 4)
/// stores them; there must be no byte after them.
pub(crate) fn records<const D: usize>(
    rest: &[u8],
    version: u32,
) -> Result<Vec<ShapeRecord<D>>, String> {
    let decoded = if version <= 2 {
        decode_bounded::<Vec<ShapeRecordV2<D>>>(rest)
            .map(|(r, used)| (r.into_iter().map(ShapeRecord::from).collect(), used))
    } else if version == 3 {
        decode_bounded::<Vec<ShapeRecordV3<D>>>(rest)
            .map(|(r, used)| (r.into_iter().map(ShapeRecord::from).collect(), used))
    } else {
        decode_bounded(rest)
    };
    let (records, used): (Vec<ShapeRecord<D>>, usize) =
        decoded.map_err(|e| format!("records: {e}"))?;
    if used != rest.len() {
        return Err(format!(
            "{} unexpected bytes after the records",
            rest.len() - used
        ));
    }
    Ok(records)
}

/// [`ComponentRecord`] as formats 1 and 2 store it (without [`ComponentRecord::centre`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct ComponentRecordV2<const D: usize> {
    #[serde(with = "array_serde")]
    descriptor: [f32; D],
    centre_vertex: u32,
    area_fraction: f32,
    keypoint_count: u32,
}

/// [`ShapeRecord`] as formats 1 and 2 store it.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct ShapeRecordV2<const D: usize> {
    path: PathBuf,
    canonical_path: PathBuf,
    content_hash: ContentHash,
    vertex_count: u32,
    face_count: u32,
    surface_area: f64,
    components: Vec<ComponentRecordV2<D>>,
    layout: Vec<f32>,
}

/// [`ShapeRecord`] as format 3 stores it (without [`ShapeRecord::sample`]).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct ShapeRecordV3<const D: usize> {
    path: PathBuf,
    canonical_path: PathBuf,
    content_hash: ContentHash,
    vertex_count: u32,
    face_count: u32,
    surface_area: f64,
    components: Vec<ComponentRecord<D>>,
    layout: Vec<f32>,
}

impl<const D: usize> From<ShapeRecordV3<D>> for ShapeRecord<D> {
    fn from(r: ShapeRecordV3<D>) -> Self {
        ShapeRecord {
            path: r.path,
            canonical_path: r.canonical_path,
            content_hash: r.content_hash,
            vertex_count: r.vertex_count,
            face_count: r.face_count,
            surface_area: r.surface_area,
            components: r.components,
            layout: r.layout,
            sample: Vec::new(),
            boundary_vertices: 0,
        }
    }
}

impl<const D: usize> From<ShapeRecordV2<D>> for ShapeRecord<D> {
    fn from(r: ShapeRecordV2<D>) -> Self {
        ShapeRecordV3 {
            path: r.path,
            canonical_path: r.canonical_path,
            content_hash: r.content_hash,
            vertex_count: r.vertex_count,
            face_count: r.face_count,
            surface_area: r.surface_area,
            components: r
                .components
                .into_iter()
                .map(|c| ComponentRecord {
                    descriptor: c.descriptor,
                    centre_vertex: c.centre_vertex,
                    area_fraction: c.area_fraction,
                    keypoint_count: c.keypoint_count,
                    centre: None,
                })
                .collect(),
            layout: r.layout,
        }
        .into()
    }
}
