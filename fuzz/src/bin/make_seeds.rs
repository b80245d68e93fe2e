//! Writes the starting corpus of every fuzz target into `fuzz/seeds/TARGET/` (small meshes, range
//! grids and point clouds in each format, an index's segment and manifest payloads, a map file),
//! all made here in code.
//! Run with `cargo run --bin make_seeds` from `fuzz/`.

use std::fs;
use std::path::Path;

const D: usize = keycomp_describe::DIM;

fn put(target: &str, name: &str, bytes: &[u8]) {
    let dir = Path::new("seeds").join(target);
    fs::create_dir_all(&dir).expect("create the seed folder");
    fs::write(dir.join(name), bytes).expect("write a seed");
}

/// A tetrahedron's corners and faces.
const V: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
];
const F: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

/// A unit square in two triangles: an open sheet with a border.
const SHEET: &[u8] = b"OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";

/// Two unit squares crossing at right angles: a soup, whose pieces cross.
const CROSSING: &[u8] = b"OFF\n8 4 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n\
0.5 -0.5 -0.5\n0.5 1.5 -0.5\n0.5 1.5 0.5\n0.5 -0.5 0.5\n3 0 1 2\n3 0 2 3\n3 4 5 6\n3 4 6 7\n";

/// Literal-only LZF (runs of at most 32 bytes): valid input for PCD's binary_compressed.
fn lzf_literals(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    for run in data.chunks(32) {
        out.push((run.len() - 1) as u8);
        out.extend_from_slice(run);
    }
    out
}

/// Range grids and point clouds: PLY range grid and vertex-only PLY, XYZ, PTS, PCD in its three
/// encodings, organised and not.
fn scans_and_clouds() {
    // A 3 x 3 range grid, the centre cell absent, with a header line that is not a keyword.
    let mut grid = String::from(
        "ply\nformat ascii 1.0\nobj_info is_interlaced 1\nobj_info num_cols 3\n\
         obj_info num_rows 3\nbye\nelement vertex 8\nproperty float x\nproperty float y\n\
         property float z\nelement range_grid 9\nproperty list uchar int vertex_indices\n\
         end_header\n",
    );
    let mut cells = String::new();
    let mut v = 0;
    for r in 0..3 {
        for c in 0..3 {
            if (r, c) == (1, 1) {
                cells += "0\n";
            } else {
                grid += &format!("{} {} {}\n", c, r, (r * c) as f32 * 0.1);
                cells += &format!("1 {v}\n");
                v += 1;
            }
        }
    }
    grid += &cells;
    put("mesh_ply", "grid.ply", grid.as_bytes());
    let mut points = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n\
property float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
end_header\n"
        .to_vec();
    for p in V {
        for c in p.iter().chain(&[0.0, 0.0, 1.0]) {
            points.extend_from_slice(&c.to_le_bytes());
        }
    }
    put("mesh_ply", "points-binary.ply", &points);

    put(
        "mesh_xyz",
        "normals.xyz",
        b"# x y z nx ny nz\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n0 0 1 1 0 0\n",
    );
    put(
        "mesh_xyz",
        "names-commas.xyz",
        b"X,Y,Z\n0.5, 0, 0\n// a comment\n1,0,0.25\n\n0,1e-3,0\n",
    );
    put(
        "mesh_pts",
        "scan.pts",
        b"3\n0 0 0 -1200 10 20 30\n1 0 0 -1100 10 20 30\n0 1 0 -900 10 20 30\n2\n5 5 5 0 0 0 0\n6 5 5 0 0 0 0\n",
    );

    // PCD: 2 rows of 3 points, the middle of row 1 invalid (NaN); x y z as floats, rgb, an
    // intensity byte.
    let pts: [[f32; 3]; 6] = [
        [0.0, 0.0, 1.0],
        [0.5, 0.0, 1.0],
        [1.0, 0.0, 1.1],
        [0.0, 0.5, 1.0],
        [f32::NAN, f32::NAN, f32::NAN],
        [1.0, 0.5, 1.2],
    ];
    let head = |data: &str, width: usize, height: usize| {
        format!(
            "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb intensity\n\
             SIZE 4 4 4 4 1\nTYPE F F F U U\nCOUNT 1 1 1 1 1\nWIDTH {width}\nHEIGHT {height}\n\
             VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA {data}\n",
            width * height
        )
        .into_bytes()
    };
    let mut ascii = head("ascii", 3, 2);
    let mut binary = head("binary", 6, 1);
    let mut fields: [Vec<u8>; 5] = Default::default();
    for (i, p) in pts.iter().enumerate() {
        let xyz: Vec<String> = p
            .iter()
            .map(|c| {
                if c.is_nan() {
                    "nan".into()
                } else {
                    c.to_string()
                }
            })
            .collect();
        ascii.extend(format!("{} {} {}\n", xyz.join(" "), 4_286_611_584u32, i).bytes());
        for (k, c) in p.iter().enumerate() {
            binary.extend_from_slice(&c.to_le_bytes());
            fields[k].extend_from_slice(&c.to_le_bytes());
        }
        binary.extend_from_slice(&4_286_611_584u32.to_le_bytes());
        binary.push(i as u8);
        fields[3].extend_from_slice(&4_286_611_584u32.to_le_bytes());
        fields[4].push(i as u8);
    }
    put("mesh_pcd", "organised-ascii.pcd", &ascii);
    put("mesh_pcd", "unorganised-binary.pcd", &binary);
    let raw = fields.concat();
    let packed = lzf_literals(&raw);
    let mut compressed = head("binary_compressed", 3, 2);
    compressed.extend_from_slice(&(packed.len() as u32).to_le_bytes());
    compressed.extend_from_slice(&(raw.len() as u32).to_le_bytes());
    compressed.extend_from_slice(&packed);
    put("mesh_pcd", "organised-compressed.pcd", &compressed);
}

fn main() {
    let mut off = String::from("OFF\n4 4 0\n");
    let mut obj = String::from("# tetrahedron\n");
    let mut ply = String::from(
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n",
    );
    for v in V {
        off += &format!("{} {} {}\n", v[0], v[1], v[2]);
        obj += &format!("v {} {} {}\n", v[0], v[1], v[2]);
        ply += &format!("{} {} {}\n", v[0], v[1], v[2]);
    }
    for f in F {
        off += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
        obj += &format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
        ply += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
    }
    put("mesh_off", "tetra.off", off.as_bytes());
    put(
        "mesh_off",
        "quad.off",
        b"OFF\n# a square as one polygon\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n",
    );
    // the canonical surface: a closed mesh (remeshed), an open sheet, two crossing squares (a
    // soup, reconstructed)
    put("surface_off", "tetra.off", off.as_bytes());
    put("surface_off", "sheet.off", SHEET);
    put("surface_off", "crossing.off", CROSSING);
    put("mesh_obj", "tetra.obj", obj.as_bytes());
    put(
        "mesh_obj",
        "quad.obj",
        b"o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n",
    );
    put("mesh_ply", "tetra.ply", ply.as_bytes());
    let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n\
property float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\n\
end_header\n"
        .to_vec();
    for v in V {
        for c in v {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for f in F {
        bin.push(3);
        for c in f {
            bin.extend_from_slice(&(c as i32).to_le_bytes());
        }
    }
    put("mesh_ply", "tetra-binary.ply", &bin);
    let mut stl = String::from("solid t\n");
    let mut stl_bin = vec![0u8; 80];
    stl_bin.extend_from_slice(&(F.len() as u32).to_le_bytes());
    for f in F {
        stl += " facet normal 0 0 0\n  outer loop\n";
        stl_bin.extend_from_slice(&[0u8; 12]);
        for c in f {
            let v = V[c as usize];
            stl += &format!("   vertex {} {} {}\n", v[0], v[1], v[2]);
            for x in v {
                stl_bin.extend_from_slice(&x.to_le_bytes());
            }
        }
        stl += "  endloop\n endfacet\n";
        stl_bin.extend_from_slice(&[0u8; 2]);
    }
    stl += "endsolid t\n";
    put("mesh_stl", "tetra.stl", stl.as_bytes());
    let tetra = keycomp_mesh::Mesh {
        positions: V
            .iter()
            .map(|v| keycomp_mesh::Point3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2])))
            .collect(),
        faces: F.to_vec(),
    };
    let glb_path = std::env::temp_dir().join(format!("keycomp-seed-{}.glb", std::process::id()));
    keycomp_mesh::write_glb(&tetra, &glb_path).expect("write a GLB");
    put(
        "mesh_gltf",
        "tetra.glb",
        &fs::read(&glb_path).expect("read the GLB"),
    );
    let _ = fs::remove_file(&glb_path);
    // A glTF with its buffer (one triangle strip, not indexed) in a data URI, and two nodes.
    put(
        "mesh_gltf",
        "strip.gltf",
        br#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"children":[1],"translation":[1,0,0]},{"mesh":0,"scale":[-1,1,1]}],"meshes":[{"primitives":[{"attributes":{"POSITION":0},"mode":5}]}],"buffers":[{"byteLength":48,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAACAPwAAgD8AAAAA"}],"bufferViews":[{"buffer":0,"byteLength":48}],"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}]}"#,
    );
    put("mesh_stl", "tetra-binary.stl", &stl_bin);
    scans_and_clouds();

    // An index of three synthetic shapes, one removed: its segment and manifest payloads.
    let tmp = std::env::temp_dir().join(format!("keycomp-fuzz-seeds-{}", std::process::id()));
    let _ = fs::remove_dir_all(&tmp);
    {
        let mut w = keycomp_index::IndexWriter::<D>::create_or_open(&tmp).expect("index");
        w.ensure_profile("fuzz seeds").expect("profile");
        let mut recs = keycomp_index::synthetic::records::<D>(3, 0..3);
        for r in &mut recs {
            r.components.truncate(2);
            r.layout = vec![0.0, 0.5, 0.5, 0.0];
        }
        w.add_batch(recs).expect("add");
        w.remove(&[keycomp_index::synthetic::record::<D>(3, 1).canonical_path])
            .expect("remove");
    }
    let footer = keycomp_index::FOOTER_LEN;
    for e in fs::read_dir(&tmp).expect("list the index") {
        let p = e.expect("entry").path();
        let name = p
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default()
            .to_string();
        let bytes = fs::read(&p).expect("read");
        if bytes.len() < footer {
            continue;
        }
        let payload = &bytes[..bytes.len() - footer];
        if name == keycomp_index::MANIFEST_NAME {
            let mut seed = vec![1u8]; // odd first byte: the current format version
            seed.extend_from_slice(payload);
            put("index_manifest", "manifest", &seed);
        } else if name.ends_with(".kcs") {
            put("index_segment", &name, payload);
        }
    }
    let _ = fs::remove_dir_all(&tmp);
    put(
        "index_search_cache",
        "cache",
        &keycomp_index::fuzzing::search_cache_seed(),
    );
    put(
        "map_file",
        "small.map",
        b"# keycomp-map v1 transformed=4 null=3\n2\n-1\n0\n1\n",
    );
}
