//! A SunRay III job from start to end: its plan (a new scene, or a checkpointed job to
//! resume), the first checkpoint and the job's record, the workers REM starts, the
//! controller actor, and the statistics of the whole image. `sunray submit` turns its flags
//! into a [`JobRequest`]; with the controller in this process it calls [`run`] and prints
//! the [`JobOutcome`], else it hands the job to the [farm](super::farm), whose controller
//! process runs it the same way ([`drive`]).
//!
//! # Layout
//! - [`plan`]: what is decided before the workers start, for a new job or a resumed one.
//! - [`drive`]: one run of a job's controller wherever it runs (workers, the controller
//!   actor, the statistics); where it runs is a [`drive::ControllerSite`].
//! - [`in_process`]: the job whose controller runs in this process (`--in-process`).
//! - [`input`]: a new job's scene: compiled here, or shipped before and still in REM.

pub(crate) mod drive;
mod in_process;
pub mod input;
mod plan;

pub use in_process::run;
pub(crate) use plan::{new_plan, Plan};

use super::checkpoint::CheckpointError;
use super::connection::ConnectionError;
use super::controller::ControllerError;
use super::messages::{proto, MessageError};
use super::nodes::JobStats;
use super::strategy::Strategy;
use crate::film::FilmError;
use crate::render::settings::SettingsError;
use crate::render::Overrides;
use crate::scene::load::SceneLoadError;
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
    /// Hosts no worker is started on.
    pub avoid_hosts: Vec<String>,
    /// Its priority in the farm's queue (0..=100, higher first).
    pub priority: u32,
    /// Render threads per worker [default: every core; on the embedded default, the cores
    /// shared among the workers; on resume, as before].
    pub threads: Option<usize>,
    /// The image to write [default: the scene's name with .png; on resume, as before].
    pub output: Option<PathBuf>,
    /// With a target error: where to write the heat map of the samples each pixel took.
    pub samples_map: Option<PathBuf>,
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
    /// With a target error, compact the checkpoint at every save that finds a line's record
    /// superseded, not only once the superseded records outweigh the latest ones (tests).
    pub compact_every_save: bool,
    /// Rewrite the partial image to this file every `preview_every`.
    pub preview: Option<PathBuf>,
    /// How often the preview is rewritten.
    pub preview_every: Duration,
    /// Show a progress bar on stderr.
    pub show_bar: bool,
    /// Print JSON events on stderr instead of a progress bar.
    pub events: bool,
    /// When the user submitted the job (Unix milliseconds; 0: when it starts): the origin of
    /// its timeline.
    pub submitted_unix_ms: u64,
}

/// The scene of a job.
// One per job, moved once: the size of the `New` variant costs nothing worth a Box.
#[allow(clippy::large_enum_variant)]
pub enum JobScene {
    /// A new job of a scene already loaded (so a bad scene starts nothing).
    New(input::JobInput),
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
    /// More workers asked for than there are live hosts (not avoided), one per host.
    #[error("asked for {asked} hosts, but the cluster has {} live host(s) to start them on: {}", live.len(), live.join(", "))]
    TooFewHosts {
        /// Workers asked for.
        asked: u32,
        /// The live hosts' names (those not avoided).
        live: Vec<String>,
    },
    /// More hosts to avoid than REM takes.
    #[error("{0} hosts to avoid; at most {max}", max = rem::wire::MAX_AVOID_HOSTS)]
    TooManyAvoided(usize),
    /// The model could not be encoded.
    #[error("cannot encode the model: {0}")]
    Model(#[from] yari::modelfile::ModelFileError),
    /// REM failed.
    #[error(transparent)]
    RemConnection(#[from] ConnectionError),
    /// REM could not start the workers.
    #[error("starting the workers: {0}")]
    Spawn(ConnectionError),
    /// Ctrl-C stopped a job whose controller runs in this process: it stops with it.
    #[error("job {job} interrupted: {kept} of {lines} lines are in its checkpoint; `sunray submit --resume {job}` continues it")]
    Interrupted {
        /// The job.
        job: String,
        /// Lines its checkpoint holds.
        kept: usize,
        /// Lines of the image.
        lines: u32,
    },
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
    /// Whether the farm stored the image (its last checkpoint): a finished job not stored has
    /// its image written here, and its record says interrupted (`--resume` stores the rest).
    pub stored: bool,
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

/// REM's request for a job's workers: `PROGRAM worker [--threads N]` with this process's
/// [`worker_env`], at nice 10 when asked; the caller says how many, where and for whom. The
/// in-process job and the farm's controller both start their workers with it.
pub(crate) fn worker_spawn(
    program: &Path,
    threads: Option<usize>,
    nice: bool,
) -> rem::SpawnRequest {
    let mut args = vec!["worker".to_string()];
    if let Some(t) = threads {
        args.extend(["--threads".to_string(), t.to_string()]);
    }
    rem::SpawnRequest {
        program: program.display().to_string(),
        args,
        env: worker_env(std::env::vars()),
        nice: nice.then_some(10),
        ..rem::SpawnRequest::default()
    }
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
        if self.avoid_hosts.len() > rem::wire::MAX_AVOID_HOSTS {
            return Err(JobError::TooManyAvoided(self.avoid_hosts.len()));
        }
        Ok(())
    }

    /// The `live` hosts a worker may be started on (those not avoided).
    pub fn eligible(&self, live: &[rem::HostInfo]) -> Vec<rem::HostInfo> {
        live.iter()
            .filter(|h| !self.avoid_hosts.contains(&h.name))
            .cloned()
            .collect()
    }
}

/// What the checkpoint remembers of the job, so `--resume` can continue it.
pub(crate) fn job_spec(req: &JobRequest, plan: &Plan) -> proto::JobSpec {
    let path_string = |p: &Path| p.display().to_string();
    proto::JobSpec {
        scene: plan.source.remembered(),
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
        avoid_hosts: req.avoid_hosts.clone(),
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
