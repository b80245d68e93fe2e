//! `IndexWriter::merge`: shards built apart merge into one index with every shape once, in one
//! commit; conflicts and profile mismatches are refused with nothing written.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use std::path::Path;

use keycomp_index::{IndexError, IndexReader, IndexWriter, ShapeRecord, synthetic, verify};

const D: usize = 8;

fn index(dir: &Path, profile: &str, records: Vec<ShapeRecord<D>>) -> IndexReader<D> {
    let mut w = IndexWriter::<D>::create_or_open(dir).unwrap();
    w.ensure_profile(profile).unwrap();
    w.add_batch(records).unwrap();
    drop(w);
    IndexReader::open(dir).unwrap()
}

fn sorted(r: &IndexReader<D>) -> Vec<ShapeRecord<D>> {
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
fn shards_merge_into_the_union() {
    let tmp = tempfile::tempdir().unwrap();
    let a = index(&tmp.path().join("a"), "p", synthetic::records(1, 0..5));
    // shard b overlaps shard a on shapes 3 and 4 (same contents)
    let b = index(&tmp.path().join("b"), "p", synthetic::records(1, 3..9));
    let whole = index(&tmp.path().join("whole"), "p", synthetic::records(1, 0..9));
    let dst = tmp.path().join("merged");
    let mut w = IndexWriter::<D>::create_or_open(&dst).unwrap();
    let s = w.merge(&[a, b]).unwrap();
    assert_eq!((s.read, s.added, s.duplicates), (11, 9, 2));
    drop(w);
    let merged = IndexReader::<D>::open(&dst).unwrap();
    assert_eq!(merged.profile(), "p");
    assert_eq!(sorted(&merged), sorted(&whole));
    assert!(verify::<D>(&dst).unwrap().is_ok());
    // merging the same shards again changes nothing
    let a = IndexReader::<D>::open(tmp.path().join("a")).unwrap();
    let mut w = IndexWriter::<D>::create_or_open(&dst).unwrap();
    let s = w.merge(&[a]).unwrap();
    assert_eq!((s.added, s.duplicates), (0, 5));
    assert_eq!(s.generation, merged.generation());
}

#[test]
fn conflicts_and_other_profiles_are_refused_and_nothing_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let a = index(&tmp.path().join("a"), "p", synthetic::records(1, 0..3));
    // the same path with other contents
    let edited = vec![synthetic::record_version::<D>(1, 2, 1)];
    let b = index(&tmp.path().join("b"), "p", edited);
    let dst = tmp.path().join("merged");
    let mut w = IndexWriter::<D>::create_or_open(&dst).unwrap();
    let e = w.merge(&[a, b]).unwrap_err();
    assert!(matches!(e, IndexError::MergeConflict { .. }), "{e}");
    let msg = e.to_string();
    assert!(
        msg.contains("shape-0000002.off") && msg.contains("/a") && msg.contains("/b"),
        "{msg}"
    );
    assert_eq!(w.len(), 0);
    assert_eq!(w.generation(), 0, "nothing was committed");

    let c = index(
        &tmp.path().join("c"),
        r#"{"v":3,"k":1}"#,
        synthetic::records(2, 0..2),
    );
    let d = index(
        &tmp.path().join("d"),
        r#"{"v":3,"k":2}"#,
        synthetic::records(3, 0..2),
    );
    let e = w.merge(&[c, d]).unwrap_err();
    assert!(matches!(e, IndexError::MergeProfile { .. }), "{e}");
    assert!(e.to_string().contains("k: 1 vs 2"), "{e}");
    assert_eq!(w.len(), 0);
}
