//! Helpers shared by the end-to-end tests: running the real `keycomp` binary. The research
//! meshes are found by `keycomp_test_support::shared_data`.

#![allow(dead_code)] // each test file uses a different subset

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `keycomp` binary built for these tests.
pub fn keycomp(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_keycomp"))
        .args(args)
        .output()
        .expect("the keycomp binary runs")
}

/// The process's standard output, as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The process's standard error, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A path as a `&str` argument.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf8 path")
}
