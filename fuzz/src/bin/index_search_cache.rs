//! Fuzz target: the search-cache decoder (`SEARCH-CACHE` without its footer) on arbitrary
//! payloads, checked against a fixed set of descriptors as a reader checks it.
fn main() {
    afl::fuzz!(|data: &[u8]| {
        let _ = keycomp_index::fuzzing::decode_search_cache_payload(data);
    });
}
