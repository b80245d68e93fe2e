//! Test-only writers for every readable format and variant, to build round-trip and fuzzing
//! inputs from meshes generated in code. They are deliberately simple and independent of the
//! readers (binary STL is written by the `stl_io` crate).

use std::collections::HashMap;
use std::fmt::Write as _;

use crate::{Mesh, VertexId};

/// OFF variants: plain, comments everywhere with `NOFF` normals, `COFF` with colours and counts on
/// the header line, `CNOFF` with CRLF line ends, and no header keyword at all.
pub(crate) fn off_variants(m: &Mesh) -> Vec<(&'static str, Vec<u8>)> {
    let (nv, nf) = (m.positions.len(), m.faces.len());
    let mut plain = format!("OFF\n{nv} {nf} 0\n");
    let mut noff = format!("# made in a test\nNOFF # normals follow\n\n# counts\n{nv} {nf} 0\n");
    let mut coff = format!("COFF {nv} {nf} {}\n", 3 * nf / 2);
    let mut cnoff = format!("CNOFF\r\n{nv} {nf} 0\r\n");
    let mut bare = format!("{nv} {nf} 0\n");
    for (i, p) in m.positions.iter().enumerate() {
        let xyz = format!("{} {} {}", p.x, p.y, p.z);
        writeln!(plain, "{xyz}").unwrap();
        writeln!(noff, "  {xyz}  0 0 1 # vertex {i}").unwrap();
        writeln!(coff, "{xyz} 255 128 0 255").unwrap();
        write!(cnoff, "{xyz} 0 0 1 0.5 0.5 0.5 1\r\n").unwrap();
        writeln!(bare, "{xyz}").unwrap();
        if i == 0 {
            noff.push_str("# a comment between vertices\n\n");
        }
    }
    for [a, b, c] in &m.faces {
        writeln!(plain, "3 {a} {b} {c}").unwrap();
        writeln!(noff, "3\t{a} {b}  {c}").unwrap();
        writeln!(coff, "3 {a} {b} {c} 1 0 0").unwrap();
        write!(cnoff, "3 {a} {b} {c}\r\n").unwrap();
        writeln!(bare, "3 {a} {b} {c}").unwrap();
    }
    noff.push_str("# trailing comment\n");
    vec![
        ("OFF", plain.into_bytes()),
        ("NOFF+comments", noff.into_bytes()),
        ("COFF", coff.into_bytes()),
        ("CNOFF+CRLF", cnoff.into_bytes()),
        ("no keyword", bare.into_bytes()),
    ]
}

/// OBJ variants: plain; `v/vt/vn` corners in two objects whose vertices are interleaved with
/// faces (faces referring to vertices defined later); and negative (relative) indices, each face
/// written after its vertices.
pub(crate) fn obj_variants(m: &Mesh) -> Vec<(&'static str, Vec<u8>)> {
    let n = m.positions.len();
    let v = |i: usize| {
        let p = m.positions[i];
        format!("v {} {} {}\n", p.x, p.y, p.z)
    };
    let mut plain = String::from("# plain\n");
    (0..n).for_each(|i| plain.push_str(&v(i)));
    for [a, b, c] in &m.faces {
        writeln!(plain, "f {} {} {}", a + 1, b + 1, c + 1).unwrap();
    }

    let half = n / 2;
    let (f1, f2) = m.faces.split_at(m.faces.len() / 2);
    let mut objects = String::from("mtllib none.mtl\no first\n");
    (0..half).for_each(|i| objects.push_str(&v(i)));
    objects.push_str("vt 0.5 0.5\nvn 0 0 1\ng part\nusemtl x\ns off\n");
    for [a, b, c] in f1 {
        writeln!(objects, "f {}/1/1 {}/1/1 {}/1/1", a + 1, b + 1, c + 1).unwrap();
    }
    objects.push_str("o second\n");
    for [a, b, c] in f2 {
        writeln!(objects, "f {}//1 {}//1 {}//1", a + 1, b + 1, c + 1).unwrap();
    }
    (half..n).for_each(|i| objects.push_str(&v(i)));

    // Relative indices: each face right after the vertex that completes it.
    let mut relative = String::new();
    let mut by_last: HashMap<VertexId, Vec<[VertexId; 3]>> = HashMap::new();
    for f in &m.faces {
        by_last
            .entry(*f.iter().max().unwrap())
            .or_default()
            .push(*f);
    }
    for i in 0..n {
        relative.push_str(&v(i));
        for f in by_last.get(&(i as VertexId)).into_iter().flatten() {
            let r = f.map(|x| x as i64 - (i as i64 + 1));
            writeln!(relative, "f {}/1 {}/1 {}/1", r[0], r[1], r[2]).unwrap();
        }
    }
    vec![
        ("plain", plain.into_bytes()),
        ("objects", objects.into_bytes()),
        ("relative", relative.into_bytes()),
    ]
}

/// Face order after [`obj_variants`]' "objects" and "relative" layouts: compare faces as sorted
/// multisets when the layout changes the order.
pub(crate) fn sorted_faces(faces: &[[VertexId; 3]]) -> Vec<[VertexId; 3]> {
    let mut v: Vec<_> = faces
        .iter()
        .map(|f| {
            // Rotate so the smallest id comes first (keeps the winding).
            let k = (0..3).min_by_key(|&k| f[k]).unwrap();
            [f[k], f[(k + 1) % 3], f[(k + 2) % 3]]
        })
        .collect();
    v.sort_unstable();
    v
}

/// PLY encodings.
#[derive(Clone, Copy, Debug)]
pub(crate) enum PlyEncoding {
    Ascii,
    Little,
    Big,
}

/// How the PLY stores its triangles.
#[derive(Clone, Copy, Debug)]
pub(crate) enum PlyFaces {
    /// `element face` with a `list uchar int vertex_indices`.
    Faces,
    /// `element face` with a `list ushort uint vertex_index` and an extra flag property.
    FacesIndex,
    /// `element tristrips` with one `-1`-separated list.
    Strips,
}

/// A PLY file: vertices as `double` (exact) or `float`, with extra normal and colour properties
/// and an `edge` element to skip.
pub(crate) fn ply(m: &Mesh, enc: PlyEncoding, faces: PlyFaces, double: bool) -> Vec<u8> {
    let format = match enc {
        PlyEncoding::Ascii => "ascii",
        PlyEncoding::Little => "binary_little_endian",
        PlyEncoding::Big => "binary_big_endian",
    };
    let ft = if double { "double" } else { "float" };
    let mut h = format!(
        "ply\nformat {format} 1.0\ncomment test\nobj_info none\nelement vertex {}\n\
         property {ft} x\nproperty float nx\nproperty {ft} y\nproperty {ft} z\n\
         property uchar red\nproperty list uchar int junk\n",
        m.positions.len()
    );
    let lists: Vec<Vec<i64>> = match faces {
        PlyFaces::Faces => {
            h.push_str(&format!(
                "element face {}\nproperty list uchar int vertex_indices\n",
                m.faces.len()
            ));
            m.faces
                .iter()
                .map(|f| f.iter().map(|&v| i64::from(v)).collect())
                .collect()
        }
        PlyFaces::FacesIndex => {
            h.push_str(&format!(
                "element face {}\nproperty uchar flags\nproperty list ushort uint vertex_index\n",
                m.faces.len()
            ));
            m.faces
                .iter()
                .map(|f| f.iter().map(|&v| i64::from(v)).collect())
                .collect()
        }
        PlyFaces::Strips => {
            h.push_str("element tristrips 1\nproperty list int int vertex_indices\n");
            vec![strips(m)]
        }
    };
    h.push_str("element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n");
    let mut out = h.into_bytes();
    let put = |out: &mut Vec<u8>, x: f64, size: u8| match (enc, size) {
        (PlyEncoding::Ascii, _) => write_ascii(out, x),
        (PlyEncoding::Little, 8) => out.extend_from_slice(&x.to_le_bytes()),
        (PlyEncoding::Big, 8) => out.extend_from_slice(&x.to_be_bytes()),
        (PlyEncoding::Little, 4) => out.extend_from_slice(&(x as f32).to_le_bytes()),
        (PlyEncoding::Big, 4) => out.extend_from_slice(&(x as f32).to_be_bytes()),
        (PlyEncoding::Little, 1) | (PlyEncoding::Big, 1) => out.push(x as u8),
        _ => unreachable!(),
    };
    let int = |out: &mut Vec<u8>, x: i64, size: u8, enc: PlyEncoding| match (enc, size) {
        (PlyEncoding::Ascii, _) => out.extend_from_slice(format!("{x} ").as_bytes()),
        (PlyEncoding::Little, 1) | (PlyEncoding::Big, 1) => out.push(x as u8),
        (PlyEncoding::Little, 2) => out.extend_from_slice(&(x as u16).to_le_bytes()),
        (PlyEncoding::Big, 2) => out.extend_from_slice(&(x as u16).to_be_bytes()),
        (PlyEncoding::Little, _) => out.extend_from_slice(&(x as i32).to_le_bytes()),
        (PlyEncoding::Big, _) => out.extend_from_slice(&(x as i32).to_be_bytes()),
    };
    let cs = if double { 8 } else { 4 };
    let nl = |out: &mut Vec<u8>| {
        if let PlyEncoding::Ascii = enc {
            out.push(b'\n');
        }
    };
    for p in &m.positions {
        put(&mut out, p.x, cs);
        put(&mut out, 0.25, 4);
        put(&mut out, p.y, cs);
        put(&mut out, p.z, cs);
        put(&mut out, 200.0, 1);
        int(&mut out, 2, 1, enc);
        int(&mut out, 7, 4, enc);
        int(&mut out, -7, 4, enc);
        nl(&mut out);
    }
    for l in &lists {
        match faces {
            PlyFaces::Faces => int(&mut out, l.len() as i64, 1, enc),
            PlyFaces::FacesIndex => {
                int(&mut out, 1, 1, enc);
                int(&mut out, l.len() as i64, 2, enc);
            }
            PlyFaces::Strips => int(&mut out, l.len() as i64, 4, enc),
        }
        for &v in l {
            int(&mut out, v, 4, enc);
        }
        nl(&mut out);
    }
    int(&mut out, 0, 4, enc);
    int(&mut out, 1, 4, enc);
    nl(&mut out);
    out
}

fn write_ascii(out: &mut Vec<u8>, x: f64) {
    out.extend_from_slice(format!("{x} ").as_bytes());
}

/// Encodes the faces as triangle strips separated by `-1`, greedily extending each strip across
/// shared edges: at strip position k with the last two ids (p, q), the next face must be
/// (p, q, d) for even k and (q, p, d) for odd k.
pub(crate) fn strips(m: &Mesh) -> Vec<i64> {
    let mut by_edge: HashMap<(VertexId, VertexId), Vec<usize>> = HashMap::new();
    for (i, f) in m.faces.iter().enumerate() {
        for k in 0..3 {
            by_edge.entry((f[k], f[(k + 1) % 3])).or_default().push(i);
        }
    }
    let mut used = vec![false; m.faces.len()];
    let mut out = Vec::new();
    for start in 0..m.faces.len() {
        if used[start] {
            continue;
        }
        used[start] = true;
        let f = m.faces[start];
        let mut strip = vec![f[0], f[1], f[2]];
        let mut k = 1;
        loop {
            let n = strip.len();
            let (p, q) = (strip[n - 2], strip[n - 1]);
            let edge = if k % 2 == 0 { (p, q) } else { (q, p) };
            let next = by_edge
                .get(&edge)
                .and_then(|fs| fs.iter().copied().find(|&i| !used[i]));
            let Some(i) = next else { break };
            used[i] = true;
            let g = m.faces[i];
            let s = (0..3).find(|&s| (g[s], g[(s + 1) % 3]) == edge).unwrap();
            strip.push(g[(s + 2) % 3]);
            k += 1;
        }
        if !out.is_empty() {
            out.push(-1);
        }
        out.extend(strip.iter().map(|&v| i64::from(v)));
    }
    out
}

/// Ascii STL with `f64` coordinates written in full.
pub(crate) fn stl_ascii(m: &Mesh) -> Vec<u8> {
    let mut s = String::from("solid test\n");
    for f in &m.faces {
        s.push_str("  facet normal 0 0 0\n    outer loop\n");
        for &v in f {
            let p = m.positions[v as usize];
            writeln!(s, "      vertex {} {} {}", p.x, p.y, p.z).unwrap();
        }
        s.push_str("    endloop\n  endfacet\n");
    }
    s.push_str("endsolid test\n");
    s.into_bytes()
}

/// Binary STL written by the `stl_io` crate, with a header that starts with "solid " as many
/// exporters write.
pub(crate) fn stl_binary(m: &Mesh) -> Vec<u8> {
    let tris = m.faces.iter().map(|f| stl_io::Triangle {
        normal: stl_io::Normal::new([0.0, 0.0, 0.0]),
        vertices: f.map(|v| {
            let p = m.positions[v as usize];
            stl_io::Vertex::new([p.x as f32, p.y as f32, p.z as f32])
        }),
    });
    let mut out = Vec::new();
    stl_io::write_stl(&mut out, tris).unwrap();
    out[..6].copy_from_slice(b"solid ");
    out
}

/// Where a test glTF keeps its one buffer.
pub(crate) enum GltfBuffer<'a> {
    /// In the GLB's BIN chunk (wrap the JSON with [`glb`]).
    Bin,
    /// In a `data:` URI, base64.
    DataUri,
    /// In a file of this name beside the glTF.
    File(&'a str),
}

/// A glTF document (JSON) and its buffer: one mesh of one primitive (`mode`: 4 triangles, 5
/// strip, 6 fan, 1 lines) with float positions and, when given, `u32` indices; `nodes` is the
/// JSON array of nodes (each `"mesh": 0` node draws it), `scene_nodes` the default scene's
/// root list, `required` the `extensionsRequired` array.
pub(crate) fn gltf_doc(
    positions: &[[f32; 3]],
    indices: Option<&[u32]>,
    mode: u32,
    nodes: &str,
    scene_nodes: &str,
    buffer: GltfBuffer,
    required: &str,
) -> (String, Vec<u8>) {
    let mut bin = Vec::new();
    for p in positions {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    let pos_len = bin.len();
    for &i in indices.unwrap_or(&[]) {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for p in positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let uri = match buffer {
        GltfBuffer::Bin => String::new(),
        GltfBuffer::DataUri => {
            use base64::Engine as _;
            format!(
                r#","uri":"data:application/octet-stream;base64,{}""#,
                base64::engine::general_purpose::STANDARD.encode(&bin)
            )
        }
        GltfBuffer::File(name) => format!(r#","uri":"{name}""#),
    };
    let (index_view, index_accessor, index_ref) = match indices {
        Some(ix) => (
            format!(
                r#",{{"buffer":0,"byteOffset":{pos_len},"byteLength":{}}}"#,
                4 * ix.len()
            ),
            format!(
                r#",{{"bufferView":1,"componentType":5125,"count":{},"type":"SCALAR"}}"#,
                ix.len()
            ),
            r#","indices":1"#.to_string(),
        ),
        None => (String::new(), String::new(), String::new()),
    };
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsRequired":{required},"extensionsUsed":{required},"scene":0,"scenes":[{{"nodes":{scene_nodes}}}],"nodes":{nodes},"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}{index_ref},"mode":{mode}}}]}}],"buffers":[{{"byteLength":{}{uri}}}],"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{pos_len}}}{index_view}],"accessors":[{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}}{index_accessor}]}}"#,
        bin.len(),
        positions.len(),
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2],
    );
    (json, bin)
}

/// `json` and `bin` as one GLB file (the container of `write_glb`, which the reader's tests
/// do not otherwise depend on).
pub(crate) fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    super::write::glb_container(json.as_bytes(), bin)
}

/// A GLB of `m` (triangles, indexed, one node at the origin): positions rounded to `f32`.
pub(crate) fn glb_of(m: &Mesh) -> Vec<u8> {
    let positions: Vec<[f32; 3]> = m
        .positions
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let indices: Vec<u32> = m.faces.iter().flatten().copied().collect();
    let (json, bin) = gltf_doc(
        &positions,
        Some(&indices),
        4,
        r#"[{"mesh":0}]"#,
        "[0]",
        GltfBuffer::Bin,
        "[]",
    );
    glb(&json, &bin)
}

/// PCD data encodings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PcdData {
    Ascii,
    Binary,
    Compressed,
}

/// A PCD v0.7 file as PCL writes it, `height` rows of `width` points (NaN coordinates for
/// invalid points), with fields of every kind around the ones the reader uses: `x` F4, `y` F8,
/// `z` F4, `rgb` U4, `fpfh` F4 x 3, `intensity` U1, the normals as F4 when given, `ring` I2.
pub(crate) fn pcd(
    points: &[[f64; 3]],
    normals: Option<&[[f64; 3]]>,
    width: usize,
    height: usize,
    data: PcdData,
) -> Vec<u8> {
    assert_eq!(points.len(), width * height);
    // (name, TYPE, SIZE, COUNT, value of point i and component k)
    type Value<'a> = Box<dyn Fn(usize, usize) -> f64 + 'a>;
    type Field<'a> = (&'a str, char, usize, usize, Value<'a>);
    let mut fields: Vec<Field> = vec![
        ("x", 'F', 4, 1, Box::new(|i, _| points[i][0])),
        ("y", 'F', 8, 1, Box::new(|i, _| points[i][1])),
        ("z", 'F', 4, 1, Box::new(|i, _| points[i][2])),
        ("rgb", 'U', 4, 1, Box::new(|i, _| (i * 65793) as f64)),
        ("fpfh", 'F', 4, 3, Box::new(|i, k| (i + k) as f64 * 0.5)),
        ("intensity", 'U', 1, 1, Box::new(|i, _| (i % 256) as f64)),
    ];
    if let Some(n) = normals {
        fields.push(("normal_x", 'F', 4, 1, Box::new(move |i, _| n[i][0])));
        fields.push(("normal_y", 'F', 4, 1, Box::new(move |i, _| n[i][1])));
        fields.push(("normal_z", 'F', 4, 1, Box::new(move |i, _| n[i][2])));
    }
    fields.push(("ring", 'I', 2, 1, Box::new(|i, _| -(i as f64))));
    let column = |f: &dyn Fn(&Field) -> String| fields.iter().map(f).collect::<Vec<_>>().join(" ");
    let encoding = match data {
        PcdData::Ascii => "ascii",
        PcdData::Binary => "binary",
        PcdData::Compressed => "binary_compressed",
    };
    let mut out = format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {}\nSIZE {}\nTYPE {}\n\
         COUNT {}\nWIDTH {width}\nHEIGHT {height}\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA {encoding}\n",
        column(&|f| f.0.to_string()),
        column(&|f| f.2.to_string()),
        column(&|f| f.1.to_string()),
        column(&|f| f.3.to_string()),
        points.len()
    )
    .into_bytes();
    let encode = |t: char, size: usize, v: f64| -> Vec<u8> {
        match (t, size) {
            ('F', 4) => (v as f32).to_le_bytes().to_vec(),
            ('F', _) => v.to_le_bytes().to_vec(),
            ('U', 1) => vec![v as u8],
            ('U', _) => (v as u32).to_le_bytes().to_vec(),
            _ => (v as i16).to_le_bytes().to_vec(),
        }
    };
    match data {
        PcdData::Ascii => {
            for i in 0..points.len() {
                let mut values = Vec::new();
                for (_, _, _, count, value) in &fields {
                    for k in 0..*count {
                        let v = value(i, k);
                        values.push(if v.is_nan() {
                            "nan".into()
                        } else {
                            v.to_string()
                        });
                    }
                }
                out.extend(values.join(" ").bytes());
                out.push(b'\n');
            }
        }
        PcdData::Binary => {
            for i in 0..points.len() {
                for (_, t, size, count, value) in &fields {
                    for k in 0..*count {
                        out.extend(encode(*t, *size, value(i, k)));
                    }
                }
            }
        }
        PcdData::Compressed => {
            let mut raw = Vec::new();
            for (_, t, size, count, value) in &fields {
                for i in 0..points.len() {
                    for k in 0..*count {
                        raw.extend(encode(*t, *size, value(i, k)));
                    }
                }
            }
            let packed = super::lzf::compress(&raw);
            out.extend((packed.len() as u32).to_le_bytes());
            out.extend((raw.len() as u32).to_le_bytes());
            out.extend(packed);
        }
    }
    out
}

/// An XYZ file of the points (with normals as columns 4-6 when given), separated as `sep`.
pub(crate) fn xyz(points: &[[f64; 3]], normals: Option<&[[f64; 3]]>, sep: &str) -> Vec<u8> {
    let mut out = String::from("# written by a test\n");
    for (i, p) in points.iter().enumerate() {
        let mut values: Vec<f64> = p.to_vec();
        if let Some(n) = normals {
            values.extend(n[i]);
        }
        let v: Vec<String> = values.iter().map(f64::to_string).collect();
        writeln!(out, "{}", v.join(sep)).unwrap();
    }
    out.into_bytes()
}
