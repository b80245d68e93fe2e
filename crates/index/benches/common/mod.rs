#![allow(dead_code)] // each bench uses a part of this module
//! What this crate's benches share: their command line under `cargo bench`, and paths on it
//! taken from the workspace root.

use std::path::{Path, PathBuf};

/// The bench's command line, its name first, without the `--bench` flag `cargo bench` appends;
/// `None` when `cargo bench` did not run it (`cargo test --benches` and `--all-targets` run
/// bench targets too, and a measurement is no test), after printing `usage`.
pub fn bench_args(usage: &str) -> Option<Vec<String>> {
    let args: Vec<String> = std::env::args().collect();
    if !args.iter().any(|a| a == "--bench") {
        eprintln!("a measurement: run it with `{usage}`");
        return None;
    }
    Some(args.into_iter().filter(|a| a != "--bench").collect())
}

/// A path from the command line, a relative one taken from the workspace root (`cargo bench`
/// runs a bench in its crate's folder).
pub fn workspace_path(path: impl AsRef<Path>) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(path)
}
