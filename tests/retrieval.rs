//! End-to-end retrieval: `keycomp index add`, `query`, `index list|stats|verify|remove` on
//! real shapes (skipped with a message when `../shared/data` is absent) and on synthetic ones.

mod common;

use std::path::{Path, PathBuf};

use keycomp_mesh::{Point3, Vector3, cut, geometry, read_mesh, synth, write_off};
use keycomp_test_support::shared_data;
use serde_json::Value;

use common::{keycomp, s, stderr};

fn class_of(path: &str) -> String {
    let name = Path::new(path)
        .file_stem()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    name.trim_end_matches(|c: char| c.is_ascii_digit())
        .to_string()
}

/// Index TOSCA cats, dogs, horses and centaurs; query with halves of shapes cut by planes
/// through their centroid: the source shape's class must come first.
#[test]
fn partial_queries_find_their_class_on_tosca() {
    let Some(data) = shared_data("") else { return };
    let dir = tempfile::tempdir().expect("tempdir");
    let index = dir.path().join("index");
    let tosca = data.join("tosca");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&tosca)
        .expect("tosca")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let c = class_of(s(p));
            ["cat", "dog", "horse", "centaur"].contains(&c.as_str())
        })
        .collect();
    files.sort();
    let mut args = vec!["index", "add", "--index", s(&index)];
    args.extend(files.iter().map(|p| s(p)));
    let o = keycomp(&args);
    assert!(o.status.success(), "index add: {}", stderr(&o));

    let (mut hits, mut total) = (0, 0);
    for (name, axis) in [
        ("cat3", 0),
        ("cat3", 1),
        ("dog2", 0),
        ("horse5", 0),
        ("centaur1", 0),
    ] {
        let mesh = read_mesh(&tosca.join(format!("{name}.off")))
            .expect("read")
            .mesh;
        let bb = geometry::bounding_box(&mesh);
        let mid = Point3::from((bb.min.coords + bb.max.coords) / 2.0);
        for sign in [1.0, -1.0] {
            let mut n = Vector3::zeros();
            n[axis] = sign;
            let (half, _) = cut::cut_by_plane(&mesh, mid, n);
            let frac = geometry::total_area(&half) / geometry::total_area(&mesh);
            let q = dir.path().join(format!("{name}-{axis}-{sign}.off"));
            write_off(&half, &q).expect("write fragment");
            let o = keycomp(&["query", s(&q), "--index", s(&index), "-k", "5", "--json"]);
            let v: Value = serde_json::from_slice(&o.stdout).unwrap_or(Value::Null);
            let top: Vec<String> = v["results"]
                .as_array()
                .map(|r| {
                    r.iter()
                        .map(|x| x["path"].as_str().unwrap_or("").to_string())
                        .collect()
                })
                .unwrap_or_default();
            let hit = top.first().is_some_and(|t| class_of(t) == class_of(name));
            println!(
                "{name} half (axis {axis}, side {sign}, {:.0} % of the area, {} components): top {:?} {}",
                frac * 100.0,
                v["components"],
                top.iter()
                    .map(|t| class_of(t) + &t[t.len().saturating_sub(6)..])
                    .collect::<Vec<_>>(),
                if hit { "HIT" } else { "miss" }
            );
            total += 1;
            hits += hit as usize;
        }
    }
    println!("partial queries: {hits} of {total} ranked their class first");
    assert!(hits * 10 >= total * 7, "{hits} of {total}");
}

#[test]
fn index_commands_on_synthetic_shapes() {
    let dir = tempfile::tempdir().expect("tempdir");
    let index = dir.path().join("idx");
    let shapes = dir.path().join("shapes");
    std::fs::create_dir_all(shapes.join("sub")).expect("mkdir");
    write_off(
        &synth::textured_protrusion_sphere(6),
        &shapes.join("textured.off"),
    )
    .expect("w");
    write_off(
        &synth::torus(2.0, 0.5, 120, 60),
        &shapes.join("sub/torus.off"),
    )
    .expect("w");
    std::fs::write(shapes.join("sub/broken.off"), "OFF\n3 1 0\n0 0 0\n").expect("w");
    std::fs::write(shapes.join("notes.txt"), "not a mesh").expect("w");

    // a directory, recursively: the broken file is reported and skipped, exit 2
    let o = keycomp(&["index", "add", s(&shapes), "--index", s(&index)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("2 added") && out.contains("1 failed"), "{out}");
    assert!(stderr(&o).contains("broken.off"), "{}", stderr(&o));

    // again: nothing changes
    let o = keycomp(&[
        "index",
        "add",
        s(&shapes.join("textured.off")),
        "--index",
        s(&index),
    ]);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("1 unchanged"));

    let o = keycomp(&["index", "stats", "--index", s(&index), "--json"]);
    let v: Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(v["shapes"], 2);
    let o = keycomp(&["index", "verify", "--index", s(&index)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stdout));

    // the textured shape finds itself first
    let o = keycomp(&[
        "query",
        s(&shapes.join("textured.off")),
        "--index",
        s(&index),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).expect("json");
    assert!(
        v["results"][0]["path"]
            .as_str()
            .expect("path")
            .ends_with("textured.off")
    );
    assert!((v["results"][0]["score"].as_f64().expect("score") - 1.0).abs() < 1e-6);
    // a closed query: one description, not verified
    assert_eq!(v["results"][0]["hypothesis"], 0);
    assert!(v["results"][0]["verified"].is_null());

    // changing a file replaces its entry
    write_off(
        &synth::textured_protrusion_sphere(5),
        &shapes.join("textured.off"),
    )
    .expect("w");
    let o = keycomp(&[
        "index",
        "add",
        s(&shapes.join("textured.off")),
        "--index",
        s(&index),
    ]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("1 replaced"));

    let o = keycomp(&[
        "index",
        "remove",
        s(&shapes.join("sub/torus.off")),
        "--index",
        s(&index),
    ]);
    assert!(o.status.success());
    let o = keycomp(&["index", "list", "--index", s(&index), "--json"]);
    let v: Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(v.as_array().expect("list").len(), 1);

    // a corrupt index is an error naming the file, never a wrong answer
    let seg = std::fs::read_dir(&index)
        .expect("index dir")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.extension().is_some_and(|e| e == "kcs"))
        .expect("a segment");
    let mut bytes = std::fs::read(&seg).expect("read");
    bytes[10] ^= 0x40;
    std::fs::write(&seg, bytes).expect("write");
    let o = keycomp(&[
        "query",
        s(&shapes.join("textured.off")),
        "--index",
        s(&index),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("corrupt"), "{}", stderr(&o));
    let o = keycomp(&["index", "verify", "--index", s(&index)]);
    assert_eq!(o.status.code(), Some(2));
}

/// An index whose profile was recorded before the landmark fronts and SMACOF's classical start
/// existed (its detection parameters lack those fields) keeps its own parameters: read back
/// as full fronts and four random starts, `index add` without options accepts it and leaves
/// its profile as recorded, and a query finds the indexed shape with score 1 (analysed as the
/// shape was).
#[test]
fn an_index_recorded_before_new_parameters_keeps_its_own() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (index, shape, other) = index_and_two_shapes(dir.path());
    let o = keycomp(&[
        "index",
        "add",
        s(&shape),
        "--index",
        s(&index),
        "--landmarks",
        "0",
        "--smacof-starts",
        "4",
        "--smacof-init",
        "random",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let reader =
        keycomp_index::IndexReader::<{ keycomp_describe::DIM }>::open(&index).expect("reader");
    let mut profile: Value = serde_json::from_str(reader.profile()).expect("profile");
    profile["detect"]["geodesic"]
        .as_object_mut()
        .expect("geodesic")
        .retain(|k, _| k != "landmarks" && k != "landmark_radius");
    profile["detect"]["components"]["smacof"]
        .as_object_mut()
        .expect("smacof")
        .remove("classical_start");
    let old_text = serde_json::to_string(&profile).expect("json");
    let records: Vec<_> = reader
        .shapes()
        .unwrap()
        .iter()
        .map(|sh| (*sh.record).clone())
        .collect();
    let old = dir.path().join("old");
    let mut w = keycomp_index::IndexWriter::<{ keycomp_describe::DIM }>::create_or_open(&old)
        .expect("writer");
    w.ensure_profile(&old_text).expect("profile");
    w.add_batch(records).expect("add");
    drop(w);

    let o = keycomp(&["index", "add", s(&other), "--index", s(&old), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let reader =
        keycomp_index::IndexReader::<{ keycomp_describe::DIM }>::open(&old).expect("reader");
    assert_eq!(reader.profile(), old_text);
    assert_eq!(reader.shapes().unwrap().len(), 2);
    let o = keycomp(&["query", s(&shape), "--index", s(&old), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).expect("json");
    assert!((v["results"][0]["score"].as_f64().expect("score") - 1.0).abs() < 1e-6);
}

/// In `dir`: the path of an index to create, a textured sphere and a torus (OFF files).
fn index_and_two_shapes(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let shape = dir.join("textured.off");
    write_off(&synth::textured_protrusion_sphere(6), &shape).expect("w");
    let other = dir.join("torus.off");
    write_off(&synth::torus(2.0, 0.5, 120, 60), &other).expect("w");
    (dir.join("idx"), shape, other)
}

/// The index records how its descriptors were made: a query without detection options uses
/// the index's parameters, contradicting options and adding with other parameters are refused
/// (exit 2, index unchanged), and a format-1 index (no profile) is refused for queries.
#[test]
fn index_profile_keeps_descriptors_comparable() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (index, shape, other) = index_and_two_shapes(dir.path());

    let o = keycomp(&[
        "index",
        "add",
        s(&shape),
        "--index",
        s(&index),
        "--preset",
        "kc2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let query = |extra: &[&str]| {
        let mut a = vec!["query", s(&shape), "--index", s(&index), "--json"];
        a.extend_from_slice(extra);
        keycomp(&a)
    };
    // no options: the index's KC-2 parameters, so the shape finds itself with score 1
    let plain = query(&[]);
    assert!(plain.status.success(), "{}", stderr(&plain));
    let v: Value = serde_json::from_slice(&plain.stdout).expect("json");
    assert!((v["results"][0]["score"].as_f64().expect("score") - 1.0).abs() < 1e-6);
    // the same parameters spelled out agree
    let same = query(&["--preset", "kc2"]);
    assert!(same.status.success(), "{}", stderr(&same));
    let w: Value = serde_json::from_slice(&same.stdout).expect("json");
    assert_eq!(v["results"], w["results"]);
    // other parameters are refused
    let o = query(&["--preset", "kc3"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("other detection parameters"),
        "{}",
        stderr(&o)
    );
    // adding with other parameters is refused and changes nothing
    let manifest = index.join("MANIFEST");
    let before = std::fs::read(&manifest).expect("manifest");
    let o = keycomp(&[
        "index",
        "add",
        s(&other),
        "--index",
        s(&index),
        "--preset",
        "kc3",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("made another way"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&manifest).expect("manifest"), before);
    // adding without options uses the index's parameters, as a query does
    let o = keycomp(&["index", "add", s(&other), "--index", s(&index), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let added: Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(added["added"], 1);

    // an index with shapes but no profile (as every format-1 index) is refused for queries
    let bare = dir.path().join("bare");
    let mut w = keycomp_index::IndexWriter::<{ keycomp_describe::DIM }>::create_or_open(&bare)
        .expect("writer");
    w.add_batch(keycomp_index::synthetic::records(3, 0..2))
        .expect("add");
    drop(w);
    let o = keycomp(&["query", s(&shape), "--index", s(&bare)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("has no profile"), "{}", stderr(&o));

    // an index of 32-value descriptors (descriptor version 2) is refused with what to do
    let old = dir.path().join("old");
    let mut w = keycomp_index::IndexWriter::<32>::create_or_open(&old).expect("writer");
    w.add_batch(keycomp_index::synthetic::records(3, 0..2))
        .expect("add");
    drop(w);
    for args in [
        vec!["query", s(&shape), "--index", s(&old)],
        vec!["index", "add", s(&other), "--index", s(&old)],
    ] {
        let o = keycomp(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let e = stderr(&o);
        assert!(e.contains("32 values") && e.contains("rebuild"), "{e}");
    }
}

/// `--units file` is recorded in the profile: later adds keep the index's unit, asking for
/// scale-free units there is refused, and queries use the index's unit.
#[test]
fn file_units_are_recorded_in_the_index() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (index, shape, other) = index_and_two_shapes(dir.path());
    let o = keycomp(&[
        "index",
        "add",
        s(&shape),
        "--index",
        s(&index),
        "--units",
        "file",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let profile = |i: &Path| -> Value {
        let r = keycomp_index::IndexReader::<{ keycomp_describe::DIM }>::open(i).expect("open");
        serde_json::from_str(r.profile()).expect("profile")
    };
    let units = profile(&index)["describe"]["units"].clone();
    assert_eq!(units["kind"], "file", "{units}");
    // the unit is the square root of the only shape's area
    let area = keycomp_mesh::geometry::total_area(&synth::textured_protrusion_sphere(6));
    assert!((units["length"].as_f64().expect("length") - area.sqrt()).abs() < 1e-9);
    let o = keycomp(&[
        "index",
        "add",
        s(&other),
        "--index",
        s(&index),
        "--units",
        "scale-free",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("file units"), "{}", stderr(&o));
    let o = keycomp(&["index", "add", s(&other), "--index", s(&index)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(profile(&index)["describe"]["units"], units);
    let o = keycomp(&["query", s(&shape), "--index", s(&index), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).expect("json");
    assert!((v["results"][0]["score"].as_f64().expect("score") - 1.0).abs() < 1e-6);
    assert_eq!(v["results"].as_array().expect("results").len(), 2);
}

/// An index of canonical surfaces (`--surface canonical`) takes a bare point cloud as a query
/// and finds the shape the points were taken from; the choice is recorded and another one is
/// refused; `keycomp surface` writes the surface it analyses.
#[test]
fn canonical_surfaces_take_point_clouds() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (index, shape, other) = index_and_two_shapes(dir.path());
    let o = keycomp(&[
        "index",
        "add",
        s(&shape),
        s(&other),
        "--index",
        s(&index),
        "--surface",
        "canonical",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // the sphere's vertices as points, without faces or normals
    let cloud = dir.path().join("points.xyz");
    let text: String = synth::textured_protrusion_sphere(6)
        .positions
        .iter()
        .map(|p| format!("{} {} {}\n", p.x, p.y, p.z))
        .collect();
    std::fs::write(&cloud, text).expect("w");
    let o = keycomp(&["query", s(&cloud), "--index", s(&index), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).expect("json");
    let first = v["results"][0]["path"].as_str().expect("path");
    assert!(first.ends_with("textured.off"), "{first}");
    // the index analyses canonical surfaces: meshes as read are refused, nothing added
    let o = keycomp(&[
        "index",
        "add",
        s(&cloud),
        "--index",
        s(&index),
        "--surface",
        "as-read",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("canonical surfaces"), "{}", stderr(&o));
    let o = keycomp(&["index", "stats", "--index", s(&index), "--json"]);
    let v: Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(v["shapes"], 2);
    // the surface itself: about the default 10,000 vertices, closed like the sphere
    let out = dir.path().join("surface.off");
    let o = keycomp(&["surface", s(&cloud), "-o", s(&out), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).expect("json");
    let n = v["vertices"].as_u64().expect("vertices");
    assert!((8_000..=12_000).contains(&n), "{n}");
    assert_eq!(v["boundary_vertices"], 0);
    assert!(read_mesh(&out).is_ok());
}
