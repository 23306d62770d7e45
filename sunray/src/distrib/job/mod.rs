//! A SunRay III job from start to end: its plan (a new scene, or a checkpointed job to
//! resume), the first checkpoint and the job-index entry, the workers REM starts, the
//! controller actor, and the statistics of the whole image. `sunray submit` turns its flags
//! into a [`JobRequest`], calls [`run`] and prints the [`JobOutcome`].
//!
//! - [`plan`]: what is decided before the workers start, for a new job or a resumed one.

mod plan;

use plan::resume_plan;
pub(crate) use plan::{new_plan, Plan};

use super::checkpoint::{self, CheckpointError, Checkpointer};
use super::connection::{ConnectionError, RemConnection};
use super::controller::{self, ControllerConfig, ControllerError, Start, WorkerProc};
use super::jobs;
use super::messages::{self, proto, Body, MessageError};
use super::model_chunks;
use super::nodes::{self, JobStats};
use super::strategy::Strategy;
use crate::film::FilmError;
use crate::render::settings::SettingsError;
use crate::render::Overrides;
use crate::scene::load::{LoadedScene, SceneLoadError};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Environment variables whose names start with this are passed on to the workers (the
/// test and benchmark hooks of `sunray worker`); no other variable is.
pub const WORKER_ENV_PREFIX: &str = "SUNRAY_WORKER_";

/// The longest job id.
pub const MAX_JOB_ID: usize = 100;

/// What a user asks of a job, besides its scene.
#[derive(Clone, Debug)]
pub struct JobRequest {
    /// The id of a new job [default: made up]; the key of its checkpoint.
    pub job: Option<String>,
    /// Workers to start, one per host [default: 1; on resume, as before].
    pub hosts: Option<u32>,
    /// Run the workers at nice 10.
    pub nice: bool,
    /// How lines are dealt out [default: dynamic; on resume, as before].
    pub strategy: Option<Strategy>,
    /// Allow more than one worker per host (always so on the embedded default).
    pub same_host: bool,
    /// Render threads per worker [default: every core; on the embedded default, the cores
    /// shared among the workers; on resume, as before].
    pub threads: Option<usize>,
    /// The image to write [default: the scene's name with .png; on resume, as before].
    pub output: Option<PathBuf>,
    /// A colour-name file extending the built-in table.
    pub colours: Option<PathBuf>,
    /// What the user asks for on top of the scene's own settings (new jobs only: a resumed
    /// job keeps the settings it was checkpointed with).
    pub overrides: Overrides,
    /// The program REM starts as `PROGRAM worker` on the hosts.
    pub worker_program: PathBuf,
    /// A worker holding a line longer than this is silent [default: 10 s or 20 slowest lines].
    pub worker_timeout: Option<Duration>,
    /// How often the controller checkpoints.
    pub checkpoint_every: Duration,
    /// Rewrite the partial image to this file every `preview_every`.
    pub preview: Option<PathBuf>,
    /// How often the preview is rewritten.
    pub preview_every: Duration,
    /// Show a progress bar on stderr.
    pub show_bar: bool,
    /// Print JSON events on stderr instead of a progress bar.
    pub events: bool,
}

/// The scene of a job.
// One per job, moved once: the size of the `New` variant costs nothing worth a Box.
#[allow(clippy::large_enum_variant)]
pub enum JobScene {
    /// A new job of a scene already loaded (so a bad scene starts nothing).
    New(LoadedScene),
    /// Continue job `job` from its checkpoint, with its own scene unless `scene` names one.
    Resume {
        /// The job to continue.
        job: String,
        /// The scene file, when it has moved since the job was checkpointed.
        scene: Option<PathBuf>,
    },
}

/// A job that could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum JobError {
    /// The job id has characters REM does not take, or is too long.
    #[error("bad job id {0:?}: use up to 100 of [A-Za-z0-9._-]")]
    BadJobId(String),
    /// `--hosts 0`.
    #[error("--hosts must be at least 1")]
    NoHosts,
    /// More workers asked for than there are live hosts, one per host.
    #[error("asked for {asked} hosts, but the cluster has {} live host(s): {}", live.len(), live.join(", "))]
    TooFewHosts {
        /// Workers asked for.
        asked: u32,
        /// The live hosts' names.
        live: Vec<String>,
    },
    /// The model could not be encoded.
    #[error("cannot encode the model: {0}")]
    Model(#[from] yari::modelfile::ModelFileError),
    /// REM failed.
    #[error(transparent)]
    RemConnection(#[from] ConnectionError),
    /// REM could not start the workers.
    #[error("starting the workers: {0}")]
    Spawn(ConnectionError),
    /// The checkpoint of a job to resume could not be read.
    #[error("reading the checkpoint of job {job}: {source}")]
    ReadCheckpoint {
        /// The job.
        job: String,
        /// Why.
        source: CheckpointError,
    },
    /// No checkpoint of a job to resume.
    #[error("no checkpoint of job {job} on {addr}")]
    NoCheckpoint {
        /// The job.
        job: String,
        /// The remd asked.
        addr: String,
    },
    /// The checkpoint holds no or bad render settings.
    #[error("the checkpoint of job {job} has no usable render settings{}", .reason.as_ref().map(|r| format!(": {r}")).unwrap_or_default())]
    BadSettings {
        /// The job.
        job: String,
        /// What is wrong with them, if they are there.
        reason: Option<MessageError>,
    },
    /// The scene and flags ask for render settings out of bounds.
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// The scene of a job to resume is not the one checkpointed.
    #[error("the scene has changed since job {0} was checkpointed; it cannot be resumed")]
    SceneChanged(String),
    /// The scene of a job to resume could not be loaded.
    #[error(transparent)]
    Scene(#[from] SceneLoadError),
    /// The first checkpoint could not be written.
    #[error("writing the first checkpoint: {0}")]
    FirstCheckpoint(CheckpointError),
    /// The output has an unknown format, or could not be written.
    #[error(transparent)]
    Film(#[from] FilmError),
    /// The controller failed.
    #[error(transparent)]
    Controller(#[from] ControllerError),
    /// The connection to remd was lost mid-job (its daemon or host stopped): the checkpoint
    /// is kept in the farm.
    #[error(
        "lost remd at {addr} mid-job ({reason}); the checkpoint is kept: \
         resume with `sunray submit --resume {job}` through a live remd"
    )]
    LostRemd {
        /// The remd address.
        addr: String,
        /// The innermost cause.
        reason: String,
        /// The job.
        job: String,
    },
}

/// How a job ended.
#[derive(Debug)]
pub struct JobOutcome {
    /// The job's id (`sunray submit --resume ID` continues it).
    pub job: String,
    /// The image written (when finished).
    pub output: PathBuf,
    /// False when no worker was left to finish the image (its lines are in the checkpoint).
    pub finished: bool,
    /// The per-node table and the totals.
    pub stats: JobStats,
}

/// Checks a job id given by a user.
pub fn check_job_id(job: &str) -> Result<(), JobError> {
    if !rem::wire::ids::is_valid_name(job) || job.len() > MAX_JOB_ID {
        return Err(JobError::BadJobId(job.to_string()));
    }
    Ok(())
}

/// The environment the workers get: the [`WORKER_ENV_PREFIX`] variables of `vars`.
pub fn worker_env(
    vars: impl Iterator<Item = (String, String)>,
) -> std::collections::BTreeMap<String, String> {
    vars.filter(|(k, _)| k.starts_with(WORKER_ENV_PREFIX))
        .collect()
}

impl JobRequest {
    /// Checks what can be checked before anything is loaded or started.
    pub fn check(&self) -> Result<(), JobError> {
        if self.hosts == Some(0) {
            return Err(JobError::NoHosts);
        }
        if let Some(job) = &self.job {
            check_job_id(job)?;
        }
        Ok(())
    }
}

/// Runs a job on `cluster` to its end: the image written when every line is in.
pub async fn run(
    cluster: &RemConnection,
    req: &JobRequest,
    scene: JobScene,
) -> Result<JobOutcome, JobError> {
    req.check()?;
    let plan = match scene {
        JobScene::New(loaded) => new_plan(req, loaded)?,
        JobScene::Resume { job, scene } => resume_plan(req, cluster, job, scene).await?,
    };
    run_plan(cluster, req, plan).await
}

async fn run_plan(
    cluster: &RemConnection,
    req: &JobRequest,
    mut plan: Plan,
) -> Result<JobOutcome, JobError> {
    let allow_same_host = cluster.is_embedded() || req.same_host;
    let live = cluster.live_hosts().await?;
    // A resumed job goes on with the hosts that are left, unless --hosts says otherwise.
    let fewer = live.len().min(u32::MAX as usize) as u32;
    if plan.restored.is_some()
        && req.hosts.is_none()
        && !allow_same_host
        && fewer >= 1
        && plan.hosts > fewer
    {
        eprintln!(
            "sunray: resuming on {fewer} host(s): the job had {}, the others are not live",
            plan.hosts
        );
        plan.hosts = fewer;
    }
    if !allow_same_host && plan.hosts as usize > live.len() {
        return Err(JobError::TooFewHosts {
            asked: plan.hosts,
            live: live.iter().map(|h| h.name.clone()).collect(),
        });
    }
    // The model goes as REM chunks (no message limit; hosts that have them fetch nothing).
    let shipped = model_chunks::ship(&cluster.client, &plan.model)
        .await
        .map_err(|e| cluster.rpc_error(e))?;
    // In-process: nobody takes this controller's workers over (epoch 0).
    let scene_msg = messages::encode(Body::Scene(shipped.scene(
        plan.settings.to_proto(),
        &plan.job,
        0,
    )));
    let relay = cluster
        .client
        .attach(Some(&plan.job))
        .await
        .map_err(|e| cluster.rpc_error(e))?;

    let mut checkpointer = Checkpointer::new(
        &plan.job,
        job_spec(req, &plan),
        messages::fnv1a(&plan.model),
        plan.restored.as_ref(),
    );
    checkpointer
        .save(&cluster.client, "running")
        .await
        .map_err(JobError::FirstCheckpoint)?;
    let mut entry = proto::JobEntry {
        job: plan.job.clone(),
        scene: plan.loaded.source.display_name(),
        state: "running".into(),
        lines_done: checkpointer.lines_done(),
        height: plan.settings.render.height,
        hosts: plan.hosts,
        started_unix_ms: checkpoint::unix_ms(),
        output: plan.output.display().to_string(),
        ..Default::default()
    };
    let epoch = jobs::next_epoch(&cluster.client, &plan.job)
        .await
        .unwrap_or(1);
    record_update(cluster, &entry, plan.settings.render.width, epoch).await;

    let spawned = start_workers(cluster, req, &plan, allow_same_host, relay.id().clone()).await?;
    let workers = WorkerProc::placed(&spawned, &live);
    let (sender, receiver) = relay.split();
    let cfg = ControllerConfig {
        job: plan.job.clone(),
        strategy: plan.strategy,
        width: plan.settings.render.width,
        height: plan.settings.render.height,
        scene: scene_msg,
        worker_timeout: req.worker_timeout,
        checkpoint_every: req.checkpoint_every,
        preview: req.preview.clone(),
        preview_every: req.preview_every,
        show_bar: req.show_bar,
        events: req.events,
        finish_grace: Duration::from_secs(3),
        checkpointed: None,
        adopt: None,
        // remd's web view shows farm jobs; this one ends with this process.
        web: None,
    };
    let handle = controller::spawn(Start {
        cfg,
        client: cluster.client.clone(),
        sender,
        receiver,
        workers,
        restored: plan.restored,
        checkpointer,
        epoch: 0,
    });
    let result = handle.join().await.map_err(|e| match e {
        ControllerError::Relay(e) if e.is_connection_lost() => JobError::LostRemd {
            addr: cluster.addr.clone(),
            reason: e.root_cause(),
            job: plan.job.clone(),
        },
        e => JobError::Controller(e),
    })?;

    entry.lines_done = result.lines.resumed + result.lines.rendered;
    entry.state = if result.finished {
        "finished"
    } else {
        "failed"
    }
    .into();
    record_update(cluster, &entry, plan.settings.render.width, epoch).await;
    if result.finished {
        result.film.write(&plan.output)?;
    }
    let name = plan.loaded.source.display_name();
    let header = plan.settings.stats_header(&name, &plan.loaded.scene);
    let finished = result.finished;
    let stats = job_stats(
        &plan.job,
        plan.strategy,
        plan.hosts,
        header,
        result,
        shipped.bytes_sent,
    );
    Ok(JobOutcome {
        job: plan.job,
        output: plan.output,
        finished,
        stats,
    })
}

/// The statistics of a controller's run of `job`: the per-node table, and `header` (the
/// scene and image, from [`Settings::stats_header`]) with the counted totals of every line;
/// `scene_bytes_sent` is what the submitting host's remd sent of the model.
pub(crate) fn job_stats(
    job: &str,
    strategy: Strategy,
    hosts: u32,
    mut totals: crate::stats::RenderStats,
    result: controller::JobResult,
    scene_bytes_sent: u64,
) -> JobStats {
    totals.threads = result.nodes.iter().map(|n| n.threads as usize).sum();
    totals.time.render_s = result.elapsed_s;
    totals.time.cpu_s = result.nodes.iter().map(|n| n.cpu_s).sum();
    totals.set_counters(&result.counters);
    let (wait_share, tail_wait_share) = nodes::wait_shares(&result.nodes);
    JobStats {
        job: job.to_string(),
        strategy: Some(strategy),
        hosts,
        lines: result.lines,
        elapsed_s: result.elapsed_s,
        totals,
        controller: result.cost,
        scene_bytes_sent,
        wait_share,
        tail_wait_share,
        nodes: result.nodes,
    }
}

/// What the checkpoint remembers of the job, so `--resume` can continue it.
pub(crate) fn job_spec(req: &JobRequest, plan: &Plan) -> proto::JobSpec {
    let path_string = |p: &Path| p.display().to_string();
    proto::JobSpec {
        scene: plan.loaded.source.remembered(),
        settings: Some(plan.settings.to_proto()),
        output: path_string(
            &std::path::absolute(&plan.output).unwrap_or_else(|_| plan.output.clone()),
        ),
        strategy: plan.strategy.name().to_string(),
        hosts: plan.hosts,
        nice: plan.nice,
        colours: plan.colours.as_deref().map(path_string).unwrap_or_default(),
        spd_corners: req.overrides.spd_corners,
        threads: plan.threads.unwrap_or(0) as u32,
        same_host: req.same_host,
    }
}

/// Asks REM for the workers (none when a resumed job's lines are all in already).
async fn start_workers(
    cluster: &RemConnection,
    req: &JobRequest,
    plan: &Plan,
    allow_same_host: bool,
    owner: rem::ProcId,
) -> Result<rem::Job, JobError> {
    let rem_job = format!("{}.{}", plan.job, checkpoint::unix_ms() / 1000);
    let all_in = plan
        .restored
        .as_ref()
        .is_some_and(|r| r.lines.len() as u32 >= plan.settings.render.height);
    if all_in {
        return Ok(rem::Job {
            id: rem_job,
            processes: Vec::new(),
        });
    }
    let threads = plan.threads.or_else(|| {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        cluster
            .is_embedded()
            .then(|| (cores / plan.hosts as usize).max(1))
    });
    let mut args = vec!["worker".to_string()];
    if let Some(t) = threads {
        args.extend(["--threads".to_string(), t.to_string()]);
    }
    cluster
        .client
        .spawn(rem::SpawnRequest {
            program: req.worker_program.display().to_string(),
            args,
            env: worker_env(std::env::vars()),
            nice: plan.nice.then_some(10),
            count: plan.hosts,
            allow_same_host,
            job: Some(rem_job),
            owner: Some(owner),
            host: None,
            avoid_hosts: Vec::new(),
        })
        .await
        .map_err(|e| JobError::Spawn(cluster.rpc_error(e)))
}

async fn record_update(cluster: &RemConnection, entry: &proto::JobEntry, width: u32, epoch: u64) {
    if let Err(e) = jobs::update(&cluster.client, entry, width, epoch).await {
        eprintln!("sunray: warning: the job's record in REM: {e}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn job_ids_are_checked() {
        assert!(check_job_id("render-7.b_c").is_ok());
        for bad in ["", "a/b", "a b", &"x".repeat(MAX_JOB_ID + 1)] {
            assert!(check_job_id(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn workers_get_only_their_own_variables() {
        let vars = [
            ("SUNRAY_WORKER_LINE_DELAY_MS", "5"),
            ("LD_PRELOAD", "/tmp/x.so"),
            ("REM_SECRET", "s"),
        ]
        .map(|(k, v)| (k.to_string(), v.to_string()));
        assert_eq!(
            worker_env(vars.into_iter()),
            [("SUNRAY_WORKER_LINE_DELAY_MS".to_string(), "5".to_string())].into()
        );
    }
}
