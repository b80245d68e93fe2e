//! Kill-test helper: adds synthetic shapes to an index in a loop, printing `committed N` after
//! every batch, so a test can SIGKILL it at random moments and check the index afterwards.
//!
//! Usage: `keycomp-index-stress DIR SEED BATCH TOTAL`
//!
//! Resumes from the number of live shapes already in `DIR` (record `i` of `SEED` is
//! [`keycomp_index::synthetic::record`]), adding batches of `BATCH` until `TOTAL` shapes.
//! Descriptors have 32 values. Exit code 2 on error.

use std::io::Write;
use std::process::ExitCode;

use keycomp_index::{IndexError, IndexWriter, synthetic};

const D: usize = 32;

fn run(args: &[String]) -> Result<(), String> {
    let [dir, seed, batch, total] = args else {
        return Err("usage: keycomp-index-stress DIR SEED BATCH TOTAL".into());
    };
    let num = |s: &str| {
        s.parse::<u64>()
            .map_err(|e| format!("bad number {s:?}: {e}"))
    };
    let (seed, batch, total) = (num(seed)?, num(batch)?.max(1), num(total)?);
    let mut w = IndexWriter::<D>::create_or_open(dir).map_err(|e: IndexError| e.to_string())?;
    let mut n = w.len() as u64;
    let mut out = std::io::stdout().lock();
    while n < total {
        let end = (n + batch).min(total);
        w.add_batch(synthetic::records::<D>(seed, n..end))
            .map_err(|e| e.to_string())?;
        n = end;
        writeln!(out, "committed {n}").map_err(|e| e.to_string())?;
        out.flush().map_err(|e| e.to_string())?;
    }
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("keycomp-index-stress: {e}");
            ExitCode::from(2)
        }
    }
}
