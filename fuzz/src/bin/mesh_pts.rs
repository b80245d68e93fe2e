//! Fuzz target: the PTS point-cloud reader on arbitrary bytes (count lines, blocks, columns),
//! through `read_input` (`read_mesh` is `read_input` and a check).
fn main() {
    afl::fuzz!(|data: &[u8]| {
        let _ = keycomp_mesh::read_input_from_bytes(data, keycomp_mesh::Format::Pts);
    });
}
