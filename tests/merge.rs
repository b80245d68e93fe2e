//! End-to-end: `keycomp index merge` of shards gives the records and the query results of one
//! `keycomp index add` of the same files.

mod common;

use std::path::Path;

use keycomp_mesh::{synth, write_off};
use serde_json::Value;

use common::{keycomp, s, stderr, stdout};

fn run(args: &[&str]) -> String {
    let o = keycomp(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    stdout(&o)
}

/// (path, hash, vertices, components) of every indexed shape, sorted.
fn records(index: &Path) -> Vec<(String, String, u64, u64)> {
    let v: Value = serde_json::from_str(&run(&["index", "list", "--index", s(index), "--json"]))
        .expect("JSON");
    let mut rows: Vec<_> = v
        .as_array()
        .expect("array")
        .iter()
        .map(|r| {
            (
                r["path"].as_str().expect("path").to_string(),
                r["hash"].as_str().expect("hash").to_string(),
                r["vertices"].as_u64().expect("vertices"),
                r["components"].as_u64().expect("components"),
            )
        })
        .collect();
    rows.sort();
    rows
}

/// (score, path) of every result of querying `mesh`, best first; shapes of equal score (the
/// ranking orders them by their id in the index, which a merge may change) by path.
fn results(index: &Path, mesh: &Path) -> Vec<(String, String)> {
    let v: Value = serde_json::from_str(&run(&["query", s(mesh), "--index", s(index), "--json"]))
        .expect("JSON");
    let mut rows: Vec<(f64, String)> = v["results"]
        .as_array()
        .expect("results")
        .iter()
        .map(|r| {
            (
                r["score"].as_f64().expect("score"),
                r["path"].as_str().expect("path").to_string(),
            )
        })
        .collect();
    let scores: Vec<f64> = rows.iter().map(|r| r.0).collect();
    assert!(scores.windows(2).all(|w| w[0] >= w[1]), "{scores:?}");
    rows.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    rows.into_iter()
        .map(|(score, path)| (format!("{score:.6}"), path))
        .collect()
}

#[test]
fn merged_shards_equal_one_index_of_all_files() {
    let dir = tempfile::tempdir().expect("tempdir");
    let shapes = dir.path().join("shapes");
    std::fs::create_dir(&shapes).expect("mkdir");
    let meshes = [
        ("a.off", synth::protrusion_sphere(3, 0.8, 0.25)),
        ("b.off", synth::icosphere(3, 1.0)),
        ("c.off", synth::torus(1.0, 0.35, 40, 20)),
        ("d.off", synth::textured_protrusion_sphere(3)),
    ];
    for (name, m) in &meshes {
        write_off(m, &shapes.join(name)).expect("write");
    }
    let f = |n: &str| shapes.join(n);
    let (all, s0, s1, merged) = (
        dir.path().join("all"),
        dir.path().join("shard0"),
        dir.path().join("shard1"),
        dir.path().join("merged"),
    );
    run(&["index", "add", s(&shapes), "--index", s(&all)]);
    // the shards overlap on c.off
    run(&[
        "index",
        "add",
        s(&f("a.off")),
        s(&f("c.off")),
        "--index",
        s(&s0),
    ]);
    run(&[
        "index",
        "add",
        s(&f("b.off")),
        s(&f("c.off")),
        s(&f("d.off")),
        "--index",
        s(&s1),
    ]);
    let out = run(&["index", "merge", s(&s0), s(&s1), "--index", s(&merged)]);
    assert!(
        out.contains("5 shapes read, 4 added, 1 already there"),
        "{out}"
    );
    assert_eq!(records(&merged), records(&all));
    for (name, _) in &meshes {
        assert_eq!(
            results(&merged, &f(name)),
            results(&all, &f(name)),
            "{name}"
        );
    }
    let o = keycomp(&["index", "verify", "--index", s(&merged)]);
    assert!(o.status.success(), "{}", stdout(&o));

    // a shard made with other parameters is refused, naming it; nothing changes
    let other = dir.path().join("other");
    run(&[
        "index",
        "add",
        s(&f("a.off")),
        "--index",
        s(&other),
        "--units",
        "file",
    ]);
    let before = records(&merged);
    let o = keycomp(&["index", "merge", s(&other), "--index", s(&merged)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("other") && stderr(&o).contains("profiles differ"),
        "{}",
        stderr(&o)
    );
    assert_eq!(records(&merged), before);
}
