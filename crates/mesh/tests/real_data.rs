//! Reads the real meshes in `../shared/data` (next to the project; never copied into it): every
//! model in `models/` and one shape from each of `tosca/`, `kids/` and `faust/`, checking counts
//! against the files' own headers, and the OBJ files' triangles against the `tobj` crate.
//! Skips with a message when the folder is absent. Prints read times (run with `--release
//! --nocapture` for meaningful figures).

use std::path::{Path, PathBuf};
use std::time::Instant;

use keycomp_mesh::{Format, LoadedMesh, Point3, read_mesh};

fn data_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipping: ../shared/data not found ({})", dir.display());
        None
    }
}

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
    let Some(dir) = data_dir() else { return };
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
    let Some(dir) = data_dir() else { return };
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
    let Some(dir) = data_dir() else { return };
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
