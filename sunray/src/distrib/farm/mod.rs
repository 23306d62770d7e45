//! Jobs owned by the farm (DESIGN section 7): `sunray submit --detach` checks and compiles
//! the scene here, stores the job in REM (the model, the first checkpoint and the job
//! record) and asks REM to start its controller (`sunray controller`, a REM process like the
//! workers). From then on REM keeps the controller running: if it exits unfinished, stalls or
//! loses its host, the daemons start another at the next epoch, which continues from the
//! checkpoint. The terminal only follows (`sunray watch`), fetches the image (`sunray fetch`)
//! or cancels (`sunray cancel`).
//!
//! Keys in REM's store: `JOB` the checkpoint header and `JOB.sN` its segments (see
//! [`checkpoint`](super::checkpoint)), `JOB.scene` the Scene message every worker gets,
//! `JOB.stats` a finished job's statistics (JSON, as `--stats-json` writes them), and what
//! remd's web view (`remd --web`) shows ([`web_view`](super::web_view)): `JOB.web.json` the
//! per-node table, the job's history and what the image is, `JOB.web.png` the image so far.
//! A finished job's image is its last checkpoint (every line in it).
//!
//! # Layout
//! - [`controller_process`]: `sunray controller`, the process REM keeps running for a farm
//!   job; it runs the [controller actor](super::controller) of the job.
//! - [`follow`]: `watch`, `fetch` and `cancel`.
//! - [`job_workers`]: the workers a farm controller takes over or starts.
//! - [`lease`]: the controller's lease on its job (its record, written at its epoch).
//! - [`share_keeper`]: the job's share of the farm's slots (workers started and retired by
//!   REM's queue).
//! - [`tail`]: the controller's output, read through REM as it is written.

pub mod controller_process;
pub mod follow;
mod job_workers;
mod lease;
pub mod share_keeper;
pub mod tail;

use super::checkpoint::{self, CheckpointError, Checkpointer, Fenced, Store};
use super::connection::RemConnection;
use super::job::input::JobInput;
use super::job::{self, JobError, JobRequest};
use super::job_record;
use super::messages::proto;
use super::timeline::JobClock;
use super::web_view;
use prost::Message;

/// The key of a job's Scene message in REM's store.
pub fn scene_key(job: &str) -> String {
    format!("{job}.scene")
}

/// The key of a finished job's statistics (`sunray submit --stats-json`) in REM's store.
pub fn stats_key(job: &str) -> String {
    format!("{job}.stats")
}

/// Why a farm job could not be submitted, followed or run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FarmError {
    /// The job could not be planned or checked (scene, settings, hosts, sizes).
    #[error(transparent)]
    Job(#[from] JobError),
    /// A job by that id is still active.
    #[error("job {job} exists and is {state}: choose another --job, or follow it with `sunray watch {job}`")]
    Exists {
        /// The job id.
        job: String,
        /// Its state.
        state: String,
    },
    /// No live host holds the job's record.
    #[error("no live host holds a record of job {0} (never submitted, expired, or lost with the hosts that held it)")]
    NoRecord(String),
    /// The job's stored scene or checkpoint is missing or unusable.
    #[error("job {job}: {reason}")]
    Stored {
        /// The job id.
        job: String,
        /// What is wrong.
        reason: String,
    },
    /// The checkpoint could not be written or read.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// REM failed.
    #[error("{}", rem_line(.0))]
    Rem(#[from] rem::Error),
    /// The connection to the local remd was lost; the job goes on in the farm.
    #[error("lost remd at {addr} ({reason}); job {job} continues in the farm: follow it with `sunray watch {job}` through a live remd")]
    LostRemd {
        /// The remd address.
        addr: String,
        /// The innermost cause.
        reason: String,
        /// The job.
        job: String,
    },
    /// A newer controller has the job (this one stands down).
    #[error("a newer controller has job {job}: {reason}")]
    Superseded {
        /// The job id.
        job: String,
        /// REM's refusal.
        reason: String,
    },
    /// A job for the farm (`--detach`, `--controller-anywhere`) on the private embedded
    /// remd, which ends with the command.
    #[error("--detach and --controller-anywhere need a cluster (--remd or REM_ADDR): the private remd of the default set-up ends with this command")]
    DetachNeedsCluster,
    /// The image could not be written.
    #[error(transparent)]
    Film(#[from] crate::film::FilmError),
}

/// One line for a REM error: the innermost cause for transport failures.
fn rem_line(e: &rem::Error) -> String {
    if e.is_transport() {
        format!("cannot reach remd: {}", e.root_cause())
    } else {
        e.to_string()
    }
}

impl FarmError {
    /// `e` from the remd at `addr`, following `job`: a lost connection says the job goes on.
    pub fn from_rem(e: rem::Error, addr: &str, job: &str) -> FarmError {
        if e.is_connection_lost() {
            FarmError::LostRemd {
                addr: addr.to_string(),
                reason: e.root_cause(),
                job: job.to_string(),
            }
        } else {
            FarmError::Rem(e)
        }
    }
}

/// How the controller REM starts is to run (its command line besides `controller`).
#[derive(Clone, Debug, Default)]
pub struct ControllerFlags {
    /// Milliseconds between checkpoints.
    pub checkpoint_ms: u64,
    /// A worker holding a line longer than this is silent (milliseconds).
    pub worker_timeout_ms: Option<u64>,
    /// Start the first controller on the least-loaded live host rather than on the host of
    /// the remd the job is submitted through (restarts always go to the least-loaded).
    pub anywhere: bool,
}

/// A job handed to the farm.
#[derive(Clone, Debug)]
pub struct Submitted {
    /// Its id.
    pub job: String,
    /// Where the submitting user wants its image (`-o`, or the scene's name with .png).
    pub output: std::path::PathBuf,
}

/// Stores a new job of `input` in the farm and starts its controller. A scene compiled here
/// is remembered once shipped ([`JobInput::remember`]).
pub async fn submit(
    cluster: &RemConnection,
    req: &JobRequest,
    input: JobInput,
    flags: &ControllerFlags,
) -> Result<Submitted, FarmError> {
    if cluster.is_embedded() {
        return Err(FarmError::DetachNeedsCluster);
    }
    req.check()?;
    let clock = JobClock::at(req.submitted_unix_ms);
    let model_ready_s = clock.now();
    let plan = job::new_plan(req, input)?;
    let client = &cluster.client;
    // Independent reads and writes go at once, not one round trip after another (each is
    // a fixed cost of every job, DESIGN section 10).
    let (live, existing) = tokio::join!(cluster.live_hosts(), job_record::find(client, &plan.job));
    let live = req.eligible(&live.map_err(JobError::from)?);
    if !req.same_host && plan.hosts as usize > live.len() {
        return Err(JobError::TooFewHosts {
            asked: plan.hosts,
            live: live.iter().map(|h| h.name.clone()).collect(),
        }
        .into());
    }
    let existing = existing?;
    if let Some(r) = &existing {
        if !rem::store::job_store::is_ended(&r.state) {
            return Err(FarmError::Exists {
                job: plan.job,
                state: r.state.clone(),
            });
        }
    }
    // An id used again takes the next epoch (as REM will), so it may write over the old job.
    let store = Fenced {
        client,
        epoch: existing.map_or(1, |r| r.epoch + 1),
        job: &plan.job,
    };
    // The model goes as REM chunks; the stored Scene names them (the controller's epoch is
    // set when it sends the scene).
    let shipped = plan.ship(client).await?;
    let model_stored_s = clock.now();
    let scene_msg = shipped.scene(plan.settings.to_proto(), &plan.job, 0);
    let mut checkpointer =
        Checkpointer::new(&plan.job, job::job_spec(req, &plan), shipped.hash, None);
    let (width, height) = (plan.settings.render.width, plan.settings.render.height);
    let title = job_record::title(&plan.source.display_name(), width, height);
    // The Scene message, the first checkpoint and remd's web view (the page of a job used
    // again by this id starts afresh), at once.
    let key = scene_key(&plan.job);
    let (scene_put, saved, page) = tokio::join!(
        store.put(&key, scene_msg.encode_to_vec()),
        checkpointer.save(&store, "queued"),
        web_view::submitted(&store, &plan.job, &title, plan.hosts, (width, height))
    );
    scene_put?;
    saved?;
    if let Err(e) = page {
        eprintln!("sunray: warning: the job's page for remd's web view: {e}");
    }
    let entry = proto::JobEntry {
        job: plan.job.clone(),
        scene: plan.source.display_name(),
        state: "queued".into(),
        height: plan.settings.render.height,
        hosts: plan.hosts,
        started_unix_ms: checkpoint::unix_ms(),
        output: plan.output.display().to_string(),
        scene_objects: plan.summary.objects as u64,
        scene_primitives: plan.summary.primitives as u64,
        scene_unbounded: plan.summary.unbounded as u64,
        scene_bytes_sent: shipped.bytes_sent,
        submitted_unix_ms: req.submitted_unix_ms,
        model_ready_s,
        model_stored_s,
        ..Default::default()
    };
    let mut record = job_record::to_record(&entry, width, 1);
    record.controller_spawn = Some(controller_spawn(req, flags).to_proto());
    // What the queue shares the farm's slots by, from the start.
    record.priority = req.priority;
    let threads = plan.threads.unwrap_or(0) as u32;
    record.slots_wanted = share_keeper::slots_wanted(plan.hosts, threads, &live);
    let stored = client.start_job(record, flags.anywhere).await?;
    Ok(Submitted {
        job: stored.id,
        output: plan.output,
    })
}

/// How REM starts (and starts again) the job's controller: `sunray controller` of the
/// worker program, with the job's flags and the submitter's environment for workers.
fn controller_spawn(req: &JobRequest, flags: &ControllerFlags) -> rem::SpawnRequest {
    let mut args = vec![
        "controller".to_string(),
        "--checkpoint-ms".to_string(),
        flags.checkpoint_ms.to_string(),
        "--worker-program".to_string(),
        req.worker_program.display().to_string(),
    ];
    if let Some(ms) = flags.worker_timeout_ms {
        args.extend(["--worker-timeout-ms".to_string(), ms.to_string()]);
    }
    rem::SpawnRequest {
        program: req.worker_program.display().to_string(),
        args,
        env: job::worker_env(std::env::vars()),
        ..rem::SpawnRequest::default()
    }
}
