//! Reads glTF 2.0 files: `.gltf` (JSON, with buffers in `.bin` files beside it or in `data:`
//! URIs) and `.glb` (binary, buffers in its BIN chunk). The `gltf` crate parses and validates
//! the document; the accessors are read here, every offset and length checked against the
//! buffer, so no file makes the reader panic or allocate beyond its size.
//!
//! Conventions:
//! - The mesh is every triangle primitive of the default scene (the first scene when none is
//!   marked default; every mesh, untransformed, in file order when the file has no scene), with
//!   node transforms applied (each node's matrix, or translation · rotation · scale, times its
//!   parent's).
//! - Vertex ids: the primitives' vertices concatenated in scene order (nodes depth first, in
//!   the order the scene and each node list their children; a node's primitives in mesh order),
//!   each primitive's vertices in accessor order. Nothing is welded: a vertex shared by two
//!   primitives appears twice, and the pieces are separate components of the mesh.
//! - Modes: triangles, triangle strips (triangle k is `(s[k], s[k+1], s[k+2])`, the first two
//!   swapped for odd k) and triangle fans (`(s[0], s[k+1], s[k+2])`), indexed or not. Point and
//!   line primitives are left out; a file with no triangle primitive is an error. A node whose
//!   matrix mirrors (negative determinant) has its triangles' winding reversed, so the surface
//!   keeps its orientation.
//! - Positions must be three 32-bit floats (the core format). Quantized positions
//!   (`KHR_mesh_quantization`), sparse accessors, and files requiring Draco
//!   (`KHR_draco_mesh_compression`) or meshopt (`EXT_meshopt_compression`) compression are
//!   refused with the reason. Morph targets, skins, normals and materials are ignored.

use std::path::Path;

use base64::Engine as _;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use nalgebra::{Matrix4, Point3};

use super::RawMesh;
use super::output::read_input;
use crate::{ErrorKind, MeshError, VertexId};

/// Compression extensions whose data this reader cannot decode.
const COMPRESSION: [&str; 2] = ["KHR_draco_mesh_compression", "EXT_meshopt_compression"];

/// Most node visits while walking a scene: a node may appear once per path, and a valid file
/// visits each node once, so this only stops files whose nodes are shared many times over.
const MAX_NODE_VISITS_PER_NODE: usize = 16;

fn syntax(msg: impl Into<String>) -> MeshError {
    MeshError::new(ErrorKind::Syntax(msg.into()))
}

/// Parses a glTF or GLB file's bytes. `base` is the folder of the file, where `.bin` buffers
/// named by relative URIs are found; without it (bytes not from a file), only GLB and `data:`
/// buffers can be read.
pub(crate) fn read_gltf(bytes: &[u8], base: Option<&Path>) -> Result<RawMesh, MeshError> {
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(MeshError::new(ErrorKind::Empty));
    }
    check_glb_header(bytes)?;
    let gltf = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| syntax(format!("glTF: {e}")))?;
    check_position_accessors(gltf.document.as_json())?;
    let blob = gltf.blob;
    let document = gltf::Document::from_json(gltf.document.into_json())
        .map_err(|e| syntax(format!("glTF: {e}")))?;
    let doc = &document;
    for ext in doc.extensions_required() {
        if COMPRESSION.contains(&ext) {
            return Err(syntax(format!(
                "the file is compressed with {ext}, which keycomp cannot decode; write it \
                 uncompressed (e.g. `gltf-transform copy` without compression) first"
            )));
        }
    }
    let buffers = load_buffers(doc, blob.as_deref(), base)?;
    let mut out = RawMesh {
        positions: Vec::new(),
        faces: Vec::new(),
    };
    let mut triangle_primitives = 0usize;
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    match scene {
        Some(scene) => {
            let mut budget = doc.nodes().len().saturating_mul(MAX_NODE_VISITS_PER_NODE);
            let mut path = Vec::new();
            for node in scene.nodes() {
                walk(
                    &node,
                    &Matrix4::identity(),
                    &buffers,
                    &mut path,
                    &mut budget,
                    &mut out,
                    &mut triangle_primitives,
                )?;
            }
        }
        None => {
            for mesh in doc.meshes() {
                add_mesh(
                    &mesh,
                    &Matrix4::identity(),
                    &buffers,
                    &mut out,
                    &mut triangle_primitives,
                )?;
            }
        }
    }
    if triangle_primitives == 0 {
        return Err(syntax(
            "no triangle primitive in the scene (only points or lines, or no mesh at all)",
        ));
    }
    Ok(out)
}

/// A GLB whose header announces fewer bytes than the header itself would make the `gltf`
/// crate's length arithmetic underflow: refused here first.
fn check_glb_header(bytes: &[u8]) -> Result<(), MeshError> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let Some(len) = bytes.get(8..12) else {
        return Err(MeshError::new(ErrorKind::Truncated {
            expected: "the GLB header".into(),
        }));
    };
    let announced = u32::from_le_bytes([len[0], len[1], len[2], len[3]]) as usize;
    if announced < 12 + 8 || announced > bytes.len() {
        return Err(syntax(format!(
            "GLB header: the file says it has {announced} bytes, it has {}",
            bytes.len()
        )));
    }
    Ok(())
}

/// Every primitive's POSITION accessor exists. The `gltf` crate's validation reads that
/// accessor before checking its index (and panics on a bad one), so this runs first.
fn check_position_accessors(root: &gltf::json::Root) -> Result<(), MeshError> {
    let n = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for accessor in prim.attributes.values() {
                if accessor.value() >= n {
                    return Err(syntax(format!(
                        "mesh {m} primitive {p}: an attribute names accessor {}, the file has {n}",
                        accessor.value()
                    )));
                }
            }
        }
    }
    Ok(())
}

/// The data of every buffer, in the document's order, each at least as long as declared.
fn load_buffers(
    doc: &gltf::Document,
    blob: Option<&[u8]>,
    base: Option<&Path>,
) -> Result<Vec<Vec<u8>>, MeshError> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let i = buffer.index();
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .ok_or_else(|| {
                    syntax(format!(
                        "buffer {i} is the GLB's BIN chunk, which is missing"
                    ))
                })?
                .to_vec(),
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let Some((_, encoded)) = rest.split_once(";base64,") else {
                        return Err(syntax(format!("buffer {i}: a data URI that is not base64")));
                    };
                    base64::engine::general_purpose::STANDARD
                        .decode(encoded)
                        .map_err(|e| syntax(format!("buffer {i}: bad base64 data: {e}")))?
                } else {
                    let Some(base) = base else {
                        return Err(syntax(format!(
                            "buffer {i} is in the file '{uri}', which cannot be read without the \
                             glTF file's folder"
                        )));
                    };
                    if uri.contains("://") || Path::new(uri).is_absolute() {
                        return Err(syntax(format!(
                            "buffer {i}: '{uri}' is not a path relative to the glTF file"
                        )));
                    }
                    let file = base.join(percent_decode(uri));
                    read_input(&file).map_err(|e| {
                        MeshError::new(ErrorKind::Other(format!(
                            "buffer {i}: cannot read {}: {e}",
                            file.display()
                        )))
                    })?
                }
            }
        };
        if data.len() < buffer.length() {
            return Err(MeshError::new(ErrorKind::Truncated {
                expected: format!(
                    "buffer {i} ({} bytes declared, {} present)",
                    buffer.length(),
                    data.len()
                ),
            }));
        }
        out.push(data);
    }
    Ok(out)
}

/// `%20` and the like in a relative URI, as file names with spaces are written.
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && let Some(h) = bytes.get(i + 1..i + 3)
            && let Ok(v) = u8::from_str_radix(std::str::from_utf8(h).unwrap_or("zz"), 16)
        {
            out.push(v);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Adds `node` and its children, depth first.
fn walk(
    node: &gltf::Node,
    parent: &Matrix4<f64>,
    buffers: &[Vec<u8>],
    path: &mut Vec<usize>,
    budget: &mut usize,
    out: &mut RawMesh,
    triangle_primitives: &mut usize,
) -> Result<(), MeshError> {
    if path.contains(&node.index()) {
        return Err(syntax(format!(
            "node {} is its own ancestor (the node hierarchy has a cycle)",
            node.index()
        )));
    }
    if *budget == 0 {
        return Err(syntax(
            "the scene's nodes are shared too many times over (not a tree)",
        ));
    }
    *budget -= 1;
    let m = node.transform().matrix();
    let local = Matrix4::from_fn(|r, c| f64::from(m[c][r]));
    let world = parent * local;
    if let Some(mesh) = node.mesh() {
        add_mesh(&mesh, &world, buffers, out, triangle_primitives)?;
    }
    path.push(node.index());
    for child in node.children() {
        walk(
            &child,
            &world,
            buffers,
            path,
            budget,
            out,
            triangle_primitives,
        )?;
    }
    path.pop();
    Ok(())
}

/// Adds the triangle primitives of `mesh`, transformed by `world`.
fn add_mesh(
    mesh: &gltf::Mesh,
    world: &Matrix4<f64>,
    buffers: &[Vec<u8>],
    out: &mut RawMesh,
    triangle_primitives: &mut usize,
) -> Result<(), MeshError> {
    let mirrored = world.fixed_view::<3, 3>(0, 0).determinant() < 0.0;
    for prim in mesh.primitives() {
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            continue;
        }
        let at = |msg: String| {
            syntax(format!(
                "mesh {} primitive {}: {msg}",
                mesh.index(),
                prim.index()
            ))
        };
        let Some(acc) = prim.get(&gltf::Semantic::Positions) else {
            return Err(at("no POSITION attribute".into()));
        };
        if acc.data_type() != DataType::F32 || acc.dimensions() != Dimensions::Vec3 {
            return Err(at(format!(
                "positions are {:?} {:?}; only three 32-bit floats are supported \
                 (quantized positions, KHR_mesh_quantization, are not)",
                acc.dimensions(),
                acc.data_type()
            )));
        }
        let base = out.positions.len();
        let count = acc.count();
        let raw =
            accessor_elements(&acc, buffers, 12).map_err(|m| at(format!("positions: {m}")))?;
        out.positions.reserve(count);
        for e in raw {
            let f = |k: usize| f64::from(f32::from_le_bytes([e[k], e[k + 1], e[k + 2], e[k + 3]]));
            let p = world.transform_point(&Point3::new(f(0), f(4), f(8)));
            out.positions.push(p);
        }
        let order: Vec<u32> = match prim.indices() {
            Some(ia) => {
                if ia.dimensions() != Dimensions::Scalar {
                    return Err(at("indices are not scalars".into()));
                }
                let size = match ia.data_type() {
                    DataType::U8 => 1,
                    DataType::U16 => 2,
                    DataType::U32 => 4,
                    other => return Err(at(format!("indices of type {other:?}"))),
                };
                let raw = accessor_elements(&ia, buffers, size)
                    .map_err(|m| at(format!("indices: {m}")))?;
                let mut v = Vec::with_capacity(ia.count());
                for e in raw {
                    let i = match size {
                        1 => u32::from(e[0]),
                        2 => u32::from(u16::from_le_bytes([e[0], e[1]])),
                        _ => u32::from_le_bytes([e[0], e[1], e[2], e[3]]),
                    };
                    if i as usize >= count {
                        return Err(MeshError::new(ErrorKind::IndexOutOfRange {
                            index: u64::from(i),
                            vertices: count as u64,
                        }));
                    }
                    v.push(i);
                }
                v
            }
            None => (0..count as u32).collect(),
        };
        let id = |i: u32| -> Result<VertexId, MeshError> {
            VertexId::try_from(base + i as usize).map_err(|_| at("too many vertices".into()))
        };
        let mut push = |a: u32, b: u32, c: u32| -> Result<(), MeshError> {
            let t = [id(a)?, id(b)?, id(c)?];
            out.faces
                .push(if mirrored { [t[0], t[2], t[1]] } else { t });
            Ok(())
        };
        match mode {
            Mode::Triangles => {
                for t in order.chunks_exact(3) {
                    push(t[0], t[1], t[2])?;
                }
            }
            Mode::TriangleStrip => {
                for (k, w) in order.windows(3).enumerate() {
                    if k % 2 == 0 {
                        push(w[0], w[1], w[2])?;
                    } else {
                        push(w[1], w[0], w[2])?;
                    }
                }
            }
            _ => {
                if let Some((&first, rest)) = order.split_first() {
                    for w in rest.windows(2) {
                        push(first, w[0], w[1])?;
                    }
                }
            }
        }
        *triangle_primitives += 1;
    }
    Ok(())
}

/// The `size`-byte elements of `acc`, each a slice of its buffer; every offset and length
/// checked (an error names what does not fit).
fn accessor_elements<'b>(
    acc: &gltf::Accessor,
    buffers: &'b [Vec<u8>],
    size: usize,
) -> Result<Vec<&'b [u8]>, String> {
    if acc.sparse().is_some() {
        return Err("sparse accessors are not supported".into());
    }
    let Some(view) = acc.view() else {
        return Err("the accessor has no buffer view".into());
    };
    let data = buffers
        .get(view.buffer().index())
        .ok_or("the buffer view names no buffer")?;
    let view_data = view
        .offset()
        .checked_add(view.length())
        .and_then(|end| data.get(view.offset()..end))
        .ok_or("the buffer view lies outside its buffer")?;
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!("a stride of {stride} bytes for elements of {size}"));
    }
    let count = acc.count();
    // The whole range must be in the view before anything is allocated.
    let last_end = count
        .checked_sub(1)
        .and_then(|n| n.checked_mul(stride))
        .and_then(|x| x.checked_add(acc.offset()))
        .and_then(|x| x.checked_add(size));
    match last_end {
        Some(end) if end <= view_data.len() => {}
        _ if count == 0 => return Ok(Vec::new()),
        _ => {
            return Err(format!(
                "{count} elements of {size} bytes (stride {stride}, offset {}) do not fit in the \
                 {}-byte buffer view",
                acc.offset(),
                view_data.len()
            ));
        }
    }
    Ok((0..count)
        .map(|i| {
            let start = acc.offset() + i * stride;
            &view_data[start..start + size]
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{GltfBuffer, glb, glb_of, gltf_doc};
    use crate::io::{Format, read_mesh, read_mesh_from_bytes};
    use crate::{ErrorKind, synth};

    const QUAD: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];

    /// One node drawing the mesh.
    const ONE_NODE: &str = r#"[{"mesh":0}]"#;

    fn doc(indices: Option<&[u32]>, mode: u32, nodes: &str, roots: &str) -> Vec<u8> {
        let (json, bin) = gltf_doc(&QUAD, indices, mode, nodes, roots, GltfBuffer::Bin, "[]");
        glb(&json, &bin)
    }

    fn error(bytes: &[u8]) -> String {
        read_mesh_from_bytes(bytes, Format::Gltf)
            .map(|_| ())
            .expect_err("an error")
            .to_string()
    }

    /// A GLB holds the mesh exactly (positions as f32), vertex ids in accessor order.
    #[test]
    fn glb_round_trip() {
        let m = synth::protrusion_sphere(3, 0.8, 0.25);
        let back = read_mesh_from_bytes(&glb_of(&m), Format::Gltf)
            .unwrap()
            .mesh;
        assert_eq!(back.faces, m.faces);
        assert_eq!(back.positions.len(), m.positions.len());
        for (a, b) in back.positions.iter().zip(&m.positions) {
            assert_eq!(a.x, f64::from(b.x as f32));
            assert_eq!(a.z, f64::from(b.z as f32));
        }
    }

    /// The same document with its buffer in a `data:` URI, and in a `.bin` file beside it (read
    /// through `read_mesh`, which knows the folder; bytes alone cannot reach the file).
    #[test]
    fn embedded_and_external_buffers() {
        let ix = [0u32, 1, 2, 2, 1, 3];
        let (json, _) = gltf_doc(
            &QUAD,
            Some(&ix),
            4,
            r#"[{"mesh":0}]"#,
            "[0]",
            GltfBuffer::DataUri,
            "[]",
        );
        let m = read_mesh_from_bytes(json.as_bytes(), Format::Gltf)
            .unwrap()
            .mesh;
        assert_eq!(m.faces, vec![[0, 1, 2], [2, 1, 3]]);
        let dir = tempfile::tempdir().unwrap();
        let (json, bin) = gltf_doc(
            &QUAD,
            Some(&ix),
            4,
            r#"[{"mesh":0}]"#,
            "[0]",
            GltfBuffer::File("my%20mesh.bin"),
            "[]",
        );
        std::fs::write(dir.path().join("my mesh.bin"), &bin).unwrap();
        let path = dir.path().join("quad.gltf");
        std::fs::write(&path, &json).unwrap();
        assert_eq!(read_mesh(&path).unwrap().mesh.faces, m.faces);
        let e = error(json.as_bytes());
        assert!(e.contains("my%20mesh.bin"), "{e}");
        std::fs::remove_file(dir.path().join("my mesh.bin")).unwrap();
        let e = read_mesh(&path).unwrap_err().to_string();
        assert!(e.contains("quad.gltf") && e.contains("my mesh.bin"), "{e}");
    }

    /// Strips alternate their winding, fans turn around their first vertex; without indices
    /// the vertices are taken in order.
    #[test]
    fn strips_and_fans() {
        let m = read_mesh_from_bytes(&doc(None, 5, r#"[{"mesh":0}]"#, "[0]"), Format::Gltf);
        assert_eq!(m.unwrap().mesh.faces, vec![[0, 1, 2], [2, 1, 3]]);
        let fan = doc(Some(&[0, 1, 3, 2]), 6, r#"[{"mesh":0}]"#, "[0]");
        let m = read_mesh_from_bytes(&fan, Format::Gltf).unwrap().mesh;
        assert_eq!(m.faces, vec![[0, 1, 3], [0, 3, 2]]);
    }

    /// Two nodes drawing the same mesh, one translated under a scaled parent, one mirrored:
    /// primitives concatenated in scene order, transforms composed, mirrored winding reversed.
    #[test]
    fn node_transforms_in_scene_order() {
        let nodes = r#"[{"children":[1],"scale":[2,2,2]},{"mesh":0,"translation":[0,0,1]},{"mesh":0,"scale":[-1,1,1]}]"#;
        let bytes = doc(Some(&[0, 1, 2]), 4, nodes, "[0,2]");
        let m = read_mesh_from_bytes(&bytes, Format::Gltf).unwrap().mesh;
        assert_eq!(m.positions.len(), 8);
        // node 1: scale 2 applied after its own translation: (1, 0, 0) → (2, 0, 2)
        assert_eq!(m.positions[1], crate::Point3::new(2.0, 0.0, 2.0));
        // node 2: mirrored in x, ids follow node 1's four vertices, winding reversed
        assert_eq!(m.positions[5], crate::Point3::new(-1.0, 0.0, 0.0));
        assert_eq!(m.faces, vec![[0, 1, 2], [4, 6, 5]]);
    }

    #[test]
    fn what_cannot_be_read_is_named() {
        let draco = r#"["KHR_draco_mesh_compression"]"#;
        let (json, bin) = gltf_doc(&QUAD, None, 4, ONE_NODE, "[0]", GltfBuffer::Bin, draco);
        let e = error(&glb(&json, &bin));
        assert!(e.contains("KHR_draco_mesh_compression"), "{e}");
        let e = error(&doc(None, 1, r#"[{"mesh":0}]"#, "[0]"));
        assert!(e.contains("no triangle primitive"), "{e}");
        let e = read_mesh_from_bytes(
            &doc(Some(&[0, 1, 9]), 4, r#"[{"mesh":0}]"#, "[0]"),
            Format::Gltf,
        )
        .unwrap_err();
        assert!(
            matches!(e.kind, ErrorKind::IndexOutOfRange { index: 9, .. }),
            "{e}"
        );
        let e = error(&doc(
            None,
            4,
            r#"[{"mesh":0,"children":[1]},{"children":[0]}]"#,
            "[0]",
        ));
        assert!(e.contains("cycle") || e.contains("glTF"), "{e}");
        // a GLB header announcing fewer bytes than a header
        let mut bad = doc(None, 4, r#"[{"mesh":0}]"#, "[0]");
        bad[8..12].copy_from_slice(&4u32.to_le_bytes());
        assert!(error(&bad).contains("GLB header"));
        // an accessor claiming more vertices than its view holds
        let (json, bin) = gltf_doc(&QUAD, None, 4, ONE_NODE, "[0]", GltfBuffer::Bin, "[]");
        let json = json.replacen(r#""count":4"#, r#""count":4000000000"#, 1);
        let e = error(&glb(&json, &bin));
        assert!(e.contains("do not fit"), "{e}");
        assert!(matches!(
            read_mesh_from_bytes(b"  ", Format::Gltf).unwrap_err().kind,
            ErrorKind::Empty
        ));
    }

    /// `write_glb` writes what the reader reads back: the mesh with f32 positions.
    #[test]
    fn write_glb_round_trip() {
        let m = synth::torus(1.0, 0.3, 12, 8);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.glb");
        crate::write_glb(&m, &path).unwrap();
        let back = read_mesh(&path).unwrap().mesh;
        assert_eq!(back.faces, m.faces);
        for (a, b) in back.positions.iter().zip(&m.positions) {
            assert_eq!(a.y, f64::from(b.y as f32));
        }
    }

    /// With colours, the GLB passes the `gltf` crate's validation, its primitive has a
    /// `COLOR_0` of one normalised RGBA byte quadruple per vertex holding the colours, and the
    /// reader still reads the mesh back.
    #[test]
    fn colored_glb_is_valid_gltf() {
        let m = synth::torus(1.0, 0.3, 12, 8);
        let colors: Vec<[u8; 3]> = (0..m.num_vertices())
            .map(|i| [i as u8, (2 * i) as u8, 7])
            .collect();
        let bytes = crate::glb_bytes(&m, Some(&colors));
        let doc = gltf::Gltf::from_slice(&bytes).unwrap();
        let prim = doc.meshes().next().unwrap().primitives().next().unwrap();
        let acc = prim.get(&gltf::Semantic::Colors(0)).unwrap();
        assert_eq!(acc.count(), m.num_vertices());
        assert!(acc.normalized());
        assert_eq!(acc.dimensions(), gltf::accessor::Dimensions::Vec4);
        let view = acc.view().unwrap();
        let blob = doc.blob.as_deref().unwrap();
        let at = view.offset() + 4 * 5;
        assert_eq!(&blob[at..at + 4], &[5, 10, 7, 255]);
        let back = read_mesh_from_bytes(&bytes, Format::Gltf).unwrap().mesh;
        assert_eq!(back.faces, m.faces);
        // colours of the wrong length are left out
        let plain = crate::glb_bytes(&m, Some(&colors[1..]));
        assert_eq!(plain, crate::glb_bytes(&m, None));
    }

    /// An attribute naming an accessor the file does not have is an error (the `gltf`
    /// crate's own validation would index out of bounds on it; found by fuzzing).
    #[test]
    fn a_missing_position_accessor_is_an_error() {
        let (json, bin) = gltf_doc(&QUAD, None, 4, ONE_NODE, "[0]", GltfBuffer::Bin, "[]");
        let json = json.replacen(r#""POSITION":0"#, r#""POSITION":7"#, 1);
        let e = error(&glb(&json, &bin));
        assert!(e.contains("accessor 7"), "{e}");
    }

    /// Truncations and byte flips of a GLB give a mesh or an error, never a panic.
    #[test]
    fn damaged_glb_never_panics() {
        let bytes = glb_of(&synth::icosphere(1, 1.0));
        for cut in 0..bytes.len() {
            let _ = read_mesh_from_bytes(&bytes[..cut], Format::Gltf);
        }
        for i in 0..bytes.len() {
            let mut b = bytes.clone();
            b[i] ^= 0xA5;
            let _ = read_mesh_from_bytes(&b, Format::Gltf);
        }
    }
}
