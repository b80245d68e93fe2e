//! Progress on stderr for the commands that analyse many files (`index add`, `demo`, the
//! benchmarks), and the index writer they open.

use std::path::Path;

use anyhow::Result;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use keycomp::Profile;
use keycomp::collection::{self, Failure, Writer};

/// Opens (or creates) the index at `dir` for adding shapes analysed with `profile`: an empty
/// index takes it, an index made another way is refused with a clear error.
pub fn open_writer(dir: &Path, profile: &Profile) -> Result<Writer> {
    let mut w = Writer::create_or_open(dir)?;
    w.ensure_profile(&profile.to_text()?)?;
    Ok(w)
}

/// A progress bar on stderr, hidden when stderr is not a terminal.
pub fn progress(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    if let Ok(style) =
        ProgressStyle::with_template("{spinner} {msg} [{bar:30}] {pos}/{len} {elapsed} (eta {eta})")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_string());
    bar
}

/// Progress of an add on a bar, failures printed above it.
pub struct Bar(pub ProgressBar);

impl collection::Progress for Bar {
    fn files(&self, count: usize) {
        self.0.set_length(count as u64);
    }
    fn file_done(&self) {
        self.0.inc(1);
    }
    fn failed(&self, failure: &Failure) {
        self.0.suspend(|| eprintln!("skipped: {}", failure.message));
    }
    fn warned(&self, message: &str) {
        self.0.suspend(|| eprintln!("warning: {message}"));
    }
}
