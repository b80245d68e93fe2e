//! Indexes written by released format versions still open and read the same.
//!
//! `tests/fixtures/v1/` was written by format version 1 (D = 8, synthetic seed 21: shapes
//! 0..4 in two segments, shape 1 removed); `tests/fixtures/v1.json` holds the live records it
//! must decode to (JSON, so the check does not depend on the random generator staying the
//! same). Write a new version's fixture with
//! `cargo test -p keycomp-index --test fixture -- --ignored write_fixture`; never rewrite an
//! old one.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use std::path::PathBuf;

use keycomp_index::{IndexReader, IndexWriter, ShapeRecord, synthetic, verify};

const D: usize = 8;

fn fixture(version: u32) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("tests/fixtures/v{version}"))
}

#[test]
fn format_v1_fixture_still_opens() {
    let dir = fixture(1);
    let r = IndexReader::<D>::open(&dir).unwrap();
    let json = std::fs::read_to_string(fixture(1).with_extension("json")).unwrap();
    let want: Vec<ShapeRecord<D>> = serde_json::from_str(&json).unwrap();
    assert_eq!(want.len(), 3);
    let got: Vec<_> = r.shapes().iter().map(|s| s.record.clone()).collect();
    assert_eq!(got, want);
    assert_eq!(r.stats().segments, 2);
    assert_eq!(r.stats().tombstones, 1);
    assert!(verify::<D>(&dir).unwrap().is_ok());
}

#[test]
#[ignore = "writes the current version's fixture into the source tree"]
fn write_fixture() {
    let dir = fixture(keycomp_index::FORMAT_VERSION);
    let _ = std::fs::remove_dir_all(&dir);
    let mut w = IndexWriter::<D>::create_or_open(&dir).unwrap();
    w.add_batch(synthetic::records::<D>(21, 0..2)).unwrap();
    w.add_batch(synthetic::records::<D>(21, 2..4)).unwrap();
    w.remove(&[synthetic::record::<D>(21, 1).canonical_path])
        .unwrap();
    drop(w);
    std::fs::remove_file(dir.join(keycomp_index::LOCK_NAME)).unwrap();
    let live: Vec<_> = [0u64, 2, 3]
        .iter()
        .map(|&i| synthetic::record::<D>(21, i))
        .collect();
    let json = serde_json::to_string_pretty(&live).unwrap();
    std::fs::write(dir.with_extension("json"), json + "\n").unwrap();
}
