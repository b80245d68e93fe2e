//! Fuzz target: the MANIFEST decoder on arbitrary payloads, with the checksum check bypassed;
//! the first byte picks the format version (1 or the current one).
fn main() {
    afl::fuzz!(|data: &[u8]| {
        if let Some((&v, payload)) = data.split_first() {
            let version = if v % 2 == 0 {
                1
            } else {
                keycomp_index::FORMAT_VERSION
            };
            let _ = keycomp_index::fuzzing::decode_manifest_payload(version, payload);
        }
    });
}
