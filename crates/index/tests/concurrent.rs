//! Readers open and query while a writer adds, replaces and compacts: every open succeeds
//! and sees a consistent snapshot (whole batches, records identical to what was written), and
//! `verify` running meanwhile reports no damage.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use keycomp_index::{IndexReader, IndexWriter, synthetic, verify};

const D: usize = 8;
const SEED: u64 = 5;
const BATCH: u64 = 16;
const BATCHES: u64 = 60;

#[test]
fn readers_see_consistent_snapshots_during_add() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("index");
    let mut w = IndexWriter::<D>::create_or_open(&dir).unwrap();
    w.add_batch(synthetic::records::<D>(SEED, 0..BATCH))
        .unwrap();
    let done = Arc::new(AtomicBool::new(false));

    let readers: Vec<_> = (0..2)
        .map(|t| {
            let dir = dir.clone();
            let done = done.clone();
            std::thread::spawn(move || {
                let mut opens = 0u64;
                let mut last_gen = 0;
                let mut last_n = 0;
                loop {
                    let finished = done.load(Ordering::SeqCst);
                    let r = IndexReader::<D>::open(&dir)
                        .unwrap_or_else(|e| panic!("reader {t}: open failed: {e}"));
                    opens += 1;
                    let n = r.shapes().unwrap().len() as u64;
                    assert_eq!(n % BATCH, 0, "partial batch visible");
                    assert!(r.generation() >= last_gen, "generation went back");
                    assert!(n >= last_n, "shapes went back");
                    last_gen = r.generation();
                    last_n = n;
                    for (i, s) in r.shapes().unwrap().iter().enumerate() {
                        assert_eq!(*s.record, synthetic::record::<D>(SEED, i as u64));
                    }
                    let q = r.shapes().unwrap()[0].record.components[1].descriptor;
                    let hits = r.nearest_components(&q, 10).unwrap();
                    let scan = r.nearest_linear(&q, 10);
                    assert_eq!(hits, scan);
                    assert_eq!(hits[0].distance_sq, 0.0);
                    if finished {
                        return (opens, n);
                    }
                }
            })
        })
        .collect();

    let verifier = {
        let dir = dir.clone();
        let done = done.clone();
        std::thread::spawn(move || {
            let mut runs = 0u64;
            while !done.load(Ordering::SeqCst) {
                let report = verify::<D>(&dir).unwrap();
                assert!(report.is_ok(), "verify found damage: {:?}", report.problems);
                runs += 1;
            }
            runs
        })
    };

    for b in 1..BATCHES {
        w.add_batch(synthetic::records::<D>(SEED, b * BATCH..(b + 1) * BATCH))
            .unwrap();
        if b % 3 == 0 {
            // Compaction deletes the old segments under the readers' feet.
            w.compact(100).unwrap();
        }
    }
    done.store(true, Ordering::SeqCst);
    eprintln!("verify: {} runs", verifier.join().unwrap());
    for h in readers {
        let (opens, n) = h.join().unwrap();
        assert!(opens > 0);
        assert_eq!(n, BATCH * BATCHES, "last snapshot misses shapes");
        eprintln!("reader: {opens} opens");
    }
}
