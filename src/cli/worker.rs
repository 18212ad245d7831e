//! `lightbooth worker`: a render worker (see `lightbooth::worker`).

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use clap::Args;

use lightbooth::daemon;
use lightbooth::worker::{self, WorkerOptions};

#[derive(Args, Debug)]
pub struct WorkerArgs {
    /// The lab's PostgreSQL database, the one its daemons share
    /// (postgres://user@host/db).
    #[arg(long)]
    db: String,
    /// Where fetched scene bundles are unpacked and converged spectra kept.
    #[arg(long, default_value = ".lightbooth-cache")]
    cache_dir: PathBuf,
    /// Seconds between lease renewals.
    #[arg(long, default_value_t = daemon::DEFAULT_HEARTBEAT.as_secs_f64(), value_parser = positive_seconds)]
    heartbeat_seconds: f64,
    /// Seconds without a heartbeat after which the worker counts as gone and
    /// its job is given to another (longer than --heartbeat-seconds).
    #[arg(long, default_value_t = daemon::DEFAULT_LEASE.as_secs_f64(), value_parser = positive_seconds)]
    lease_seconds: f64,
    /// Milliseconds between looks for a job when idle.
    #[arg(long, default_value_t = 250, value_parser = clap::value_parser!(u64).range(10..=60_000))]
    poll_ms: u64,
}

fn positive_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|e| format!("`{s}`: {e}"))?;
    if v.is_finite() && v > 0.0 && v < 86_400.0 {
        Ok(v)
    } else {
        Err(format!("{v} is not a number of seconds between 0 and 86400"))
    }
}

pub fn run(args: WorkerArgs) -> anyhow::Result<()> {
    let options = WorkerOptions {
        db_url: args.db,
        cache_dir: args.cache_dir,
        heartbeat: Duration::from_secs_f64(args.heartbeat_seconds),
        lease: Duration::from_secs_f64(args.lease_seconds),
        poll: Duration::from_millis(args.poll_ms),
    };
    let runtime = tokio::runtime::Runtime::new().context("starting the async runtime")?;
    runtime.block_on(worker::run(options, daemon::shutdown_signal()))
}
