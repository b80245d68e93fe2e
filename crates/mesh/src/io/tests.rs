//! Round trips through every format and variant, malformed files through `read_mesh` (kind,
//! location and file name in the message), the writers' atomicity, and fuzzing.

use std::path::{Path, PathBuf};

use proptest::prelude::*;

use super::fixtures::{self, PcdData, PlyEncoding, PlyFaces};
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
    assert_eq!(Format::from_path(Path::new("b.XYZ")).unwrap(), Format::Xyz);
    assert_eq!(Format::from_path(Path::new("b.pts")).unwrap(), Format::Pts);
    assert_eq!(Format::from_path(Path::new("b.pcd")).unwrap(), Format::Pcd);
    let e = Format::from_path(Path::new("dir/mesh.dat")).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::UnknownFormat { ref extension } if extension == "dat"));
    assert!(e.to_string().contains("mesh.dat") && e.to_string().contains(".dat"));
    assert!(e.to_string().contains(".pcd"), "{e}");
    let e = read_mesh(Path::new("dir/mesh")).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::UnknownFormat { ref extension } if extension.is_empty()));
    assert!(e.to_string().contains("dir/mesh: no file extension"), "{e}");
    for f in [
        Format::Off,
        Format::Obj,
        Format::Ply,
        Format::Stl,
        Format::Gltf,
        Format::Xyz,
        Format::Pts,
        Format::Pcd,
    ] {
        assert_eq!(Format::from_extension(f.extension()), Some(f));
    }
}

/// Points and unit normals of a mesh, for the point-cloud formats.
fn cloud(m: &Mesh) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let points = m.positions.iter().map(|p| [p.x, p.y, p.z]).collect();
    let normals = m
        .positions
        .iter()
        .map(|p| {
            let n = p.coords.normalize();
            [n.x, n.y, n.z]
        })
        .collect();
    (points, normals)
}

fn input(bytes: &[u8], format: Format) -> LoadedInput {
    read_input_from_bytes(bytes, format).unwrap_or_else(|e| panic!("{format:?}: {e}"))
}

fn points_of(i: &LoadedInput) -> &PointCloud {
    match &i.geometry {
        Geometry::Points(p) => p,
        Geometry::Mesh(_) => panic!("{:?}: a mesh", i.format),
    }
}

#[test]
fn point_clouds_round_trip_through_xyz_pts_pcd_and_ply() {
    let m = icosphere(2, 1.0);
    let (points, normals) = cloud(&m);
    let exact: Vec<Point3<f64>> = m.positions.clone();
    let f32s = as_f32(&m);
    let n = points.len();
    let mut pts = format!("{n}\n").into_bytes();
    pts.extend(fixtures::xyz(&points, None, " "));
    let mut cases: Vec<(String, Format, Vec<u8>, bool)> = vec![
        (
            "xyz".into(),
            Format::Xyz,
            fixtures::xyz(&points, None, " "),
            false,
        ),
        (
            "xyz commas".into(),
            Format::Xyz,
            fixtures::xyz(&points, Some(&normals), ","),
            true,
        ),
        ("pts".into(), Format::Pts, pts, false),
    ];
    for data in [PcdData::Ascii, PcdData::Binary, PcdData::Compressed] {
        cases.push((
            format!("pcd {data:?}"),
            Format::Pcd,
            fixtures::pcd(&points, Some(&normals), n, 1, data),
            true,
        ));
    }
    for (what, format, bytes, with_normals) in cases {
        let i = input(&bytes, format);
        assert_eq!(i.format, format, "{what}");
        assert_eq!(i.source, Source::Points, "{what}");
        assert!(i.warnings.is_empty(), "{what}: {:?}", i.warnings);
        assert_eq!(i.repairs, Repairs::default());
        let p = points_of(&i);
        // Binary PCD stores x and z as f32, y as f64 (ascii values are written in full).
        if format == Format::Pcd && !what.ends_with("Ascii") {
            for (k, (a, b)) in p.positions.iter().zip(&exact).enumerate() {
                assert_eq!((a.x, a.y, a.z), (f32s[k].x, b.y, f32s[k].z), "{what}");
            }
        } else {
            assert_eq!(p.positions, exact, "{what}");
        }
        assert_eq!(p.normals.is_some(), with_normals, "{what}");
        if let Some(ns) = &p.normals {
            for (a, b) in ns.iter().zip(&normals) {
                assert!((a - Vector3::from(*b)).norm() < 1e-6, "{what}");
            }
        }
        // read_mesh refuses points, saying what the file holds and where points are accepted.
        let e = read_mesh_from_bytes(&bytes, format).unwrap_err();
        assert!(
            matches!(e.kind, ErrorKind::PointCloud { points } if points == n),
            "{what}"
        );
        let text = e.to_string();
        assert!(text.contains(&format!("{n} points and no faces")), "{text}");
        assert!(
            text.contains("detect") && !text.contains("not supported"),
            "{text}"
        );
    }
    // Vertex-only PLY, OFF and OBJ are point clouds too.
    let ply = fixtures::ply(&m, PlyEncoding::Little, PlyFaces::Faces, true);
    let header_end = ply.windows(11).position(|w| w == b"end_header\n").unwrap();
    let mut vertices_only =
        String::from_utf8_lossy(&ply[..header_end]).replace("element face", "element unused");
    vertices_only.push_str("end_header\n");
    let mut b = vertices_only.into_bytes();
    b.extend(&ply[header_end + 11..]);
    let i = input(&b, Format::Ply);
    assert_eq!(points_of(&i).positions, exact);
    assert_eq!(points_of(&i).normals, None); // this fixture has 'nx' only
    let off = format!(
        "OFF\n{n} 0 0\n{}",
        String::from_utf8(fixtures::xyz(&points, None, " ")).unwrap()
    );
    assert_eq!(
        points_of(&input(off.as_bytes(), Format::Off)).positions,
        exact
    );
}

#[test]
fn meshes_read_the_same_through_read_input() {
    for (name, m) in meshes() {
        for (format, bytes) in [
            (Format::Off, fixtures::off_variants(&m)[0].1.clone()),
            (
                Format::Ply,
                fixtures::ply(&m, PlyEncoding::Big, PlyFaces::Strips, true),
            ),
            (Format::Stl, fixtures::stl_binary(&m)),
        ] {
            let i = input(&bytes, format);
            let l = read(&bytes, format);
            assert_eq!(i.source, Source::Mesh, "{name}");
            assert_eq!(i.geometry, Geometry::Mesh(l.mesh), "{name} {format:?}");
            assert_eq!(i.repairs, l.repairs);
            assert!(i.warnings.is_empty() && l.warnings.is_empty());
        }
    }
}

#[test]
fn a_range_grid_reads_as_a_mesh_through_both_entry_points() {
    // A 3 x 4 grid with one absent cell, written as the Stanford scans are.
    let mut text = String::from(
        "ply\nformat ascii 1.0\nobj_info num_cols 4\nobj_info num_rows 3\nelement vertex 11\n\
         property float x\nproperty float y\nproperty float z\nelement range_grid 12\n\
         property list uchar int vertex_indices\nend_header\n",
    );
    let mut cells = String::new();
    let mut v = 0;
    for r in 0..3 {
        for c in 0..4 {
            if (r, c) == (1, 2) {
                cells.push_str("0\n");
            } else {
                text.push_str(&format!("{c} {r} 0\n"));
                cells.push_str(&format!("1 {v}\n"));
                v += 1;
            }
        }
    }
    text.push_str(&cells);
    let i = input(text.as_bytes(), Format::Ply);
    assert_eq!(i.source, Source::RangeGrid { rows: 3, cols: 4 });
    let l = read(text.as_bytes(), Format::Ply);
    assert_eq!(i.geometry, Geometry::Mesh(l.mesh.clone()));
    // 6 blocks, 4 of them missing a corner.
    assert_eq!(l.mesh.num_faces(), 2 * 2 + 4);
    // A grid too sparse for any triangle: points, with a warning.
    let sparse = text.replace(
        "obj_info num_cols 4\nobj_info num_rows 3",
        "obj_info num_cols 12\nobj_info num_rows 1",
    );
    let i = input(sparse.as_bytes(), Format::Ply);
    assert_eq!(i.source, Source::Points);
    assert_eq!(points_of(&i).positions.len(), 11);
    assert!(
        i.warnings[0].contains("1 x 12 range grid gives no triangles"),
        "{:?}",
        i.warnings
    );
    let e = read_mesh_from_bytes(sparse.as_bytes(), Format::Ply).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::PointCloud { points: 11 }));
}

#[test]
fn non_finite_normals_are_dropped_with_a_warning() {
    let points = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
    let normals = [[0.0, 0.0, 1.0], [f64::NAN, 0.0, 1.0]];
    let i = input(
        &fixtures::pcd(&points, Some(&normals), 2, 1, PcdData::Binary),
        Format::Pcd,
    );
    assert_eq!(points_of(&i).normals, None);
    assert_eq!(
        i.warnings,
        vec!["point 1: its normal is NaN or infinite: normals ignored"]
    );
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
            |k| matches!(k, ErrorKind::PointCloud { points: 3 }),
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
            |k| matches!(k, ErrorKind::PointCloud { points: 3 }),
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
            |k| matches!(k, ErrorKind::PointCloud { points: 3 }),
            None,
        ),
        bad(
            "nan.xyz",
            "0 0 0\n1 0 0\n0 nan 0\n",
            |k| matches!(k, ErrorKind::NonFiniteCoordinate),
            Some(Location::Line(3)),
        ),
        bad(
            "short.xyz",
            "# x y z\n0 0 0\n1 0\n",
            |k| matches!(k, ErrorKind::Syntax(_)),
            Some(Location::Line(3)),
        ),
        bad(
            "empty.xyz",
            "// nothing\n",
            |k| matches!(k, ErrorKind::NoVertices),
            None,
        ),
        bad(
            "word.pts",
            "2\n0 0 0 1 2 3 4\n1 zero 0 1 2 3 4\n",
            |k| matches!(k, ErrorKind::Syntax(_)),
            Some(Location::Line(3)),
        ),
        bad(
            "points.pts",
            "2\n0 0 0 1 2 3 4\n1 0 0 1 2 3 4\n",
            |k| matches!(k, ErrorKind::PointCloud { points: 2 }),
            None,
        ),
        bad(
            "huge.pcd",
            "FIELDS x y z\nPOINTS 1000000000\nDATA binary\n\0\0\0\0\0\0\0\0\0\0\0\0",
            |k| matches!(k, ErrorKind::Truncated { .. }),
            Some(Location::Point(1)),
        ),
        bad(
            "inf.pcd",
            "FIELDS x y z\nPOINTS 2\nDATA ascii\n0 0 0\n0 -inf 0\n",
            |k| matches!(k, ErrorKind::NonFiniteCoordinate),
            Some(Location::Line(5)),
        ),
        bad(
            "grid.ply",
            "ply\nformat ascii 1.0\nobj_info num_cols 2\nobj_info num_rows 1\nelement vertex 1\n\
             property float x\nproperty float y\nproperty float z\nelement range_grid 2\n\
             property list uchar int vertex_indices\nend_header\n0 0 0\n1 0\n1 1\n",
            |k| {
                matches!(
                    k,
                    ErrorKind::IndexOutOfRange {
                        index: 1,
                        vertices: 1
                    }
                )
            },
            Some(Location::Line(14)),
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
    let (mut points, normals) = cloud(&m);
    v.push((Format::Xyz, fixtures::xyz(&points, Some(&normals), " ")));
    let mut pts = format!("{}\n", points.len()).into_bytes();
    pts.extend(fixtures::xyz(&points, None, ","));
    v.push((Format::Pts, pts));
    points[3] = [f64::NAN; 3];
    for data in [PcdData::Ascii, PcdData::Binary, PcdData::Compressed] {
        v.push((
            Format::Pcd,
            fixtures::pcd(&points, Some(&normals), 12, 1, data),
        ));
        v.push((Format::Pcd, fixtures::pcd(&points, None, 4, 3, data)));
    }
    let mut grid = String::from(
        "ply\nformat ascii 1.0\nobj_info num_cols 4\nobj_info num_rows 3\nbye\n\
         element vertex 12\nproperty float x\nproperty float y\nproperty float z\n\
         element range_grid 12\nproperty list uchar int vertex_indices\nend_header\n",
    );
    m.positions[..12]
        .iter()
        .for_each(|p| grid.push_str(&format!("{} {} {}\n", p.x, p.y, p.z)));
    (0..12).for_each(|i| grid.push_str(if i == 5 { "0\n" } else { "1 " }));
    v.push((Format::Ply, grid.into_bytes()));
    v
}

const FORMATS: [Format; 8] = [
    Format::Off,
    Format::Obj,
    Format::Ply,
    Format::Stl,
    Format::Gltf,
    Format::Xyz,
    Format::Pts,
    Format::Pcd,
];

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
        other in 0usize..8,
    ) {
        let seeds = seeds();
        let (format, mut bytes) = seeds[seed.index(seeds.len())].clone();
        for m in &muts {
            apply(&mut bytes, m);
        }
        // Ok or Err, never a panic; and the same bytes through another reader.
        let _ = read_mesh_from_bytes(&bytes, format);
        let _ = read_input_from_bytes(&bytes, format);
        let _ = read_input_from_bytes(&bytes, FORMATS[other]);
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
            Just(&b"ply\nformat binary_little_endian 1.0\nobj_info num_cols 3\nobj_info num_rows 2\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement range_grid 6\nproperty list uchar int vertex_indices\nend_header\n"[..]),
            Just(&b"3\n"[..]),
            Just(&b"FIELDS x y z normal_x normal_y normal_z\nWIDTH 2\nHEIGHT 2\nDATA binary\n"[..]),
            Just(&b"VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA binary_compressed\n"[..]),
            Just(&b"FIELDS x y z\nPOINTS 3\nDATA ascii\n"[..]),
        ],
    ) {
        let data = [prefix, &bytes[..]].concat();
        for format in FORMATS {
            let _ = read_mesh_from_bytes(&data, format);
            let _ = read_input_from_bytes(&data, format);
        }
    }
}
