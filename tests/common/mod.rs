//! Helpers shared by the end-to-end tests: running the real `keycomp` binary. The research
//! meshes are found by `keycomp_test_support::shared_data`.

#![allow(dead_code)] // each test file uses a different subset

use std::path::{Path, PathBuf};
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

/// A Chromium binary: `$KEYCOMP_CHROMIUM`, else `chromium` or `chromium-browser` on the usual
/// paths.
pub fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("KEYCOMP_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    [
        "/usr/bin/chromium",
        "/usr/bin/chromium-browser",
        "/snap/bin/chromium",
    ]
    .iter()
    .map(PathBuf::from)
    .find(|p| p.is_file())
}

/// Headless `browser` with a fresh profile in `profile` and no background traffic; the caller
/// adds what to do (`--dump-dom URL`, `--screenshot=FILE URL`, …).
pub fn headless(browser: &Path, profile: &Path) -> Command {
    let mut cmd = Command::new(browser);
    cmd.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--virtual-time-budget=10000",
    ])
    .arg(format!("--user-data-dir={}", profile.display()));
    cmd
}
