//! Fuzz target: the OFF reader on arbitrary bytes (parsing and validation, as `read_mesh`).
fn main() {
    afl::fuzz!(|data: &[u8]| {
        let _ = keycomp_mesh::read_mesh_from_bytes(data, keycomp_mesh::Format::Off);
    });
}
