//! Round trips through the on-disk index: add, reopen, get identical records; skip on the same
//! hash; replace on a changed hash; remove; compact; leftovers; the writer lock.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use std::path::Path;

use keycomp_index::{
    AddOutcome, IndexError, IndexReader, IndexWriter, ShapeRecord, synthetic, verify,
};

const D: usize = 16;

fn records(range: std::ops::Range<u64>) -> Vec<ShapeRecord<D>> {
    synthetic::records::<D>(7, range)
}

fn live_records(dir: &Path) -> Vec<ShapeRecord<D>> {
    let r = IndexReader::<D>::open(dir).unwrap();
    let mut v: Vec<_> = r
        .shapes()
        .unwrap()
        .iter()
        .map(|s| (*s.record).clone())
        .collect();
    v.sort_by(|a, b| a.canonical_path.cmp(&b.canonical_path));
    v
}

#[test]
fn add_reopen_get_identical_records() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("index");
    let mut w = IndexWriter::<D>::create_or_open(&dir).unwrap();
    let s1 = w.add_batch(records(0..20)).unwrap();
    assert_eq!((s1.added, s1.replaced, s1.skipped), (20, 0, 0));
    let s2 = w.add_batch(records(20..35)).unwrap();
    assert_eq!(s2.added, 15);
    assert_eq!(s2.generation, 2);
    drop(w);

    let r = IndexReader::<D>::open(&dir).unwrap();
    assert_eq!(r.shapes().unwrap().len(), 35);
    let expected = records(0..35);
    for (s, e) in r.shapes().unwrap().iter().zip(&expected) {
        assert_eq!(&*s.record, e);
        assert_eq!(r.get(s.id).unwrap().as_deref(), Some(e));
    }
    let st = r.stats();
    assert_eq!(st.shapes, 35);
    assert_eq!(st.segments, 2);
    assert_eq!(st.dim, D);
    assert_eq!(
        st.components,
        expected.iter().map(|r| r.components.len()).sum::<usize>()
    );
    assert!(r.find_path(&expected[4].canonical_path).unwrap().is_some());
    let rep = verify::<D>(&dir).unwrap();
    assert!(rep.is_ok(), "{:?}", rep.problems);
    assert!(rep.leftovers.is_empty());
    assert_eq!(rep.shapes, 35);
}

#[test]
fn same_hash_is_skipped_changed_hash_replaces() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let mut w = IndexWriter::<D>::create_or_open(dir).unwrap();
    w.add_batch(records(0..10)).unwrap();
    let gen_before = w.generation();

    // Same hashes: nothing written.
    let s = w.add_batch(records(3..6)).unwrap();
    assert_eq!((s.added, s.replaced, s.skipped), (0, 0, 3));
    assert!(s.segment.is_none());
    assert_eq!(w.generation(), gen_before);

    // Changed hash for 2 and 5, plus a new shape 10.
    let mut batch = vec![
        synthetic::record_version::<D>(7, 2, 1),
        synthetic::record_version::<D>(7, 5, 1),
        synthetic::record::<D>(7, 1),
    ];
    batch.push(synthetic::record::<D>(7, 10));
    let s = w.add_batch(batch).unwrap();
    assert_eq!((s.added, s.replaced, s.skipped), (1, 2, 1));
    assert!(matches!(s.outcomes[0], AddOutcome::Replaced { .. }));
    assert_eq!(s.outcomes[2], AddOutcome::Skipped);
    assert_eq!(w.len(), 11);
    drop(w);

    let got = live_records(dir);
    assert_eq!(got.len(), 11);
    let mut want = records(0..11);
    want[2] = synthetic::record_version::<D>(7, 2, 1);
    want[5] = synthetic::record_version::<D>(7, 5, 1);
    assert_eq!(got, want);
    let st = IndexReader::<D>::open(dir).unwrap().stats();
    assert_eq!(st.tombstones, 2);
}

#[test]
fn duplicate_path_in_one_batch_last_wins() {
    let tmp = tempfile::tempdir().unwrap();
    let mut w = IndexWriter::<D>::create_or_open(tmp.path()).unwrap();
    let batch = vec![
        synthetic::record_version::<D>(7, 0, 0),
        synthetic::record_version::<D>(7, 0, 1),
    ];
    let s = w.add_batch(batch).unwrap();
    assert_eq!((s.added, s.skipped), (1, 1));
    drop(w);
    assert_eq!(
        live_records(tmp.path()),
        vec![synthetic::record_version::<D>(7, 0, 1)]
    );
}

#[test]
fn remove_and_compact() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let mut w = IndexWriter::<D>::create_or_open(dir).unwrap();
    w.add_batch(records(0..5)).unwrap();
    w.add_batch(records(5..10)).unwrap();
    let recs = records(0..10);
    let n = w
        .remove(&[
            recs[1].canonical_path.clone(),
            recs[7].canonical_path.clone(),
            "/no/such/file.off".into(),
        ])
        .unwrap();
    assert_eq!(n, 2);
    assert_eq!(w.remove(&[recs[1].canonical_path.clone()]).unwrap(), 0);
    assert_eq!(live_records(dir).len(), 8);

    // Removing every shape of the first segment drops the segment and its file.
    let first: Vec<_> = [0, 2, 3, 4]
        .iter()
        .map(|&i| recs[i].canonical_path.clone())
        .collect();
    assert_eq!(w.remove(&first).unwrap(), 4);
    let r = IndexReader::<D>::open(dir).unwrap();
    assert_eq!(r.stats().segments, 1);
    assert_eq!(r.stats().tombstones, 1);
    assert!(!dir.join("seg-000000.kcs").exists());
    drop(r);

    w.compact(1000).unwrap();
    let r = IndexReader::<D>::open(dir).unwrap();
    assert_eq!(r.stats().tombstones, 0);
    assert_eq!(r.stats().segments, 1);
    let want: Vec<_> = [5, 6, 8, 9].iter().map(|&i| recs[i].clone()).collect();
    assert_eq!(live_records(dir), want);
    assert!(verify::<D>(dir).unwrap().is_ok());
    // Re-adding a removed shape works and gets a new id.
    let s = w.add_batch(vec![recs[1].clone()]).unwrap();
    assert_eq!(s.added, 1);
}

#[test]
fn leftovers_are_ignored_then_cleaned() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let mut w = IndexWriter::<D>::create_or_open(dir).unwrap();
    w.add_batch(records(0..3)).unwrap();
    drop(w);
    // What a killed add can leave behind.
    std::fs::write(dir.join("seg-000009.kcs"), b"half a segment").unwrap();
    std::fs::write(dir.join("seg-000001.kcs.tmp-123-0"), b"partial").unwrap();
    std::fs::write(dir.join("MANIFEST.tmp-123-1"), b"partial").unwrap();
    std::fs::write(dir.join("notes.txt"), b"not ours").unwrap();

    assert_eq!(live_records(dir).len(), 3);
    let rep = verify::<D>(dir).unwrap();
    assert!(rep.is_ok(), "{:?}", rep.problems);
    assert_eq!(rep.leftovers.len(), 3);

    let mut w = IndexWriter::<D>::create_or_open(dir).unwrap();
    w.add_batch(records(3..4)).unwrap();
    drop(w);
    let rep = verify::<D>(dir).unwrap();
    assert!(rep.leftovers.is_empty(), "{:?}", rep.leftovers);
    assert!(dir.join("notes.txt").exists());
    assert_eq!(live_records(dir).len(), 4);
}

#[test]
fn second_writer_is_locked_out() {
    let tmp = tempfile::tempdir().unwrap();
    let w = IndexWriter::<D>::create_or_open(tmp.path()).unwrap();
    let e = IndexWriter::<D>::try_create_or_open(tmp.path()).unwrap_err();
    assert!(matches!(e, IndexError::Locked { .. }), "{e}");
    assert!(e.to_string().contains("LOCK"));
    drop(w);
    IndexWriter::<D>::try_create_or_open(tmp.path()).unwrap();
}

#[test]
fn invalid_record_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let mut w = IndexWriter::<D>::create_or_open(tmp.path()).unwrap();
    let mut bad = records(0..3);
    bad[2].components[0].descriptor[0] = f32::INFINITY;
    let e = w.add_batch(bad).unwrap_err();
    assert!(matches!(e, IndexError::InvalidRecord { .. }));
    assert!(e.to_string().contains("shape-0000002"), "{e}");
    drop(w);
    assert_eq!(live_records(tmp.path()).len(), 0);
}

#[test]
fn empty_and_absent_indexes() {
    let tmp = tempfile::tempdir().unwrap();
    let e = IndexReader::<D>::open(tmp.path().join("nope")).unwrap_err();
    assert!(matches!(e, IndexError::NotAnIndex { .. }));
    assert!(e.to_string().contains("nope"));
    drop(IndexWriter::<D>::create_or_open(tmp.path().join("new")).unwrap());
    let r = IndexReader::<D>::open(tmp.path().join("new")).unwrap();
    assert!(r.shapes().unwrap().is_empty());
    assert!(r.nearest_components(&[0.5; D], 3).unwrap().is_empty());
}

#[test]
fn other_descriptor_length_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let mut w = IndexWriter::<D>::create_or_open(tmp.path()).unwrap();
    w.add_batch(records(0..2)).unwrap();
    drop(w);
    let e = IndexReader::<8>::open(tmp.path()).unwrap_err();
    assert!(
        matches!(
            e,
            IndexError::DimensionMismatch {
                found: 16,
                expected: 8,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("MANIFEST"));
    assert!(IndexWriter::<8>::create_or_open(tmp.path()).is_err());
}

#[test]
fn lost_manifest_is_not_overwritten() {
    let tmp = tempfile::tempdir().unwrap();
    let mut w = IndexWriter::<D>::create_or_open(tmp.path()).unwrap();
    w.add_batch(records(0..2)).unwrap();
    drop(w);
    std::fs::remove_file(tmp.path().join("MANIFEST")).unwrap();
    let e = IndexWriter::<D>::create_or_open(tmp.path()).unwrap_err();
    assert!(e.to_string().contains("MANIFEST"), "{e}");
    assert!(tmp.path().join("seg-000000.kcs").exists());
}

#[test]
fn remove_by_relative_path_of_a_deleted_file() {
    let tmp = tempfile::tempdir().unwrap();
    let mesh = tmp.path().join("a.off");
    std::fs::write(&mesh, b"OFF\n").unwrap();
    let mut r = synthetic::record::<D>(7, 0);
    r.path = mesh.clone();
    r.canonical_path = keycomp_index::canonical_path(&mesh);
    let mut w = IndexWriter::<D>::create_or_open(tmp.path().join("index")).unwrap();
    w.add_batch(vec![r]).unwrap();
    std::fs::remove_file(&mesh).unwrap();
    assert_eq!(w.remove(&[mesh]).unwrap(), 1);
}

/// A shape's descriptors read on their own are its record's, whether the segment is read
/// whole or memory-mapped (read in place), across segments and after a removal.
#[test]
fn descriptors_alone_are_the_records() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("index");
    let mut w = IndexWriter::<D>::create_or_open(&dir).unwrap();
    w.add_batch(records(0..12)).unwrap();
    w.add_batch(records(12..20)).unwrap();
    let gone = records(3..4).remove(0).canonical_path;
    assert_eq!(w.remove(&[gone]).unwrap(), 1);
    drop(w);
    for reader in [
        IndexReader::<D>::open(&dir).unwrap(),
        IndexReader::<D>::open_mapped(&dir).unwrap(),
    ] {
        assert_eq!(reader.len(), 19);
        for s in reader.shapes().unwrap() {
            let want: Vec<[f32; D]> = s.record.components.iter().map(|c| c.descriptor).collect();
            assert!(!want.is_empty());
            assert_eq!(
                reader.descriptors(s.id).unwrap().as_deref(),
                Some(&want[..])
            );
        }
        let absent = keycomp_index::ShapeId(reader.ids().max().unwrap().0 + 1);
        assert_eq!(reader.descriptors(absent).unwrap(), None);
    }
}
