//! `sunray controller`: a farm job's controller, a process REM starts (and starts again, at a
//! higher epoch, when it exits unfinished, stalls or loses its host). It reads the job from
//! REM (its record, `JOB.scene` and the checkpoint), takes over the workers of its
//! predecessors that still run (an Adopt message; they keep rendering the lines they hold),
//! starts more on the live hosts as the job's share of the farm's slots allows (up to the
//! count asked; none while the job waits in the queue: [`share_keeper`](super::share_keeper)
//! grows and shrinks it as the shares move), runs the controller actor
//! unchanged in its rules ([`drive`], as the in-process job does, with this process as the
//! [`ControllerSite`]), and keeps its record fresh (state, lines in the checkpoint, its
//! own process and host) every [`LEASE_WRITE`]: REM restarts a controller that stops writing.
//!
//! Every write carries the epoch REM gave it (`REM_JOB_EPOCH`); once a newer controller has
//! the job REM refuses them, and this one stands down at once ([`ControllerEnd::Superseded`]).

use super::job_workers::take_over_workers;
use super::lease::{keep_lease, own_record, put_record};
use super::share_keeper::{slots_wanted, ShareKeeper};
use super::{scene_key, stats_key, FarmError};
use crate::distrib::checkpoint::{self, Checkpointer, Fenced, Restored, Store};
use crate::distrib::controller::crew::Crew;
use crate::distrib::controller::{ControllerConfig, ControllerError, Input, WorkerProc};
use crate::distrib::job::drive::{self, ControllerSite, Drive, Ran, Totals};
use crate::distrib::job_record;
use crate::distrib::messages::{self, proto, Body};
use crate::distrib::nodes::JobStats;
use crate::distrib::strategy::Strategy;
use crate::distrib::timeline::{JobClock, Timeline};
use crate::distrib::web_view;
use crate::render::Settings;
use prost::Message;
use rem::RemClient;
use std::path::PathBuf;
use std::sync::atomic::AtomicU32;
use std::sync::Arc;
use std::time::Duration;

pub use super::lease::LEASE_WRITE;

/// How the controller runs (its command line).
#[derive(Clone, Debug)]
pub struct ControllerOptions {
    /// How often the controller checkpoints.
    pub checkpoint_every: Duration,
    /// A worker holding a line longer than this is silent.
    pub worker_timeout: Option<Duration>,
    /// The program REM starts as `PROGRAM worker`.
    pub worker_program: PathBuf,
}

/// How a controller process ended.
#[derive(Debug)]
pub enum ControllerEnd {
    /// Every line is in: the record says finished.
    Finished,
    /// No worker was left: REM starts the controller again.
    Unfinished,
    /// Every line is in, but the last checkpoint could not be stored (after
    /// [`crate::distrib::controller`]'s tries): the record still says running, so REM starts
    /// the controller again, and the next one renders the lines the store lacks.
    NotStored,
    /// A newer controller has the job.
    Superseded(String),
}

/// The job this process controls: REM_JOB_RECORD at REM_JOB_EPOCH.
fn job_from_env() -> Result<(String, u64), FarmError> {
    let job = std::env::var(rem::wire::env::JOB_RECORD).unwrap_or_default();
    let epoch = std::env::var(rem::wire::env::JOB_EPOCH)
        .ok()
        .and_then(|e| e.parse::<u64>().ok())
        .unwrap_or(0);
    if job.is_empty() || epoch == 0 {
        return Err(FarmError::Stored {
            job,
            reason: "REM_JOB_RECORD and REM_JOB_EPOCH are not set: controllers are started by REM for `sunray submit --detach`".into(),
        });
    }
    Ok((job, epoch))
}

/// Runs the job REM gave this process to its end.
pub async fn run(opts: ControllerOptions) -> Result<ControllerEnd, FarmError> {
    let started = std::time::Instant::now();
    let (job, epoch) = job_from_env()?;
    let (client, relay) = tokio::join!(RemClient::from_env(), RemClient::attach_from_env());
    let (client, relay) = (client?, relay?);
    let host = relay.host().to_string();
    let (mut record, stored, live, history) = read_job(&client, (&job, epoch), &host).await?;
    let (width, height) = (stored.settings.render.width, stored.settings.render.height);
    let lines_in = stored.restored.finished_lines();
    let spec = stored.restored.header.spec.clone().unwrap_or_default();
    record.slots_wanted = slots_wanted(spec.hosts, spec.threads, &live);
    claim(&client, &mut record, &relay, (width, height), lines_in).await?;
    let count = worker_count(&spec, live.len());
    let checkpointed = Arc::new(AtomicU32::new(lines_in));
    let strategy = Strategy::from_name(&spec.strategy).unwrap_or(Strategy::Dynamic);
    let crew = Crew::default();
    let mut cfg = controller_config(
        &opts,
        (&job, epoch),
        (strategy, (width, height)),
        stored.scene,
        (checkpointed.clone(), history),
    );
    cfg.crew = Some(crew.clone());
    // The job's timeline counts from its submit; this process started a moment ago.
    let entry = job_record::from_record(&record);
    cfg.clock = JobClock::at(entry.submitted_unix_ms);
    cfg.timeline = Timeline::submitted(entry.model_ready_s, entry.model_stored_s);
    cfg.timeline.controller_started =
        Some((cfg.clock.now() - started.elapsed().as_secs_f64()).max(0.0));
    let checkpointer = Checkpointer::new(
        &job,
        spec.clone(),
        stored.restored.header.model_hash,
        Some(&stored.restored),
    );
    // The scene's part of the totals, as `sunray render` and the in-process job give it,
    // from the counts `submit` stored (the model is not decoded here).
    let totals = Totals {
        header: stored.settings.stats_header_of(
            &entry.scene,
            entry.scene_objects as usize,
            entry.scene_primitives as usize,
            entry.scene_unbounded as usize,
        ),
        hosts: count,
        scene_bytes_sent: entry.scene_bytes_sent,
    };
    let all_in = lines_in >= height;
    let start = Drive {
        cfg,
        client: client.clone(),
        relay,
        restored: Some(stored.restored),
        checkpointer,
        epoch,
    };
    let keeper = ShareKeeper {
        client: client.clone(),
        worker_program: opts.worker_program.clone(),
        spec,
        job: job.clone(),
        epoch,
        user: record.user.clone(),
        crew,
        live,
    };
    let mut site = FarmSite {
        client: &client,
        keeper,
        me: None,
        job: &job,
        epoch,
        all_in,
        record,
        checkpointed,
        told_finished: false,
    };
    let ended = match drive::run_controller(&mut site, start, totals).await? {
        Ran::Superseded(why) => return Ok(ControllerEnd::Superseded(why)),
        Ran::Ended(ended) if !ended.finished => return Ok(ControllerEnd::Unfinished),
        Ran::Ended(ended) if !ended.stored => return Ok(ControllerEnd::NotStored),
        Ran::Ended(ended) => ended,
    };
    if !site.told_finished {
        store_finished(
            &client,
            &mut site.record,
            (&job, epoch),
            height,
            &ended.stats,
        )
        .await?;
    }
    Ok(ControllerEnd::Finished)
}

/// The job's record (once it shows this controller's `epoch`), what the job is, the live
/// hosts that accept work and what remd's web view (on `host`) showed of the job so far: read
/// at once, not one round trip after another (a fixed cost of every job). A controller that
/// takes over reads the checkpoint only once the record shows its epoch: from then on its
/// predecessor's writes are refused. The first has none.
async fn read_job(
    client: &RemClient,
    (job, epoch): (&str, u64),
    host: &str,
) -> Result<
    (
        rem::JobRecord,
        StoredJob,
        Vec<rem::HostInfo>,
        Vec<web_view::Event>,
    ),
    FarmError,
> {
    let fenced = match epoch {
        0 | 1 => None,
        _ => Some(own_record(client, job, epoch).await?),
    };
    let (record, stored, hosts, history) = tokio::join!(
        async {
            match fenced {
                Some(r) => Ok(r),
                None => own_record(client, job, epoch).await,
            }
        },
        StoredJob::load(client, job),
        client.hosts(),
        web_view::history(client, job, host, epoch)
    );
    let live = hosts?
        .into_iter()
        .filter(|h| h.alive && h.accepting)
        .collect();
    Ok((record?, stored?, live, history))
}

/// Marks the job's `record` running under this controller (`relay`, on its host) with
/// `lines_in` lines in the checkpoint, titled if it was not (a `width` x `height` image), and
/// writes it.
async fn claim(
    client: &RemClient,
    record: &mut rem::JobRecord,
    relay: &rem::Relay,
    (width, height): (u32, u32),
    lines_in: u32,
) -> Result<(), FarmError> {
    record.state = "running".into();
    record.controller = relay.id().to_string();
    record.controller_host = relay.host().to_string();
    record.progress_done = u64::from(lines_in);
    if record.title.is_empty() {
        record.title = job_record::title(&job_record::from_record(record).scene, width, height);
    }
    let job = record.id.clone();
    put_record(client, record, &job).await
}

/// How long a farm job's end waits for a worker still fetching its scene (after the record
/// says finished: nobody waits for it).
pub const FETCH_GRACE: Duration = Duration::from_secs(60);

/// The controller's settings: its events go to REM's log of this process (`rem logs`), the
/// workers it takes over get Adopt (at `epoch`), and the job is published for remd's web
/// view, its events going on from `history`.
fn controller_config(
    opts: &ControllerOptions,
    (job, epoch): (&str, u64),
    (strategy, size): (Strategy, (u32, u32)),
    scene: proto::Scene,
    (checkpointed, history): (Arc<AtomicU32>, Vec<web_view::Event>),
) -> ControllerConfig {
    ControllerConfig {
        events: true,
        checkpointed: Some(checkpointed),
        adopt: Some(messages::encode(Body::Adopt(proto::Adopt {
            job: job.to_string(),
            epoch,
        }))),
        web: Some(history),
        // The job is the user's once its image is stored; its end goes on here and waits for
        // the hosts still fetching, so that each keeps the scene for the next job.
        fetch_grace: FETCH_GRACE,
        ..drive::controller_config(
            job,
            strategy,
            size,
            messages::encode(Body::Scene(proto::Scene { epoch, ..scene })),
            opts.worker_timeout,
            opts.checkpoint_every,
        )
    }
}

/// How many workers the job is to have: as many as it asked for, or as there are `live`
/// hosts (never "too few hosts" here), at least one.
fn worker_count(spec: &proto::JobSpec, live: usize) -> u32 {
    let want = spec.hosts.max(1);
    if spec.same_host {
        want
    } else {
        want.min(live.max(1) as u32)
    }
}

/// What `submit` stored of a job: its Scene message, its checkpoint and render settings.
struct StoredJob {
    scene: proto::Scene,
    restored: Restored,
    settings: Settings,
}

impl StoredJob {
    /// Reads `JOB.scene` and the checkpoint (at once), which must be of the same model.
    async fn load(client: &RemClient, job: &str) -> Result<StoredJob, FarmError> {
        let stored = |reason: &str| FarmError::Stored {
            job: job.to_string(),
            reason: reason.to_string(),
        };
        let key = scene_key(job);
        let (scene_bytes, restored) =
            tokio::join!(client.get_checkpoint(&key), checkpoint::load(client, job));
        let scene_bytes = scene_bytes?.ok_or_else(|| stored("its scene is not in REM's store"))?;
        let scene = proto::Scene::decode(scene_bytes.as_slice())
            .map_err(|e| stored(&format!("its stored scene does not decode: {e}")))?;
        let restored = restored?.ok_or_else(|| stored("it has no checkpoint"))?;
        if scene.model_hash != restored.header.model_hash {
            return Err(stored("its stored scene is not the checkpoint's"));
        }
        let settings = scene
            .settings
            .as_ref()
            .map(Settings::from_proto)
            .transpose()
            .map_err(|e| stored(&e.to_string()))?
            .ok_or_else(|| stored("its stored scene has no render settings"))?;
        Ok(StoredJob {
            scene,
            restored,
            settings,
        })
    }
}

/// This process as the controller's site: it takes over the workers of earlier
/// controllers, starts more, and holds the job's lease (its record, written every
/// [`LEASE_WRITE`]).
struct FarmSite<'a> {
    client: &'a RemClient,
    /// The job's share of the farm's slots: its workers start and retire by it.
    keeper: ShareKeeper,
    /// The controller's relay (its workers' owner), once known.
    me: Option<rem::ProcId>,
    job: &'a str,
    epoch: u64,
    /// Every line is in the checkpoint: no worker is needed.
    all_in: bool,
    record: rem::JobRecord,
    checkpointed: Arc<AtomicU32>,
    /// The record says finished (from when the image was stored).
    told_finished: bool,
}

impl ControllerSite for FarmSite<'_> {
    type Error = FarmError;

    /// The previous controllers' workers that still run are taken over (they keep their
    /// lines and their scene, and REM sends their events here now); new ones start on other
    /// hosts than theirs, as many as the job's share of the farm's slots allows (none: the
    /// job waits in the queue, and the keeper starts them when its turn comes).
    async fn workers(&mut self, me: &rem::ProcId) -> Result<Vec<WorkerProc>, FarmError> {
        self.me = Some(me.clone());
        if self.all_in {
            return Ok(Vec::new());
        }
        let (client, job, epoch) = (self.client, self.job, self.epoch);
        // The first controller of a job has no predecessor's workers to take over.
        let mut workers = match epoch {
            0 | 1 => Vec::new(),
            _ => take_over_workers(client, job, epoch, me, &self.keeper.live).await,
        };
        let share = match self.keeper.share().await {
            Some(s) => s,
            None => self.record.slots_wanted,
        };
        let crew = crate::distrib::controller::crew::CrewView::of(&workers);
        let need = share.saturating_sub(crew.slots());
        if need > 0 {
            workers.extend(self.keeper.grow(me, need, &crew).await);
        }
        Ok(workers)
    }

    async fn hold(&mut self, feed: tokio::sync::mpsc::Sender<Input>) -> String {
        let Some(me) = self.me.clone() else {
            return std::future::pending().await;
        };
        let crew = &self.keeper.crew;
        let lease = keep_lease(
            self.client,
            &mut self.record,
            (&self.checkpointed, crew),
            self.job,
        );
        tokio::select! {
            e = lease => e.to_string(),
            () = self.keeper.run(&me, feed) => std::future::pending().await,
        }
    }

    /// The record says finished as soon as the image is stored: `watch` (and `submit`)
    /// fetch it while the workers wind down.
    async fn image_stored(&mut self, ended: &drive::Ended) -> Result<(), FarmError> {
        let height = ended.film.height;
        store_finished(
            self.client,
            &mut self.record,
            (self.job, self.epoch),
            height,
            &ended.stats,
        )
        .await?;
        self.told_finished = true;
        Ok(())
    }

    fn controller_failed(&self, e: ControllerError) -> FarmError {
        FarmError::Stored {
            job: self.job.to_string(),
            reason: e.to_string(),
        }
    }
}

/// Stores a finished job's statistics under `JOB.stats` (fenced at `epoch`) and marks its
/// record finished, with the summary `watch` prints.
async fn store_finished(
    client: &RemClient,
    record: &mut rem::JobRecord,
    (job, epoch): (&str, u64),
    height: u32,
    stats: &JobStats,
) -> Result<(), FarmError> {
    let entry = job_record::from_record(record);
    let json = serde_json::to_vec_pretty(stats).map_err(|e| FarmError::Stored {
        job: job.to_string(),
        reason: e.to_string(),
    })?;
    Fenced { client, epoch, job }
        .put(&stats_key(job), json)
        .await
        .map_err(|e| match e {
            e if e.is_fenced() => FarmError::Superseded {
                job: job.to_string(),
                reason: e.to_string(),
            },
            e => FarmError::Rem(e),
        })?;
    let mut entry = entry;
    entry.summary = stats.summary();
    record.app = entry.encode_to_vec();
    record.state = "finished".into();
    record.progress_done = u64::from(height);
    // Its workers are winding down: the farm's queue counts the job no more.
    record.slots = 0;
    record.message.clear();
    put_record(client, record, job).await
}
