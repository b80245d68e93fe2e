//! Fuzz target: the XYZ point-cloud reader on arbitrary bytes (columns, separators, comments,
//! normals), through `read_input` (`read_mesh` is `read_input` and a check).
fn main() {
    afl::fuzz!(|data: &[u8]| {
        let _ = keycomp_mesh::read_input_from_bytes(data, keycomp_mesh::Format::Xyz);
    });
}
