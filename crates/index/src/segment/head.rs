//! The head of a segment payload: the descriptor length, the segment's number and its
//! catalogue (id, canonical path and content hash of each shape). The head alone is enough for
//! a writer deciding skip or replace, so it is decoded without the records.

use serde::{Deserialize, Serialize};

use crate::record::{ContentHash, ShapeId};

/// Catalogue entry of one shape in a segment head.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct CatalogueEntry {
    /// The shape's id.
    pub id: ShapeId,
    /// The shape's canonical path (its identity for skip/replace).
    pub canonical_path: String,
    /// Hash of the source file.
    pub content_hash: ContentHash,
}

/// The first part of a segment payload.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SegmentHead {
    /// Descriptor length `D`.
    pub dim: u32,
    /// The segment's number (must match its file name and manifest entry).
    pub number: u64,
    /// One entry per shape, ids strictly increasing.
    pub catalogue: Vec<CatalogueEntry>,
}

/// `D` as stored on disk.
pub(crate) fn dim_u32<const D: usize>() -> u32 {
    u32::try_from(D).unwrap_or(u32::MAX)
}
