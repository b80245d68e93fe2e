//! Fuzz target: the segment decoder on arbitrary payloads, with the checksum check bypassed
//! (descriptors of the product's length).
fn main() {
    afl::fuzz!(|data: &[u8]| {
        let _ = keycomp_index::fuzzing::decode_segment_payload::<{ keycomp_describe::DIM }>(data);
    });
}
