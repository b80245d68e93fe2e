//! The decoders of the index files without their footer and checksum, for fuzzing: every
//! check a reader makes after the checksum runs on the bytes given. A crafted or damaged file
//! whose checksum holds reaches exactly this code, so it must return an error, never panic or
//! allocate far beyond the bytes' size (the fuzz targets in `fuzz/` at the workspace root).

use std::path::Path;

use crate::error::Result;
use crate::file::FOOTER_LEN;
use crate::ivf::{Flat, Ivf, Origin};

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
fn cache_origins() -> Vec<Origin> {
    (0..8)
        .map(|position| Origin {
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
    let flat = Flat {
        data: &points,
        d: 8,
    };
    Ivf::from_payload(payload, CACHE_KEY, &flat, 8, &cache_origins()).is_some()
}

/// A valid search-cache payload for [`decode_search_cache_payload`] (a fuzzing seed).
pub fn search_cache_seed() -> Vec<u8> {
    let points = cache_points();
    let flat = Flat {
        data: &points,
        d: 8,
    };
    let sealed = Ivf::build(&flat, 8).to_cache(CACHE_KEY, &cache_origins());
    sealed[..sealed.len() - FOOTER_LEN].to_vec()
}

/// Decodes a manifest payload (a MANIFEST without its footer) of format `version`.
pub fn decode_manifest_payload(version: u32, payload: &[u8]) -> Result<()> {
    crate::manifest::Manifest::from_payload(Path::new("fuzzed-manifest"), version, payload, None)
        .map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fuzzing_seed_is_accepted() {
        let seed = search_cache_seed();
        assert!(decode_search_cache_payload(&seed));
        assert!(!decode_search_cache_payload(&seed[..seed.len() - 1]));
    }
}
