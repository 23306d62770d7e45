//! The commands of jobs owned by the farm: `sunray controller` (the process REM starts for
//! `submit --detach`, not for typing), `sunray watch`, `sunray fetch` and `sunray cancel`.
//! See [`crate::distrib::farm`].

use super::exit;
use crate::distrib::connection::RemConnection;
use crate::distrib::farm::controller_process::{self, ControllerEnd, ControllerOptions};
use crate::distrib::farm::follow::{self, Ended, WatchView};
use crate::distrib::farm::FarmError;
use clap::Args;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// How to reach REM: the flags every farm command shares.
#[derive(Args, Debug, Clone)]
pub struct RemFlags {
    /// The remd to ask [default: the private one, whose state lives in ~/.local/state/sunray].
    #[arg(long, env = "REM_ADDR")]
    pub remd: Option<String>,
    /// File with the cluster secret (else REM_SECRET_FILE or REM_SECRET).
    #[arg(long)]
    pub secret_file: Option<PathBuf>,
}

impl RemFlags {
    /// Connects to the remd named, or starts the private one.
    pub async fn open(&self) -> anyhow::Result<RemConnection> {
        let program = std::env::current_exe()?;
        Ok(
            RemConnection::open(self.remd.as_deref(), self.secret_file.as_deref(), &program)
                .await?,
        )
    }
}

/// The flags of `sunray controller`.
#[derive(Args, Debug, Clone)]
pub struct ControllerArgs {
    /// Milliseconds between checkpoints.
    #[arg(long, default_value_t = 2000)]
    pub checkpoint_ms: u64,
    /// A worker holding a line longer than this is silent [default: 10 s or 20 slowest lines].
    #[arg(long)]
    pub worker_timeout_ms: Option<u64>,
    /// The worker program on the hosts [default: this program].
    #[arg(long)]
    pub worker_program: Option<PathBuf>,
}

/// The flags of `sunray watch`.
#[derive(Args, Debug, Clone)]
pub struct WatchArgs {
    /// The job to follow.
    pub job: String,
    /// Print JSON events (state, controller moves, progress, and the controller's own) on
    /// stderr instead of a bar.
    #[arg(long)]
    pub events: bool,
    /// Print nothing but errors.
    #[arg(long, short)]
    pub quiet: bool,
    /// How to reach REM.
    #[command(flatten)]
    pub rem: RemFlags,
}

/// The flags of `sunray fetch`.
#[derive(Args, Debug, Clone)]
pub struct FetchArgs {
    /// The finished job.
    pub job: String,
    /// The image to write: .png, .ppm, .pfm or .exr.
    #[arg(short, long)]
    pub output: PathBuf,
    /// A job rendered to an error: also write the heat map of the samples each pixel took.
    #[arg(long, value_name = "FILE")]
    pub samples_map: Option<PathBuf>,
    /// How to reach REM.
    #[command(flatten)]
    pub rem: RemFlags,
}

/// The flags of `sunray cancel`.
#[derive(Args, Debug, Clone)]
pub struct CancelArgs {
    /// The job to cancel.
    pub job: String,
    /// How to reach REM.
    #[command(flatten)]
    pub rem: RemFlags,
}

/// The runtime of a farm command: two threads are plenty for following and fetching.
pub fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    Ok(tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?)
}

/// Runs a farm job's controller (exit 0 finished, 3 unfinished or its image not stored: REM
/// starts it again, 5 superseded by a newer controller).
pub fn controller(args: ControllerArgs) -> anyhow::Result<ExitCode> {
    let worker_program = match args.worker_program {
        Some(p) => p,
        None => std::env::current_exe()?,
    };
    let opts = ControllerOptions {
        checkpoint_every: Duration::from_millis(args.checkpoint_ms.max(50)),
        worker_timeout: args.worker_timeout_ms.map(Duration::from_millis),
        worker_program,
    };
    match runtime()?.block_on(controller_process::run(opts))? {
        ControllerEnd::Finished => Ok(ExitCode::SUCCESS),
        ControllerEnd::Unfinished => {
            eprintln!("sunray controller: no worker is left; REM starts the controller again");
            Ok(ExitCode::from(exit::NO_WORKERS_LEFT))
        }
        ControllerEnd::NotStored => {
            eprintln!(
                "sunray controller: every line is in but the checkpoint store refused the last save; REM starts the controller again"
            );
            Ok(ExitCode::from(exit::NOT_STORED))
        }
        ControllerEnd::Superseded(why) => {
            eprintln!("sunray controller: standing down: {why}");
            Ok(ExitCode::from(exit::SUPERSEDED))
        }
    }
}

/// The exit code and message for a watched job's end.
pub fn report_end(job: &str, end: &Ended, quiet: bool) -> ExitCode {
    match end {
        Ended::Finished { summary } => {
            if !quiet {
                eprint!("{summary}");
                eprintln!(
                    "sunray: job {job} finished; `sunray fetch {job} -o FILE` writes its image"
                );
            }
            ExitCode::SUCCESS
        }
        Ended::Failed(why) => {
            eprintln!("sunray: error: job {job} failed: {why}");
            ExitCode::from(exit::JOB_FAILED)
        }
        Ended::Cancelled(why) => {
            eprintln!("sunray: job {job} was cancelled ({why})");
            ExitCode::from(exit::JOB_CANCELLED)
        }
    }
}

/// Follows a job until it ends: exit 0 finished, 3 failed, 4 cancelled.
pub fn watch(args: WatchArgs) -> anyhow::Result<ExitCode> {
    runtime()?.block_on(async {
        let cluster = args.rem.open().await?;
        let view = WatchView {
            bar: !args.quiet && !args.events && std::io::stderr().is_terminal(),
            events: args.events,
            // With --events, the controller's own events too (where its host answers).
            controller_output: args.events,
            preview: None,
        };
        let end = follow::watch(&cluster.client, &cluster.addr, &args.job, view).await;
        cluster.close().await;
        Ok(report_end(&args.job, &end?, args.quiet))
    })
}

/// Writes a finished job's image.
pub fn fetch(args: FetchArgs) -> anyhow::Result<ExitCode> {
    runtime()?.block_on(async {
        let cluster = args.rem.open().await?;
        let result = follow::fetch(
            &cluster.client,
            &args.job,
            &args.output,
            args.samples_map.as_deref(),
        )
        .await;
        cluster.close().await;
        result?;
        Ok(ExitCode::SUCCESS)
    })
}

/// Cancels a job.
pub fn cancel(args: CancelArgs) -> anyhow::Result<ExitCode> {
    runtime()?.block_on(async {
        let cluster = args.rem.open().await?;
        let result: Result<_, FarmError> = follow::cancel(&cluster.client, &args.job).await;
        cluster.close().await;
        let was = result?;
        eprintln!(
            "sunray: cancelled job {} ({} of {} lines were in)",
            args.job, was.progress_done, was.progress_total
        );
        Ok(ExitCode::SUCCESS)
    })
}
