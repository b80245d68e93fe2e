//! Indexes written by released format versions still open and read the same.
//!
//! `tests/fixtures/vN/` was written by format version N (D = 8, synthetic seed 21: shapes
//! 0..4 in two segments, shape 1 removed; from version 2 on, with the profile
//! [`FIXTURE_PROFILE`]); `tests/fixtures/vN.json` holds the live records it must decode to (JSON, so the check does not depend on the random generator staying the
//! same). Write a new version's fixture with
//! `cargo test -p keycomp-index --test fixture -- --ignored write_fixture`; never rewrite an
//! old one.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use std::path::PathBuf;

use keycomp_index::{IndexReader, IndexWriter, ShapeRecord, synthetic, verify};

const D: usize = 8;

/// The profile of the version-2 fixture.
const FIXTURE_PROFILE: &str = "fixture: synthetic records, seed 21";

fn fixture(version: u32) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("tests/fixtures/v{version}"))
}

/// Opens the fixture of format `version`, checks that it reads to its JSON records, holds two
/// segments and verifies clean; returns the reader and the records.
fn open_fixture(version: u32) -> (IndexReader<D>, Vec<ShapeRecord<D>>) {
    let dir = fixture(version);
    let r = IndexReader::<D>::open(&dir).unwrap();
    let json = std::fs::read_to_string(dir.with_extension("json")).unwrap();
    let want: Vec<ShapeRecord<D>> = serde_json::from_str(&json).unwrap();
    let got: Vec<_> = r
        .shapes()
        .unwrap()
        .iter()
        .map(|s| (*s.record).clone())
        .collect();
    assert_eq!(got, want, "format {version}");
    assert_eq!(r.stats().segments, 2);
    assert!(verify::<D>(&dir).unwrap().is_ok());
    (r, got)
}

#[test]
fn format_v1_fixture_still_opens() {
    let (r, got) = open_fixture(1);
    assert_eq!(r.profile(), "", "format 1 has no profile");
    assert_eq!(got.len(), 3);
    assert_eq!(r.stats().tombstones, 1);
}

#[test]
fn format_v2_fixture_still_opens() {
    let (r, _) = open_fixture(2);
    assert_eq!(r.profile(), FIXTURE_PROFILE);
}

#[test]
fn format_v3_fixture_still_opens() {
    let (r, got) = open_fixture(3);
    assert_eq!(r.profile(), FIXTURE_PROFILE);
    assert!(
        got.iter()
            .all(|s| s.components.iter().all(|c| c.centre.is_some())),
        "format 3 stores every part's centre"
    );
}

#[test]
fn format_v4_fixture_still_opens() {
    let (r, got) = open_fixture(4);
    assert_eq!(r.profile(), FIXTURE_PROFILE);
    assert!(
        got.iter().all(|s| !s.sample.is_empty()),
        "format 4 stores every shape's surface sample"
    );
    assert!(got.iter().any(|s| s.boundary_vertices > 0));
}

/// Formats 1 to 3 stored no surface sample and no boundary count: their records read with
/// none.
#[test]
fn older_formats_read_without_samples() {
    for v in 1..=3 {
        let r = IndexReader::<D>::open(fixture(v)).unwrap();
        assert!(
            r.shapes()
                .unwrap()
                .iter()
                .all(|s| s.record.sample.is_empty() && s.record.boundary_vertices == 0),
            "format {v}"
        );
    }
}

/// Formats 1 and 2 stored no centre positions: their records read with none, and an add to a
/// version-2 index writes a segment of the current version beside the old ones, both read
/// back.
#[test]
fn older_formats_read_without_centres_and_take_new_segments() {
    for v in [1, 2] {
        let r = IndexReader::<D>::open(fixture(v)).unwrap();
        assert!(
            r.shapes().unwrap().iter().all(|s| s
                .record
                .components
                .iter()
                .all(|c| c.centre.is_none())),
            "format {v}"
        );
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("v2");
    std::fs::create_dir(&dir).unwrap();
    for e in std::fs::read_dir(fixture(2)).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.join(e.file_name())).unwrap();
    }
    let mut w = IndexWriter::<D>::create_or_open(&dir).unwrap();
    w.ensure_profile(FIXTURE_PROFILE).unwrap();
    w.add_batch(synthetic::records::<D>(21, 10..12)).unwrap();
    drop(w);
    let r = IndexReader::<D>::open(&dir).unwrap();
    assert_eq!(r.shapes().unwrap().len(), 5);
    let with_centres = r
        .shapes()
        .unwrap()
        .iter()
        .filter(|s| s.record.components.iter().all(|c| c.centre.is_some()))
        .count();
    assert_eq!(with_centres, 2);
    assert!(verify::<D>(&dir).unwrap().is_ok());
}

/// A format-1 index with shapes has no profile: adding to it under a profile is refused and
/// leaves it untouched; removing from it still works and rewrites it in the current format,
/// keeping the (empty) profile.
#[test]
fn format_v1_index_refuses_a_profile_but_stays_usable() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("v1");
    std::fs::create_dir(&dir).unwrap();
    for e in std::fs::read_dir(fixture(1)).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.join(e.file_name())).unwrap();
    }
    let before = std::fs::read(dir.join(keycomp_index::MANIFEST_NAME)).unwrap();
    let mut w = IndexWriter::<D>::create_or_open(&dir).unwrap();
    let e = w.ensure_profile("kc1").unwrap_err();
    assert!(
        matches!(&e, keycomp_index::IndexError::ProfileMismatch { found, .. } if found.is_empty()),
        "{e}"
    );
    assert!(e.to_string().contains("older keycomp"), "{e}");
    assert!(e.to_string().contains("Rebuild"), "{e}");
    assert_eq!(
        std::fs::read(dir.join(keycomp_index::MANIFEST_NAME)).unwrap(),
        before
    );
    w.remove(&[synthetic::record::<D>(21, 0).canonical_path])
        .unwrap();
    drop(w);
    let r = IndexReader::<D>::open(&dir).unwrap();
    assert_eq!(r.shapes().unwrap().len(), 2);
    assert_eq!(r.profile(), "");
}

#[test]
#[ignore = "writes the current version's fixture into the source tree"]
fn write_fixture() {
    let dir = fixture(keycomp_index::FORMAT_VERSION);
    let _ = std::fs::remove_dir_all(&dir);
    let mut w = IndexWriter::<D>::create_or_open(&dir).unwrap();
    w.ensure_profile(FIXTURE_PROFILE).unwrap();
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

#[test]
fn format_v5_fixture_still_opens() {
    let (r, got) = open_fixture(5);
    assert_eq!(r.profile(), FIXTURE_PROFILE);
    // memory-mapped, the same records
    let mapped = IndexReader::<D>::open_mapped(fixture(5)).unwrap();
    let lazy: Vec<_> = mapped
        .shapes()
        .unwrap()
        .into_iter()
        .map(|s| (*s.record).clone())
        .collect();
    assert_eq!(lazy, got);
}

/// Older formats open memory-mapped too (their segments are read whole).
#[test]
fn older_formats_open_mapped() {
    for version in 1..5 {
        let (_, got) = open_fixture(version);
        let mapped = IndexReader::<D>::open_mapped(fixture(version)).unwrap();
        let lazy: Vec<_> = mapped
            .shapes()
            .unwrap()
            .into_iter()
            .map(|s| (*s.record).clone())
            .collect();
        assert_eq!(lazy, got, "format {version}");
    }
}
