//! Deterministic synthetic shape records for tests, the kill-test helper and size benchmarks.
//!
//! Record `i` of seed `s` is generated from its own ChaCha8 stream (seeded with `s` and `i`),
//! so any record can be regenerated alone to check what an index returns. Descriptors are
//! uniform in [0, 1)^D, 4 to 8 components per shape (6 on average), and the layout is a
//! symmetric matrix with a zero diagonal.

use std::path::PathBuf;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::record::{ComponentRecord, ContentHash, ShapeRecord};

/// Synthetic record number `i` for `seed` (version 0).
pub fn record<const D: usize>(seed: u64, i: u64) -> ShapeRecord<D> {
    record_version(seed, i, 0)
}

/// Synthetic record number `i` for `seed`, as "edited" `version` times: same paths, different
/// content hash and descriptors for each version.
pub fn record_version<const D: usize>(seed: u64, i: u64, version: u32) -> ShapeRecord<D> {
    let stream = i
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(u64::from(version));
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ stream);
    let m = rng.random_range(4..=8usize);
    let components: Vec<ComponentRecord<D>> = (0..m)
        .map(|_| {
            let mut c = ComponentRecord {
                descriptor: std::array::from_fn(|_| rng.random::<f32>()),
                centre_vertex: rng.random_range(0..10_000),
                area_fraction: rng.random_range(0.01..0.3),
                keypoint_count: rng.random_range(1..40),
                centre: None,
            };
            // a position from the values drawn (no extra draw: the stream stays as it was)
            c.centre = Some([
                c.descriptor.first().copied().unwrap_or(0.0),
                c.area_fraction,
                (c.centre_vertex % 100) as f32 * 0.01,
            ]);
            c
        })
        .collect();
    let mut layout = vec![0f32; m * m];
    for a in 0..m {
        for b in a + 1..m {
            let d = rng.random_range(0.05f32..1.5);
            layout[a * m + b] = d;
            layout[b * m + a] = d;
        }
    }
    let name = format!("shape-{i:07}.off");
    let mut hash_input = Vec::with_capacity(24);
    hash_input.extend_from_slice(&seed.to_le_bytes());
    hash_input.extend_from_slice(&i.to_le_bytes());
    hash_input.extend_from_slice(&version.to_le_bytes());
    ShapeRecord {
        path: PathBuf::from("synthetic").join(&name),
        canonical_path: PathBuf::from("/synthetic").join(&name),
        content_hash: ContentHash::of_bytes(&hash_input),
        vertex_count: rng.random_range(1_000..100_000),
        face_count: rng.random_range(2_000..200_000),
        surface_area: rng.random_range(0.1..100.0),
        // a small sample from the centres (no extra draw: the stream stays as it was)
        sample: components_centres(&components),
        boundary_vertices: (i % 3) as u32,
        components,
        layout,
    }
}

/// The centres of `components` that have one, as a surface sample.
fn components_centres<const D: usize>(components: &[ComponentRecord<D>]) -> Vec<[f32; 3]> {
    components.iter().filter_map(|c| c.centre).collect()
}

/// Records `range` of `seed` (version 0).
pub fn records<const D: usize>(seed: u64, range: std::ops::Range<u64>) -> Vec<ShapeRecord<D>> {
    range.map(|i| record(seed, i)).collect()
}
