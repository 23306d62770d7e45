//! `sunray worker`: the process REM starts for `sunray submit`. Not for typing: it reads its
//! REM connection from the environment REM gives it (see [`crate::distrib::worker`]).

use crate::distrib::worker::{self, WorkerConfig, WorkerError};
use clap::Args;
use std::process::ExitCode;
use std::time::Duration;

/// Environment variable: extra milliseconds per line (a test and benchmark hook).
pub const LINE_DELAY_ENV: &str = "SUNRAY_WORKER_LINE_DELAY_MS";

/// Environment variable: milliseconds to wait before saying Ready (a test hook: a worker that
/// hangs while starting).
pub const READY_DELAY_ENV: &str = "SUNRAY_WORKER_READY_DELAY_MS";

/// Environment variable: `N` or `HOST:N`, the image version the worker (on HOST only) says
/// it renders in its Ready (a test hook: a host of another build, refused by the controller).
pub const IMAGE_VERSION_ENV: &str = "SUNRAY_WORKER_IMAGE_VERSION";

/// [`IMAGE_VERSION_ENV`]'s value read: the host it is for (every one when `None`) and the
/// version; `None` when unset or unreadable.
fn says_image_version() -> Option<(Option<String>, u32)> {
    let v = std::env::var(IMAGE_VERSION_ENV).ok()?;
    match v.rsplit_once(':') {
        Some((host, n)) => Some((Some(host.to_string()), n.parse().ok()?)),
        None => Some((None, v.parse().ok()?)),
    }
}

fn env_ms(name: &str) -> Duration {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse::<u64>().ok())
        .map_or(Duration::ZERO, Duration::from_millis)
}

/// The flags of `sunray worker`.
#[derive(Args, Debug, Clone)]
pub struct WorkerArgs {
    /// Render threads (default: every core of this host).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Runs the worker until the controller says NoMoreWork; fails when it cannot reach REM or the
/// controller.
pub fn run(args: WorkerArgs) -> anyhow::Result<ExitCode> {
    let cfg = WorkerConfig {
        threads: args.threads.filter(|&t| t > 0),
        line_delay: env_ms(LINE_DELAY_ENV),
        ready_delay: env_ms(READY_DELAY_ENV),
        says_image_version: says_image_version(),
        ..WorkerConfig::default()
    };
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    match runtime.block_on(worker::run(cfg)) {
        Ok(()) => Ok(ExitCode::SUCCESS),
        Err(WorkerError::ControllerGone) => {
            eprintln!("sunray worker: the controller is gone; stopping");
            Ok(ExitCode::from(super::exit::CONTROLLER_GONE))
        }
        Err(e) => Err(e.into()),
    }
}
