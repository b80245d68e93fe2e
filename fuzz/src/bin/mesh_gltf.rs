//! Fuzz target: the glTF/GLB reader on arbitrary bytes (parsing, accessors, node walk and
//! validation, as `read_mesh` of a `.glb` or a `.gltf` with embedded buffers).
fn main() {
    afl::fuzz!(|data: &[u8]| {
        let _ = keycomp_mesh::read_mesh_from_bytes(data, keycomp_mesh::Format::Gltf);
    });
}
