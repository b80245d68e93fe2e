//! Fuzz target: the PLY reader on arbitrary bytes: meshes, range grids (triangulated) and point
//! clouds, header lines that are not PLY keywords, through `read_input` (`read_mesh` is
//! `read_input` and a check).
fn main() {
    afl::fuzz!(|data: &[u8]| {
        let _ = keycomp_mesh::read_input_from_bytes(data, keycomp_mesh::Format::Ply);
    });
}
