//! Fuzz target: the canonical surface (`keycomp_surface::canonical`) of any small mesh an OFF
//! file gives: the clean-mesh path (hole filling, the pieces' separation test, isotropic
//! remeshing) and the reconstruction (offset volume, surface nets, trimming). It must return a
//! surface or an error, never panic or hang. Inputs of more than 64 faces are left to the
//! readers' targets, and the budget is the smallest allowed, so that one run stays short.
fn main() {
    afl::fuzz!(|data: &[u8]| {
        let Ok(read) = keycomp_mesh::read_mesh_from_bytes(data, keycomp_mesh::Format::Off) else {
            return;
        };
        if read.mesh.faces.len() > 64 {
            return;
        }
        let params = keycomp_surface::SurfaceParams {
            vertices: keycomp_surface::SurfaceParams::MIN_VERTICES,
            ..keycomp_surface::SurfaceParams::default()
        };
        let _ = keycomp_surface::canonical(keycomp_surface::Input::Mesh(&read.mesh), &params);
    });
}
