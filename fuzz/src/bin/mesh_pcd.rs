//! Fuzz target: the PCD reader on arbitrary bytes: the header, ascii, binary and
//! binary_compressed data (LZF), organised clouds triangulated as range grids, through
//! `read_input` (`read_mesh` is `read_input` and a check).
fn main() {
    afl::fuzz!(|data: &[u8]| {
        let _ = keycomp_mesh::read_input_from_bytes(data, keycomp_mesh::Format::Pcd);
    });
}
