//! End-to-end: the library's operations give what the command line prints. An index built
//! with `keycomp::collection::add` answers `keycomp query --json` exactly as the library's
//! `Searcher` does, and `keycomp::matching::match_files` equals `keycomp match --json`, apart
//! from timings.

mod common;

use std::path::PathBuf;

use keycomp::collection::{self, AddOptions};
use keycomp::matching::{MatchOptions, match_files};
use keycomp::search::{QueryResult, Searcher};
use keycomp_mesh::{synth, write_off};
use serde_json::Value;

use common::{keycomp, s, stderr};

/// `value` as the command line prints it (f32 distances written in their shortest form), read
/// back.
fn printed(value: &impl serde::Serialize) -> Value {
    serde_json::from_str(&serde_json::to_string(value).expect("JSON")).expect("JSON")
}

fn without_timings(mut v: Value) -> Value {
    v.as_object_mut().expect("object").remove("timings_ms");
    v
}

#[test]
fn library_and_command_line_agree() {
    let dir = tempfile::tempdir().expect("tempdir");
    let shapes = dir.path().join("shapes");
    std::fs::create_dir(&shapes).expect("mkdir");
    let meshes = [
        ("bumps.off", synth::textured_protrusion_sphere(4)),
        ("spikes.off", synth::protrusion_sphere(4, 0.8, 0.25)),
        ("ring.off", synth::torus(1.0, 0.35, 48, 24)),
    ];
    for (name, m) in &meshes {
        write_off(m, &shapes.join(name)).expect("write");
    }
    let index = dir.path().join("index");
    let options = AddOptions {
        keep_going: true,
        ..AddOptions::default()
    };
    let added = collection::add(&index, std::slice::from_ref(&shapes), &options, &()).expect("add");
    assert_eq!((added.added, added.shapes), (3, 3), "{added:?}");
    assert!(added.failed.is_empty());

    // the command line sees the library's index as its own: adding again changes nothing
    let o = keycomp(&["index", "add", s(&shapes), "--index", s(&index), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cli: collection::AddSummary = serde_json::from_slice(&o.stdout).expect("JSON");
    assert_eq!((cli.added, cli.unchanged, cli.shapes), (0, 3, 3));

    let query: PathBuf = shapes.join("spikes.off");
    let searcher = Searcher::open(&index, None).expect("open");
    let lib = searcher.query(&query, 10).expect("query");
    assert_eq!(lib.results.len(), 3);
    assert_eq!(lib.results[0].path, query.display().to_string());
    let o = keycomp(&["query", s(&query), "--index", s(&index), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cli: Value = serde_json::from_slice(&o.stdout).expect("JSON");
    // the printed JSON is the library's type
    let typed: QueryResult = serde_json::from_value(cli.clone()).expect("QueryResult");
    assert_eq!(typed.results, lib.results);
    assert_eq!(without_timings(cli), without_timings(printed(&lib)));
    // verification forced on for a closed query: the library and the command line agree
    let mut verified = Searcher::open(&index, None).expect("open");
    verified.set_verify_weight(Some(0.5)).expect("a weight");
    let lib_v = verified.query(&query, 10).expect("query");
    assert_eq!(lib_v.results[0].path, query.display().to_string());
    let o = keycomp(&[
        "query",
        s(&query),
        "--index",
        s(&index),
        "--json",
        "--verify",
        "0.5",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cli: Value = serde_json::from_slice(&o.stdout).expect("JSON");
    assert_eq!(without_timings(cli), without_timings(printed(&lib_v)));
    assert!(verified.set_verify_weight(Some(1.5)).is_err());
    let o = keycomp(&["query", s(&query), "--index", s(&index), "--verify", "2"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));

    let (a, b) = (shapes.join("bumps.off"), shapes.join("ring.off"));
    let (_, _, m) = match_files(&a, &b, &MatchOptions::default()).expect("match");
    let o = keycomp(&["match", s(&a), s(&b), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cli: Value = serde_json::from_slice(&o.stdout).expect("JSON");
    assert_eq!(without_timings(cli), without_timings(printed(&m)));

    let r = collection::remove(&index, &[query]).expect("remove");
    assert_eq!((r.removed, r.shapes), (1, 2));
}
