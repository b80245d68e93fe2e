//! Round trips through every format and variant, malformed files through `read_mesh` (kind,
//! location and file name in the message), the writers' atomicity, and fuzzing.

use std::path::{Path, PathBuf};

use proptest::prelude::*;

use super::fixtures::{self, PlyEncoding, PlyFaces};
use super::*;
use crate::synth::{grid, icosphere, protrusion_sphere, torus};
use crate::{ErrorKind, Location};

fn meshes() -> Vec<(&'static str, Mesh)> {
    vec![
        ("icosphere", icosphere(2, 1.0)),
        ("torus", torus(1.0, 0.3, 16, 12)),
        ("grid", grid(5, 4, 0.37)),
        ("protrusions", protrusion_sphere(2, 0.5, 0.3)),
    ]
}

fn read(bytes: &[u8], format: Format) -> LoadedMesh {
    read_mesh_from_bytes(bytes, format).unwrap_or_else(|e| panic!("{e}"))
}

fn as_f32(m: &Mesh) -> Vec<Point3<f64>> {
    m.positions
        .iter()
        .map(|p| p.map(|c| f64::from(c as f32)))
        .collect()
}

#[test]
fn off_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    for (name, m) in meshes() {
        let path = dir.path().join(format!("{name}.off"));
        write_off(&m, &path).unwrap();
        let back = read_mesh(&path).unwrap();
        assert_eq!(back.mesh, m, "{name}");
        assert_eq!(back.format, Format::Off);
        assert_eq!(back.repairs, Repairs::default(), "{name}");
        for (variant, bytes) in fixtures::off_variants(&m) {
            let back = read(&bytes, Format::Off);
            assert_eq!(back.mesh, m, "{name} {variant}");
        }
    }
}

#[test]
fn a_utf8_byte_order_mark_before_a_text_header_is_skipped() {
    let m = icosphere(1, 1.0);
    let texts = [
        ("off", Format::Off, fixtures::off_variants(&m)[0].1.clone()),
        ("obj", Format::Obj, fixtures::obj_variants(&m)[0].1.clone()),
        (
            "ply",
            Format::Ply,
            fixtures::ply(&m, PlyEncoding::Ascii, PlyFaces::Faces, false),
        ),
    ];
    for (ext, format, plain) in texts {
        let mut bom = b"\xEF\xBB\xBF".to_vec();
        bom.extend_from_slice(&plain);
        let a = read(&plain, format);
        let b = read(&bom, format);
        assert_eq!(a.mesh, b.mesh, "{ext}");
    }
}

#[test]
fn obj_round_trips() {
    for (name, m) in meshes() {
        for (variant, bytes) in fixtures::obj_variants(&m) {
            let back = read(&bytes, Format::Obj).mesh;
            assert_eq!(back.positions, m.positions, "{name} {variant}");
            if variant == "relative" {
                assert_eq!(
                    fixtures::sorted_faces(&back.faces),
                    fixtures::sorted_faces(&m.faces),
                    "{name} {variant}"
                );
            } else {
                assert_eq!(back.faces, m.faces, "{name} {variant}");
            }
        }
    }
}

#[test]
fn ply_round_trips() {
    let encodings = [PlyEncoding::Ascii, PlyEncoding::Little, PlyEncoding::Big];
    let layouts = [PlyFaces::Faces, PlyFaces::FacesIndex, PlyFaces::Strips];
    for (name, m) in meshes() {
        for enc in encodings {
            for faces in layouts {
                for double in [true, false] {
                    let what = format!("{name} {enc:?} {faces:?} double={double}");
                    let back = read(&fixtures::ply(&m, enc, faces, double), Format::Ply);
                    if double {
                        assert_eq!(back.mesh.positions, m.positions, "{what}");
                    } else {
                        assert_eq!(back.mesh.positions, as_f32(&m), "{what}");
                    }
                    if let PlyFaces::Strips = faces {
                        assert_eq!(
                            fixtures::sorted_faces(&back.mesh.faces),
                            fixtures::sorted_faces(&m.faces),
                            "{what}"
                        );
                    } else {
                        assert_eq!(back.mesh.faces, m.faces, "{what}");
                    }
                    assert_eq!(back.repairs, Repairs::default(), "{what}");
                }
            }
        }
    }
}

#[test]
fn strips_are_actually_long() {
    // The fixture must exercise both windings: many strips longer than one triangle.
    let m = icosphere(3, 1.0);
    let s = fixtures::strips(&m);
    let lengths: Vec<usize> = s.split(|&v| v == -1).map(<[i64]>::len).collect();
    assert!(
        lengths.len() * 2 < m.faces.len(),
        "{} strips",
        lengths.len()
    );
    assert!(lengths.iter().any(|&l| l >= 8));
}

#[test]
fn colored_ply_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    for (name, m) in meshes() {
        let colors: Vec<[u8; 3]> = (0..m.positions.len())
            .map(|i| [i as u8, (i * 7) as u8, 255])
            .collect();
        let path = dir.path().join(format!("{name}.PLY"));
        write_ply_colored(&m, &colors, &path).unwrap();
        let back = read_mesh(&path).unwrap();
        assert_eq!(back.mesh, m, "{name}");
        assert_eq!(back.format, Format::Ply);
        // The colours are where the header says: check one through ply-rs-bw's generic reader.
        let mut f = std::fs::File::open(&path).unwrap();
        let ply = ply_rs_bw::parser::Parser::<ply_rs_bw::ply::DefaultElement>::new()
            .read_ply(&mut f)
            .unwrap();
        let v = &ply.payload["vertex"][5];
        assert_eq!(v["green"], ply_rs_bw::ply::Property::UChar(35));
    }
}

#[test]
fn stl_round_trips_and_matches_stl_io() {
    for (name, m) in meshes() {
        let back = read(&fixtures::stl_ascii(&m), Format::Stl).mesh;
        assert_eq!(back.num_faces(), m.num_faces(), "{name}");
        assert_eq!(back.num_vertices(), m.num_vertices(), "{name}");
        for f in 0..m.num_faces() {
            assert_eq!(back.triangle(f), m.triangle(f), "{name} face {f}");
        }

        let bytes = fixtures::stl_binary(&m);
        let back = read(&bytes, Format::Stl).mesh;
        let oracle = stl_io::read_stl(&mut std::io::Cursor::new({
            let mut b = bytes.clone();
            b[..6].copy_from_slice(b"binary"); // stl_io reads "solid " files as ascii
            b
        }))
        .unwrap();
        let want: Vec<Point3<f64>> = oracle
            .vertices
            .iter()
            .map(|v| Point3::new(v[0].into(), v[1].into(), v[2].into()))
            .collect();
        assert_eq!(back.positions, want, "{name}");
        let want: Vec<[VertexId; 3]> = oracle
            .faces
            .iter()
            .map(|f| f.vertices.map(|v| v as VertexId))
            .collect();
        assert_eq!(back.faces, want, "{name}");
        let f32s = as_f32(&m);
        for (f, face) in m.faces.iter().enumerate() {
            assert_eq!(
                back.triangle(f),
                face.map(|v| f32s[v as usize]),
                "{name} face {f}"
            );
        }
    }
}

#[test]
fn format_from_path() {
    assert_eq!(
        Format::from_path(Path::new("a/b.OFF")).unwrap(),
        Format::Off
    );
    assert_eq!(Format::from_path(Path::new("b.Obj")).unwrap(), Format::Obj);
    assert_eq!(Format::from_path(Path::new("b.ply")).unwrap(), Format::Ply);
    assert_eq!(Format::from_path(Path::new("b.stl")).unwrap(), Format::Stl);
    let e = Format::from_path(Path::new("dir/mesh.xyz")).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::UnknownFormat { ref extension } if extension == "xyz"));
    assert!(e.to_string().contains("mesh.xyz") && e.to_string().contains(".xyz"));
    let e = read_mesh(Path::new("dir/mesh")).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::UnknownFormat { ref extension } if extension.is_empty()));
    assert!(e.to_string().contains("dir/mesh: no file extension"), "{e}");
    for f in [Format::Off, Format::Obj, Format::Ply, Format::Stl] {
        assert_eq!(Format::from_extension(f.extension()), Some(f));
    }
}

/// A malformed file, what error it must give and where.
struct Bad {
    file: &'static str,
    bytes: Vec<u8>,
    kind: fn(&ErrorKind) -> bool,
    location: Option<Location>,
}

fn bad(
    file: &'static str,
    bytes: impl Into<Vec<u8>>,
    kind: fn(&ErrorKind) -> bool,
    location: Option<Location>,
) -> Bad {
    Bad {
        file,
        bytes: bytes.into(),
        kind,
        location,
    }
}

fn element(name: &str, index: u64) -> Option<Location> {
    Some(Location::Element {
        name: name.into(),
        index,
    })
}

#[test]
fn malformed_files_give_clear_errors() {
    let m = icosphere(1, 1.0);
    let ply_le = fixtures::ply(&m, PlyEncoding::Little, PlyFaces::Faces, false);
    let header_len = ply_le
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    // Vertex record: x nx y z (4 floats) + red + list (uchar count 2, two ints) = 26 bytes.
    let face0 = header_len + 26 * m.positions.len();
    let mut ply_bad_index = ply_le.clone();
    // Face 3's second index (count byte, then ints).
    ply_bad_index[face0 + 13 * 3 + 5..face0 + 13 * 3 + 9].copy_from_slice(&500i32.to_le_bytes());
    let mut ply_negative = ply_le.clone();
    ply_negative[face0 + 13 * 2 + 1..face0 + 13 * 2 + 5].copy_from_slice(&(-2i32).to_le_bytes());
    let mut ply_nan = ply_le.clone();
    ply_nan[header_len + 26 * 7 + 8..header_len + 26 * 7 + 12]
        .copy_from_slice(&f32::NAN.to_le_bytes());
    let ply_cut = ply_le[..face0 + 13 * 10 + 6].to_vec();
    let stl = fixtures::stl_binary(&m);
    let mut stl_inf = stl.clone();
    stl_inf[84 + 50 * 4 + 12 + 4..84 + 50 * 4 + 12 + 8]
        .copy_from_slice(&f32::INFINITY.to_le_bytes());

    let cases = vec![
        bad("empty.off", "", |k| matches!(k, ErrorKind::Empty), None),
        bad("empty.obj", "", |k| matches!(k, ErrorKind::Empty), None),
        bad("empty.ply", "", |k| matches!(k, ErrorKind::Empty), None),
        bad("empty.stl", "", |k| matches!(k, ErrorKind::Empty), None),
        bad(
            "short.off",
            "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n",
            |k| matches!(k, ErrorKind::Truncated { .. }),
            Some(Location::Line(8)),
        ),
        bad(
            "count.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n",
            |k| {
                matches!(
                    k,
                    ErrorKind::WrongCount {
                        declared: 1,
                        found: 2,
                        ..
                    }
                )
            },
            Some(Location::Line(7)),
        ),
        bad(
            "range.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
            |k| {
                matches!(
                    k,
                    ErrorKind::IndexOutOfRange {
                        index: 7,
                        vertices: 3
                    }
                )
            },
            Some(Location::Line(6)),
        ),
        bad(
            "nan.off",
            "OFF\n3 1 0\n0 0 0\n1 0 NaN\n0 1 0\n3 0 1 2\n",
            |k| matches!(k, ErrorKind::NonFiniteCoordinate),
            Some(Location::Line(4)),
        ),
        bad(
            "nofaces.off",
            "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n",
            |k| matches!(k, ErrorKind::NoFaces { dropped: 0 }),
            None,
        ),
        bad(
            "flat.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n",
            |k| matches!(k, ErrorKind::NoFaces { dropped: 1 }),
            None,
        ),
        bad(
            "garbage.off",
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 one 2\n",
            |k| matches!(k, ErrorKind::Syntax(_)),
            Some(Location::Line(6)),
        ),
        bad(
            "binary.off",
            vec![0u8, 159, 146, 150, 10, 1, 2],
            |k| matches!(k, ErrorKind::Syntax(_)),
            Some(Location::Line(1)),
        ),
        bad(
            "range.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 3\nf 1 2 9\n",
            |k| {
                matches!(
                    k,
                    ErrorKind::IndexOutOfRange {
                        index: 8,
                        vertices: 3
                    }
                )
            },
            Some(Location::Line(6)),
        ),
        bad(
            "inf.obj",
            "v 0 0 0\nv 1 0 -inf\nv 0 1 0\nf 1 2 3\n",
            |k| matches!(k, ErrorKind::NonFiniteCoordinate),
            Some(Location::Line(2)),
        ),
        bad(
            "points.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
            |k| matches!(k, ErrorKind::NoFaces { dropped: 0 }),
            None,
        ),
        bad(
            "garbage.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 three\n",
            |k| matches!(k, ErrorKind::Syntax(_)),
            Some(Location::Line(4)),
        ),
        bad(
            "novertices.obj",
            "# nothing\nf 1 2 3\n",
            |k| matches!(k, ErrorKind::IndexOutOfRange { .. }),
            Some(Location::Line(2)),
        ),
        bad(
            "range.ply",
            ply_bad_index,
            |k| matches!(k, ErrorKind::IndexOutOfRange { index: 500, .. }),
            element("face", 3),
        ),
        bad(
            "negative.ply",
            ply_negative,
            |k| matches!(k, ErrorKind::Syntax(m) if m.contains("negative")),
            element("face", 2),
        ),
        bad(
            "nan.ply",
            ply_nan,
            |k| matches!(k, ErrorKind::NonFiniteCoordinate),
            element("vertex", 7),
        ),
        bad(
            "cut.ply",
            ply_cut,
            |k| matches!(k, ErrorKind::Truncated { .. }),
            element("face", 10),
        ),
        bad(
            "garbage.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
             end_header\n0 0 0\n1 0 0\n0 x 0\n3 0 1 2\n",
            |k| matches!(k, ErrorKind::Syntax(_)),
            Some(Location::Line(12)),
        ),
        bad(
            "nofaces.ply",
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n",
            |k| matches!(k, ErrorKind::NoFaces { dropped: 0 }),
            None,
        ),
        bad(
            "cut.stl",
            stl[..84 + 50 * 3 + 20].to_vec(),
            |k| matches!(k, ErrorKind::Truncated { .. }),
            Some(Location::Byte(84 + 50 * 3)),
        ),
        bad(
            "inf.stl",
            stl_inf,
            |k| matches!(k, ErrorKind::NonFiniteCoordinate),
            element("facet", 4),
        ),
        bad(
            "garbage.stl",
            "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertx 0 1 0\n",
            |k| matches!(k, ErrorKind::Syntax(_)),
            Some(Location::Line(6)),
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for case in cases {
        let path = dir.path().join(case.file);
        std::fs::write(&path, &case.bytes).unwrap();
        let e = read_mesh(&path).expect_err(case.file);
        assert!((case.kind)(&e.kind), "{}: wrong kind: {e:?}", case.file);
        assert_eq!(e.location, case.location, "{}: {e}", case.file);
        let shown = e.to_string();
        assert!(shown.contains(case.file), "{shown}");
        if let Some(l) = &case.location {
            assert!(shown.contains(&l.to_string()), "{shown}");
        }
        assert_eq!(e.path.as_deref(), Some(path.as_path()));
    }
}

#[test]
fn missing_file_is_an_io_error_with_the_path() {
    let e = read_mesh(Path::new("/nonexistent/dir/x.off")).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Io(_)));
    assert!(e.to_string().starts_with("/nonexistent/dir/x.off: "), "{e}");
}

fn entries(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    v
}

#[test]
fn writers_are_atomic() {
    let dir = tempfile::tempdir().unwrap();
    let m = icosphere(1, 1.0);
    let target = dir.path().join("out.off");
    std::fs::write(&target, "old").unwrap();
    write_off(&m, &target).unwrap();
    assert_eq!(entries(dir.path()), vec![target.clone()]);
    assert_eq!(read_mesh(&target).unwrap().mesh, m);

    // Wrong colour count: an error before anything is written; the old file stays.
    let ply = dir.path().join("out.ply");
    std::fs::write(&ply, "old").unwrap();
    let e = write_ply_colored(&m, &[[0, 0, 0]], &ply).unwrap_err();
    assert!(e.to_string().contains("out.ply"), "{e}");
    assert_eq!(std::fs::read(&ply).unwrap(), b"old");

    // Unwritable target (a directory): the error names it and no temporary file is left.
    let sub = dir.path().join("sub.off");
    std::fs::create_dir(&sub).unwrap();
    let e = write_off(&m, &sub).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Io(_)));
    assert!(e.to_string().contains("sub.off"), "{e}");
    assert_eq!(entries(dir.path()), vec![target, ply, sub]);

    let e = write_off(&m, &dir.path().join("missing/x.off")).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Io(_)));
}

/// Valid files of every format and variant, for mutation.
fn seeds() -> Vec<(Format, Vec<u8>)> {
    let m = icosphere(0, 1.0);
    let mut v = Vec::new();
    for (_, b) in fixtures::off_variants(&m) {
        v.push((Format::Off, b));
    }
    for (_, b) in fixtures::obj_variants(&m) {
        v.push((Format::Obj, b));
    }
    for enc in [PlyEncoding::Ascii, PlyEncoding::Little, PlyEncoding::Big] {
        for faces in [PlyFaces::Faces, PlyFaces::FacesIndex, PlyFaces::Strips] {
            v.push((
                Format::Ply,
                fixtures::ply(&m, enc, faces, matches!(enc, PlyEncoding::Little)),
            ));
        }
    }
    v.push((Format::Stl, fixtures::stl_ascii(&m)));
    v.push((Format::Stl, fixtures::stl_binary(&m)));
    v
}

#[derive(Debug, Clone)]
enum Mutation {
    Truncate(usize),
    Set(usize, u8),
    Insert(usize, Vec<u8>),
    Remove(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let special = prop_oneof![
        Just(b'\n'),
        Just(b' '),
        Just(b'-'),
        Just(b'0'),
        Just(b'9'),
        Just(0xFF),
        Just(0x00),
        Just(0x7F),
        any::<u8>(),
    ];
    prop_oneof![
        any::<usize>().prop_map(Mutation::Truncate),
        (any::<usize>(), special).prop_map(|(i, b)| Mutation::Set(i, b)),
        (
            any::<usize>(),
            prop_oneof![
                Just(b"-1 ".to_vec()),
                Just(b"4294967295 ".to_vec()),
                Just(b"99999999999 ".to_vec()),
                Just(b"nan ".to_vec()),
                Just(b"\n".to_vec()),
                Just(b"#".to_vec()),
                Just(b"/".to_vec()),
                proptest::collection::vec(any::<u8>(), 1..8),
            ]
        )
            .prop_map(|(i, b)| Mutation::Insert(i, b)),
        (any::<usize>(), 1usize..16).prop_map(|(i, n)| Mutation::Remove(i, n)),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    let len = bytes.len().max(1);
    match m {
        Mutation::Truncate(i) => bytes.truncate(i % len),
        Mutation::Set(i, b) => {
            if !bytes.is_empty() {
                bytes[i % len] = *b;
            }
        }
        Mutation::Insert(i, b) => {
            let at = i % (bytes.len() + 1);
            bytes.splice(at..at, b.iter().copied());
        }
        Mutation::Remove(i, n) => {
            let at = i % len;
            let end = (at + n).min(bytes.len());
            if at < end {
                bytes.drain(at..end);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

    #[test]
    fn mutated_files_never_panic(
        seed in any::<prop::sample::Index>(),
        muts in proptest::collection::vec(mutation(), 1..6),
        other in 0usize..4,
    ) {
        let seeds = seeds();
        let (format, mut bytes) = seeds[seed.index(seeds.len())].clone();
        for m in &muts {
            apply(&mut bytes, m);
        }
        // Ok or Err, never a panic; and the same bytes through another reader.
        let _ = read_mesh_from_bytes(&bytes, format);
        let formats = [Format::Off, Format::Obj, Format::Ply, Format::Stl];
        let _ = read_mesh_from_bytes(&bytes, formats[other]);
    }

    #[test]
    fn random_bytes_never_panic(
        bytes in proptest::collection::vec(any::<u8>(), 0..400),
        prefix in prop_oneof![
            Just(&b""[..]),
            Just(&b"OFF\n"[..]),
            Just(&b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"[..]),
            Just(&b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n"[..]),
            Just(&b"solid x\n"[..]),
            Just(&b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"[..]),
        ],
    ) {
        let data = [prefix, &bytes[..]].concat();
        for format in [Format::Off, Format::Obj, Format::Ply, Format::Stl] {
            let _ = read_mesh_from_bytes(&data, format);
        }
    }
}
