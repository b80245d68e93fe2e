//! Every kind of damage gives its own clear error naming the file, and never a result.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use std::fs;
use std::path::{Path, PathBuf};

use keycomp_index::{
    CorruptKind, FOOTER_LEN, IndexError, IndexReader, IndexWriter, MANIFEST_NAME, synthetic, verify,
};

const D: usize = 8;

/// An index with two segments of 2 and 1 shapes and one tombstone.
fn build() -> (tempfile::TempDir, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("index");
    let mut w = IndexWriter::<D>::create_or_open(&dir).unwrap();
    w.add_batch(synthetic::records::<D>(1, 0..2)).unwrap();
    w.add_batch(synthetic::records::<D>(1, 2..4)).unwrap();
    w.remove(&[synthetic::record::<D>(1, 3).canonical_path])
        .unwrap();
    (tmp, dir)
}

fn seg(dir: &Path, n: u64) -> PathBuf {
    dir.join(format!("seg-{n:06}.kcs"))
}

fn open_err(dir: &Path) -> IndexError {
    IndexReader::<D>::open(dir).expect_err("a damaged index must not open")
}

/// Asserts that `e` is about `file` (in the variant and in the message).
fn names(e: &IndexError, file: &Path) {
    assert_eq!(e.path(), Some(file), "{e}");
    let name = file.file_name().unwrap().to_str().unwrap();
    assert!(
        e.to_string().contains(name),
        "message does not name {name}: {e}"
    );
}

/// Verify must report the same problem and modify nothing.
fn verify_reports(dir: &Path, file: &Path) {
    let before = snapshot(dir);
    let rep = verify::<D>(dir).unwrap();
    assert!(!rep.is_ok());
    assert!(
        rep.problems.iter().any(|p| p.path() == Some(file)),
        "{:?}",
        rep.problems
    );
    assert_eq!(before, snapshot(dir), "verify modified the index");
}

fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<_> = fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            let b = fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    v.sort();
    v
}

/// Rewrites a file's footer version and recomputes its checksum, as another keycomp release
/// would have written it.
fn set_version(path: &Path, version: u32) {
    let mut b = fs::read(path).unwrap();
    let f = b.len() - FOOTER_LEN;
    b[f + 12..f + 16].copy_from_slice(&version.to_le_bytes());
    let sum = xxhash_rust::xxh3::xxh3_64(&b[..f + 16]);
    b[f + 16..f + 24].copy_from_slice(&sum.to_le_bytes());
    fs::write(path, b).unwrap();
}

#[test]
fn healthy_fixture_opens() {
    let (_t, dir) = build();
    assert_eq!(
        IndexReader::<D>::open(&dir)
            .unwrap()
            .shapes()
            .unwrap()
            .len(),
        3
    );
    assert!(verify::<D>(&dir).unwrap().is_ok());
}

#[test]
fn truncated_segment() {
    for cut in [1usize, FOOTER_LEN, 100] {
        let (_t, dir) = build();
        let p = seg(&dir, 0);
        let b = fs::read(&p).unwrap();
        fs::write(&p, &b[..b.len() - cut]).unwrap();
        let e = open_err(&dir);
        assert!(matches!(e, IndexError::Corrupt { .. }), "{e}");
        assert!(e.to_string().contains("is corrupt"), "{e}");
        names(&e, &p);
        verify_reports(&dir, &p);
    }
}

#[test]
fn truncated_manifest() {
    let (_t, dir) = build();
    let p = dir.join(MANIFEST_NAME);
    let b = fs::read(&p).unwrap();
    fs::write(&p, &b[..b.len() / 2]).unwrap();
    let e = open_err(&dir);
    assert!(matches!(e, IndexError::Corrupt { .. }), "{e}");
    names(&e, &p);
    verify_reports(&dir, &p);
    // A writer refuses it too.
    assert!(IndexWriter::<D>::create_or_open(&dir).is_err());
}

#[test]
fn flipped_byte_anywhere_in_a_segment() {
    let (_t, dir) = build();
    let p = seg(&dir, 1);
    let good = fs::read(&p).unwrap();
    for i in 0..good.len() {
        let mut b = good.clone();
        b[i] ^= 0x10;
        fs::write(&p, &b).unwrap();
        let e = open_err(&dir);
        match &e {
            IndexError::Corrupt { kind, .. } => {
                // In the checksum field the footer and contents disagree; elsewhere too.
                assert!(
                    matches!(
                        kind,
                        CorruptKind::ChecksumMismatch { .. } | CorruptKind::BadMagic
                    ),
                    "byte {i}: {e}"
                );
            }
            _ => panic!("byte {i}: expected Corrupt, got {e}"),
        }
        names(&e, &p);
    }
    fs::write(&p, &good).unwrap();
    assert!(IndexReader::<D>::open(&dir).is_ok());
}

#[test]
fn flipped_byte_anywhere_in_the_manifest() {
    let (_t, dir) = build();
    let p = dir.join(MANIFEST_NAME);
    let good = fs::read(&p).unwrap();
    for i in 0..good.len() {
        let mut b = good.clone();
        b[i] ^= 0x01;
        fs::write(&p, &b).unwrap();
        let e = open_err(&dir);
        assert!(matches!(e, IndexError::Corrupt { .. }), "byte {i}: {e}");
        names(&e, &p);
    }
    // Flipping a footer byte is reported as checksum damage, not as another version.
    let mut b = good.clone();
    let f = b.len() - FOOTER_LEN;
    b[f + 12] ^= 0x02;
    fs::write(&p, &b).unwrap();
    let e = open_err(&dir);
    assert!(e.to_string().contains("checksum mismatch"), "{e}");
}

#[test]
fn missing_segment_file() {
    let (_t, dir) = build();
    let p = seg(&dir, 0);
    fs::remove_file(&p).unwrap();
    let e = open_err(&dir);
    assert!(matches!(e, IndexError::MissingSegment { .. }), "{e}");
    names(&e, &p);
    assert!(e.to_string().contains("MANIFEST"), "{e}");
    verify_reports(&dir, &p);
    assert!(matches!(
        IndexWriter::<D>::create_or_open(&dir),
        Err(IndexError::MissingSegment { .. })
    ));
}

#[test]
fn newer_format_version_is_incompatible() {
    let (_t, dir) = build();
    let p = dir.join(MANIFEST_NAME);
    let newer = keycomp_index::FORMAT_VERSION + 1;
    set_version(&p, newer);
    let e = open_err(&dir);
    assert!(
        matches!(
            e,
            IndexError::Incompatible {
                found,
                supported: keycomp_index::FORMAT_VERSION,
                ..
            } if found == newer
        ),
        "{e}"
    );
    names(&e, &p);
    let msg = e.to_string();
    assert!(
        msg.contains(&format!(
            "incompatible: format version {newer}, this keycomp reads versions 1 to {}",
            keycomp_index::FORMAT_VERSION
        )),
        "{msg}"
    );
    assert!(msg.contains("upgrade keycomp"), "{msg}");
    verify_reports(&dir, &p);
}

#[test]
fn segment_of_another_version_is_incompatible() {
    let (_t, dir) = build();
    let p = seg(&dir, 1);
    set_version(&p, 0);
    let e = open_err(&dir);
    assert!(
        matches!(e, IndexError::Incompatible { found: 0, .. }),
        "{e}"
    );
    names(&e, &p);
    assert!(e.to_string().contains("rebuild the index"), "{e}");
}

#[test]
fn garbage_manifest() {
    let (_t, dir) = build();
    let p = dir.join(MANIFEST_NAME);
    fs::write(&p, b"this is not a manifest at all, just some text\n").unwrap();
    let e = open_err(&dir);
    assert!(
        matches!(
            e,
            IndexError::Corrupt {
                kind: CorruptKind::BadMagic,
                ..
            }
        ),
        "{e}"
    );
    names(&e, &p);
    verify_reports(&dir, &p);

    // Garbage inside a valid footer: the contents do not decode.
    let mut payload = vec![0xffu8; 40];
    payload.extend_from_slice(&(40u64).to_le_bytes());
    payload.extend_from_slice(&1u32.to_le_bytes());
    payload.extend_from_slice(&1u32.to_le_bytes());
    let sum = xxhash_rust::xxh3::xxh3_64(&payload);
    payload.extend_from_slice(&sum.to_le_bytes());
    payload.extend_from_slice(b"KCIDXEND");
    fs::write(&p, &payload).unwrap();
    let e = open_err(&dir);
    assert!(
        matches!(
            e,
            IndexError::Corrupt {
                kind: CorruptKind::Malformed(_),
                ..
            }
        ),
        "{e}"
    );
    names(&e, &p);
}

#[test]
fn empty_files() {
    let (_t, dir) = build();
    let m = dir.join(MANIFEST_NAME);
    let good = fs::read(&m).unwrap();
    fs::write(&m, b"").unwrap();
    let e = open_err(&dir);
    assert!(
        matches!(
            e,
            IndexError::Corrupt {
                kind: CorruptKind::Empty,
                ..
            }
        ),
        "{e}"
    );
    names(&e, &m);
    assert!(e.to_string().contains("empty"), "{e}");
    fs::write(&m, good).unwrap();

    let p = seg(&dir, 0);
    fs::write(&p, b"").unwrap();
    let e = open_err(&dir);
    assert!(
        matches!(
            e,
            IndexError::Corrupt {
                kind: CorruptKind::Empty,
                ..
            }
        ),
        "{e}"
    );
    names(&e, &p);
    verify_reports(&dir, &p);
}

#[test]
fn segment_swapped_for_another_intact_segment() {
    let (_t, dir) = build();
    fs::copy(seg(&dir, 1), seg(&dir, 0)).unwrap();
    let e = open_err(&dir);
    assert!(matches!(e, IndexError::Corrupt { .. }), "{e}");
    names(&e, &seg(&dir, 0));
}

/// A memory-mapped reader checks each record when it reads it: a flipped byte anywhere in a
/// segment is an error naming the file at open (footer, table), at the first read of the
/// record or head it falls in, or it falls where nothing is read (the zeros before the
/// descriptor block); never a record that differs from the one written.
#[test]
fn flipped_byte_is_caught_by_a_mapped_reader_where_it_reads() {
    let (_t, dir) = build();
    let want: Vec<_> = IndexReader::<D>::open(&dir).unwrap().shapes().unwrap();
    // segment 0: both its shapes are live (segment 1 holds the removed one)
    let p = seg(&dir, 0);
    let good = fs::read(&p).unwrap();
    let mut unread = 0;
    for i in 0..good.len() {
        let mut b = good.clone();
        b[i] ^= 0x10;
        fs::write(&p, &b).unwrap();
        let e = match IndexReader::<D>::open_mapped(&dir) {
            Err(e) => e,
            Ok(r) => {
                let shapes = r.shapes();
                match shapes.and_then(|s| r.find_path(Path::new("/nowhere")).map(|_| s)) {
                    Err(e) => e,
                    Ok(s) => {
                        assert_eq!(s, want, "byte {i} changed a record silently");
                        unread += 1;
                        continue;
                    }
                }
            }
        };
        assert!(matches!(e, IndexError::Corrupt { .. }), "byte {i}: {e}");
        names(&e, &p);
    }
    fs::write(&p, &good).unwrap();
    assert!(unread < 8, "{unread} bytes were never read");
}
