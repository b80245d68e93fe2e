//! `keycomp serve`: a local web app and HTTP JSON API over an index (see `crate::serve`).

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Result;

pub const EXAMPLES: &str = "Examples:
  keycomp demo && keycomp serve --index keycomp-demo/index   # then open http://127.0.0.1:8000
  keycomp serve --index shapes --addr 0.0.0.0:8080 --max-upload-mb 64
  curl -F file=@cat3-half.off 'http://127.0.0.1:8000/api/query?k=5'";

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Index directory to serve (read as `query` reads it: a running `index add` is seen once
    /// it commits).
    #[arg(long, default_value = "index", value_name = "DIR")]
    pub index: PathBuf,
    /// Address to listen on. The default answers this machine only; another address makes
    /// the collection and the query API reachable from the network.
    #[arg(long, default_value = "127.0.0.1:8000", value_name = "HOST:PORT")]
    pub addr: SocketAddr,
    /// Largest upload accepted, in MB (larger ones get 413).
    #[arg(long, default_value_t = 256, value_name = "MB", value_parser = crate::args::at_least_one)]
    pub max_upload_mb: usize,
    /// Longest a query may run, in seconds (then it is stopped and answered 504).
    #[arg(long, default_value_t = 120, value_name = "S", value_parser = crate::args::at_least_one)]
    pub timeout: usize,
    /// Queries analysed at once (the others wait their turn); each gets the cores divided
    /// among them. Default: one per two cores, at least one.
    #[arg(long, value_name = "N", value_parser = crate::args::at_least_one)]
    pub jobs: Option<usize>,
}

pub fn run(args: Args) -> Result<ExitCode> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let jobs = args.jobs.unwrap_or((cores / 2).max(1));
    crate::serve::run(crate::serve::Options {
        index: args.index,
        addr: args.addr,
        max_upload: args.max_upload_mb.saturating_mul(1 << 20),
        timeout: Duration::from_secs(args.timeout as u64),
        jobs,
        threads_per_job: (cores / jobs).max(1),
    })?;
    Ok(ExitCode::SUCCESS)
}
