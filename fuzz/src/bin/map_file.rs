//! Fuzz target: the correspondence (map) file reader on arbitrary bytes, as `read_map`.
fn main() {
    afl::fuzz!(|data: &[u8]| {
        if let Ok(text) = std::str::from_utf8(data) {
            let _ = keycomp_bench::parse_map(text, std::path::Path::new("fuzzed.map"));
        }
    });
}
