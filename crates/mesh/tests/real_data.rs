//! Reads the real meshes in `../shared/data` (next to the project; never copied into it): every
//! model in `models/` and one shape from each of `tosca/`, `kids/` and `faust/`, checking counts
//! against the files' own headers, and the OBJ files' triangles against the `tobj` crate; and the
//! Stanford bunny's raw range scans in `scans/bunny/`, triangulated, against a plain parse of
//! their grids. Skips with a message when the folder is absent. Prints read times (run with `--release
//! --nocapture` for meaningful figures).

use std::path::{Path, PathBuf};
use std::time::Instant;

use keycomp_mesh::grid::DEPTH_JUMP;
use keycomp_mesh::{Format, Geometry, LoadedMesh, Point3, Source, read_input, read_mesh};
use keycomp_test_support::{median, shared_data};

fn load(path: &Path) -> LoadedMesh {
    let t = Instant::now();
    let m = read_mesh(path).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "{:<40} {:>7} vertices {:>7} faces  {:>7.1} ms  (dropped {}, unreferenced {})",
        path.file_name().unwrap_or_default().to_string_lossy(),
        m.mesh.num_vertices(),
        m.mesh.num_faces(),
        t.elapsed().as_secs_f64() * 1e3,
        m.repairs.dropped_faces(),
        m.repairs.unreferenced_vertices,
    );
    m
}

/// Vertex and face counts as the files declare them (headers, or `v`/`f` line counts for OBJ);
/// `None` for faces when they are stored as a triangle strip.
const KNOWN: &[(&str, usize, Option<usize>)] = &[
    ("models/armadillo.obj", 43_243, Some(86_482)),
    ("models/bunny.off", 3_485, Some(6_966)),
    ("models/camelhead.off", 11_381, Some(22_704)),
    ("models/fandisk.off", 7_229, Some(14_454)),
    ("models/fertility.off", 4_494, Some(9_000)),
    ("models/homer.obj", 6_002, Some(12_000)),
    ("models/horse.ply", 48_485, Some(96_966)),
    ("models/igea.ply", 134_345, None),
    ("models/nefertiti.obj", 49_971, Some(99_938)),
    ("models/spot.obj", 2_930, Some(5_856)),
    ("models/stanford-bunny.obj", 35_947, Some(69_451)),
    ("tosca/cat0.off", 27_894, Some(55_712)),
    ("kids/0001.null.0.off", 59_727, Some(119_344)),
    ("faust/tr_reg_000.ply", 6_890, Some(13_776)),
];

#[test]
fn real_meshes_load_with_their_declared_counts() {
    let Some(dir) = shared_data("") else { return };
    // Every model in models/ is in the table (a new file must be added to it).
    for entry in std::fs::read_dir(dir.join("models")).unwrap() {
        let name = format!("models/{}", entry.unwrap().file_name().to_string_lossy());
        if Format::from_path(Path::new(&name)).is_ok() {
            assert!(KNOWN.iter().any(|k| k.0 == name), "{name} is not in KNOWN");
        }
    }
    for &(name, vertices, faces) in KNOWN {
        let path = dir.join(name);
        if !path.exists() {
            println!("{name}: absent, skipped");
            continue;
        }
        let m = load(&path);
        assert_eq!(m.mesh.num_vertices(), vertices, "{name}");
        match faces {
            Some(f) => assert_eq!(m.mesh.num_faces() + m.repairs.dropped_faces(), f, "{name}"),
            None => {
                // A strip: about two triangles per vertex for a closed-ish surface.
                let ratio = m.mesh.num_faces() as f64 / vertices as f64;
                assert!((1.9..2.1).contains(&ratio), "{name}: {ratio}");
            }
        }
        assert!(
            m.repairs.dropped_faces() * 100 < m.mesh.num_faces(),
            "{name}"
        );
    }
}

#[test]
fn obj_triangles_match_tobj() {
    let Some(dir) = shared_data("") else { return };
    for name in [
        "models/spot.obj",
        "models/homer.obj",
        "models/stanford-bunny.obj",
        "models/nefertiti.obj",
    ] {
        let path = dir.join(name);
        if !path.exists() {
            continue;
        }
        let ours = read_mesh(&path).unwrap();
        let options = tobj::LoadOptions {
            triangulate: true,
            single_index: false,
            ..Default::default()
        };
        let (models, _) = tobj::load_obj(&path, &options).unwrap();
        let mut theirs: Vec<[Point3<f64>; 3]> = Vec::new();
        for model in &models {
            let p = &model.mesh.positions;
            for t in model.mesh.indices.as_chunks::<3>().0 {
                theirs.push(t.map(|i| {
                    let i = 3 * i as usize;
                    Point3::new(p[i], p[i + 1], p[i + 2])
                }));
            }
        }
        // Ours is theirs minus the degenerate faces, in the same order.
        let mut k = 0;
        for f in 0..ours.mesh.num_faces() {
            let t = ours.mesh.triangle(f);
            while k < theirs.len() && theirs[k] != t {
                k += 1;
            }
            assert!(
                k < theirs.len(),
                "{name}: face {f} not found in tobj's order"
            );
            k += 1;
        }
        assert_eq!(
            theirs.len(),
            ours.mesh.num_faces() + ours.repairs.dropped_faces(),
            "{name}"
        );
    }
}

#[test]
fn igea_strip_winding_is_consistent() {
    let Some(dir) = shared_data("") else { return };
    let path = dir.join("models/igea.ply");
    if !path.exists() {
        return;
    }
    // With the strip's alternating winding decoded right, neighbouring triangles traverse their
    // shared edge in opposite directions: (almost) no directed edge is used twice.
    let m = read_mesh(&path).unwrap().mesh;
    let mut edges = std::collections::HashSet::new();
    let mut twice = 0;
    for [a, b, c] in &m.faces {
        for e in [(a, b), (b, c), (c, a)] {
            if !edges.insert(e) {
                twice += 1;
            }
        }
    }
    assert!(
        twice * 1000 < m.faces.len(),
        "{twice} directed edges used twice"
    );
}

/// A range scan as a plain reading of its ascii PLY gives it: the oracle for the reader.
struct Scan {
    vertices: Vec<Point3<f64>>,
    rows: usize,
    cols: usize,
    cells: Vec<Option<usize>>,
    /// The header, `element vertex` … `end_header` with the range_grid lines removed.
    points_header: String,
}

fn parse_scan(path: &Path) -> Scan {
    let text = std::fs::read_to_string(path).expect("a readable scan");
    let number = |t: &str| -> usize { t.parse().expect("a count") };
    let mut lines = text.lines();
    let (mut nv, mut ncells, mut rows, mut cols) = (0, 0, 0, 0);
    let mut points_header = String::new();
    for l in lines.by_ref() {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.as_slice() {
            ["element", "vertex", n] => nv = number(n),
            ["element", "range_grid", n] => ncells = number(n),
            ["obj_info", "num_rows", n] => rows = number(n),
            ["obj_info", "num_cols", n] => cols = number(n),
            ["end_header"] => {
                points_header.push_str("end_header\n");
                break;
            }
            _ => {}
        }
        if ncells == 0 {
            points_header.push_str(l);
            points_header.push('\n');
        }
    }
    let mut row = || -> Vec<f64> {
        lines
            .next()
            .expect("a data line")
            .split_whitespace()
            .map(|t| t.parse().expect("a number"))
            .collect()
    };
    let vertices: Vec<Point3<f64>> = (0..nv)
        .map(|_| {
            let c = row();
            Point3::new(c[0], c[1], c[2])
        })
        .collect();
    let cells = (0..ncells)
        .map(|_| {
            let c = row();
            (c[0] > 0.0).then(|| c[1] as usize)
        })
        .collect();
    assert_eq!(rows * cols, ncells, "{}", path.display());
    Scan {
        vertices,
        rows,
        cols,
        cells,
        points_header,
    }
}

#[test]
fn bunny_range_scans_triangulate_into_sensible_meshes() {
    let Some(dir) = shared_data("") else { return };
    let scans = dir.join("scans/bunny");
    if !scans.is_dir() {
        eprintln!("skipping: {} not found", scans.display());
        return;
    }
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&scans)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ply"))
        .collect();
    paths.sort();
    assert_eq!(paths.len(), 10);
    let tmp = tempfile::tempdir().unwrap();
    println!(
        "{:<13} {:>6} {:>7} {:>7} {:>8} {:>7} {:>9} {:>9} {:>9}",
        "scan", "verts", "cells", "faces", "dropped", "%", "spacing", "med.edge", "max.edge"
    );
    for path in &paths {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let scan = parse_scan(path);
        let t = Instant::now();
        let input = read_input(path).unwrap_or_else(|e| panic!("{e}"));
        let ms = t.elapsed().as_secs_f64() * 1e3;
        assert_eq!(
            input.source,
            Source::RangeGrid {
                rows: scan.rows,
                cols: scan.cols
            },
            "{name}"
        );
        assert!(input.warnings.is_empty(), "{name}: {:?}", input.warnings);
        let Geometry::Mesh(mesh) = &input.geometry else {
            panic!("{name}: not a mesh")
        };
        // The vertices are the file's, in its order.
        assert_eq!(mesh.positions.len(), scan.vertices.len(), "{name}");
        for (a, b) in mesh.positions.iter().zip(&scan.vertices) {
            assert!((a - b).norm() < 1e-6, "{name}");
        }
        // Candidate triangles: two per block of four present cells, one per block of three.
        let present = |r: usize, c: usize| scan.cells[r * scan.cols + c];
        let mut candidates = 0;
        let mut neighbour = Vec::new();
        for r in 0..scan.rows {
            for c in 0..scan.cols {
                let Some(a) = present(r, c) else { continue };
                for (rr, cc) in [(r, c + 1), (r + 1, c)] {
                    if rr < scan.rows
                        && cc < scan.cols
                        && let Some(b) = present(rr, cc)
                    {
                        neighbour.push((scan.vertices[a] - scan.vertices[b]).norm());
                    }
                }
                if r + 1 < scan.rows && c + 1 < scan.cols {
                    let n = [(r, c + 1), (r + 1, c), (r + 1, c + 1)]
                        .iter()
                        .filter(|(r, c)| present(*r, *c).is_some())
                        .count();
                    candidates += match n {
                        3 => 2,
                        2 => 1,
                        _ => 0,
                    };
                }
            }
        }
        let spacing = median(neighbour);
        let faces = mesh.num_faces();
        let dropped = candidates - faces - input.repairs.dropped_faces();
        let edges: Vec<f64> = (0..faces)
            .flat_map(|f| {
                let [a, b, c] = mesh.triangle(f);
                [(b - a).norm(), (c - b).norm(), (a - c).norm()]
            })
            .collect();
        let longest = edges.iter().copied().fold(0.0, f64::max);
        let med = median(edges);
        // Triangles face the scanner: the summed area vectors point toward +z.
        let normal: keycomp_mesh::Vector3<f64> = (0..faces)
            .map(|f| {
                let [a, b, c] = mesh.triangle(f);
                (b - a).cross(&(c - a))
            })
            .sum();
        println!(
            "{name:<13} {:>6} {:>7} {faces:>7} {dropped:>8} {:>6.2}% {spacing:>9.6} {med:>9.6} \
             {longest:>9.6}  normal z {:+.2}  degenerate {}  {ms:.0} ms",
            mesh.num_vertices(),
            scan.cells.iter().flatten().count(),
            100.0 * dropped as f64 / candidates as f64,
            normal.z / normal.norm(),
            input.repairs.dropped_faces(),
        );
        assert!(faces > 40_000, "{name}: {faces} faces");
        assert!(
            dropped * 20 < candidates,
            "{name}: {dropped} of {candidates} dropped"
        );
        assert!(
            longest <= DEPTH_JUMP * spacing * (1.0 + 1e-9),
            "{name}: {longest}"
        );
        assert!(
            (0.7..1.5).contains(&(med / spacing)),
            "{name}: {med} vs {spacing}"
        );
        assert!(normal.z > 0.5 * normal.norm(), "{name}: {normal:?}");
        // Consistent winding, no overlapping blocks: no directed edge is used twice.
        let mut directed = std::collections::HashSet::new();
        for [a, b, c] in &mesh.faces {
            for e in [(a, b), (b, c), (c, a)] {
                assert!(directed.insert(e), "{name}: edge {e:?} used twice");
            }
        }

        // The same points as a PLY without the grid: a point cloud.
        let mut ply = scan.points_header.clone();
        for p in &scan.vertices {
            ply.push_str(&format!("{} {} {}\n", p.x, p.y, p.z));
        }
        let points_path = tmp.path().join(&name);
        std::fs::write(&points_path, ply).unwrap();
        let points = read_input(&points_path).unwrap();
        assert_eq!(points.source, Source::Points);
        assert!(points.warnings.is_empty(), "{:?}", points.warnings);
        let Geometry::Points(cloud) = points.geometry else {
            panic!("{name}: not points")
        };
        assert_eq!(cloud.positions, mesh.positions, "{name}");
        assert_eq!(cloud.normals, None);
        let e = read_mesh(&points_path).unwrap_err();
        assert!(e.to_string().contains("points and no faces"), "{e}");
    }
}
