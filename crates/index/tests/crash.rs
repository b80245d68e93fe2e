//! A writer process killed (SIGKILL) at random moments of `add_batch` leaves an index that
//! opens, verifies, and holds exactly a prefix of what was added, whole batches only. The
//! writer process is this test binary run again with only its [`writer`] test.

#![allow(clippy::unwrap_used)] // helpers outside #[test] fns, in a test crate

use std::io::{Read, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use keycomp_index::{IndexReader, IndexWriter, synthetic, verify};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const D: usize = 32;
const SEED: u64 = 11;
const BATCH: u64 = 8;
const KILLS: usize = 20;
/// The environment variable naming the index folder of the [`writer`] process.
const WRITER_DIR: &str = "KEYCOMP_INDEX_CRASH_WRITER_DIR";
/// Shapes after which the [`writer`] stops, should it not be killed.
const WRITER_TOTAL: u64 = 100_000_000;

/// The writer process that `killed_writer_leaves_a_valid_prefix` starts and kills at random
/// moments: adds synthetic shapes (record `i` of [`SEED`]) to the index in [`WRITER_DIR`] in
/// batches of [`BATCH`], resuming from the live shapes already there, printing `committed N`
/// after every batch, until it is killed (or has written [`WRITER_TOTAL`] shapes). Without
/// [`WRITER_DIR`] (a run of the ignored tests) it does nothing.
#[test]
#[ignore = "the writer process of killed_writer_leaves_a_valid_prefix, which runs it"]
fn writer() {
    let Some(dir) = std::env::var_os(WRITER_DIR) else {
        return;
    };
    let mut w = IndexWriter::<D>::create_or_open(dir).unwrap();
    let mut n = w.len() as u64;
    let mut out = std::io::stdout().lock();
    while n < WRITER_TOTAL {
        w.add_batch(synthetic::records::<D>(SEED, n..n + BATCH))
            .unwrap();
        n += BATCH;
        writeln!(out, "committed {n}").unwrap();
        out.flush().unwrap();
    }
}

fn last_committed(out: &str) -> u64 {
    out.lines()
        .rev()
        .filter_map(|l| l.strip_prefix("committed "))
        .find_map(|n| n.trim().parse().ok())
        .unwrap_or(0)
}

fn check_prefix(dir: &Path, at_least: u64) -> u64 {
    let r = IndexReader::<D>::open(dir).expect("index must open after a kill");
    let n = r.shapes().unwrap().len() as u64;
    assert!(n >= at_least, "lost committed shapes: {n} < {at_least}");
    assert_eq!(n % BATCH, 0, "a partial batch is visible: {n} shapes");
    for (i, s) in r.shapes().unwrap().iter().enumerate() {
        assert_eq!(
            *s.record,
            synthetic::record::<D>(SEED, i as u64),
            "shape {i} differs"
        );
    }
    let rep = verify::<D>(dir).unwrap();
    assert!(rep.is_ok(), "verify after kill: {:?}", rep.problems);
    n
}

#[test]
fn killed_writer_leaves_a_valid_prefix() {
    let exe = std::env::current_exe().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("index");
    drop(IndexWriter::<D>::create_or_open(&dir).unwrap());
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let mut committed = 0;
    let mut with_leftovers = 0;
    let mut grew = 0;
    for round in 0..KILLS {
        let mut child = Command::new(&exe)
            .args(["writer", "--exact", "--ignored", "--nocapture"])
            .env(WRITER_DIR, &dir)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_micros(rng.random_range(0..60_000)));
        child.kill().unwrap();
        let _ = child.wait().unwrap();
        let mut out = String::new();
        child
            .stdout
            .take()
            .unwrap()
            .read_to_string(&mut out)
            .unwrap();
        let mut err = String::new();
        child
            .stderr
            .take()
            .unwrap()
            .read_to_string(&mut err)
            .unwrap();
        assert!(err.is_empty(), "round {round}: writer failed: {err}");
        committed = committed.max(last_committed(&out));
        if !verify::<D>(&dir).unwrap().leftovers.is_empty() {
            with_leftovers += 1;
        }
        let n = check_prefix(&dir, committed);
        if n > committed {
            // Killed after the manifest rename but before printing.
            grew += 1;
        }
        committed = n;
    }
    eprintln!(
        "{KILLS} kills: {committed} shapes at the end, {with_leftovers} kills left leftovers, {grew} landed between commit and report"
    );
    assert!(committed > 0, "the writer never committed: kills too early");
    // A clean writer run afterwards removes the leftovers.
    let mut w = IndexWriter::<D>::create_or_open(&dir).unwrap();
    w.add_batch(synthetic::records::<D>(SEED, committed..committed + BATCH))
        .unwrap();
    drop(w);
    assert!(verify::<D>(&dir).unwrap().leftovers.is_empty());
    check_prefix(&dir, committed + BATCH);
}
