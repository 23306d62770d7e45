//! A job whose controller runs in this process (`sunray submit --in-process`, `--resume`,
//! and the private remd of the default set-up), as the thesis's SunRay III did: the plan,
//! the first checkpoint and the job's record, then [`run_controller`](drive::run_controller) with this process as the
//! [`ControllerSite`] (its workers started here, at epoch 0, no lease), then the record, the
//! image and the statistics. The job stops with this process; `--resume` continues it.

use super::drive::{self, ControllerSite, Drive, Ran, Totals};
use super::plan::{new_plan, resume_plan, Plan};
use super::{job_spec, worker_spawn, JobError, JobOutcome, JobRequest, JobScene};
use crate::distrib::checkpoint::{self, Checkpointer};
use crate::distrib::connection::RemConnection;
use crate::distrib::controller::{ControllerConfig, ControllerError, WorkerProc};
use crate::distrib::job_record;
use crate::distrib::messages::{self, proto, Body};
use crate::distrib::timeline::{JobClock, Timeline};

/// Runs a job on `cluster` to its end: the image written when every line is in.
pub async fn run(
    cluster: &RemConnection,
    req: &JobRequest,
    scene: JobScene,
) -> Result<JobOutcome, JobError> {
    req.check()?;
    let plan = match scene {
        JobScene::New(input) => new_plan(req, input)?,
        JobScene::Resume { job, scene } => resume_plan(req, cluster, job, scene).await?,
    };
    run_plan(cluster, req, plan).await
}

/// This process as the controller's site: it starts the workers itself.
struct InProcess<'a> {
    cluster: &'a RemConnection,
    req: &'a JobRequest,
    plan: &'a Plan,
    allow_same_host: bool,
    live: Vec<rem::HostInfo>,
    /// A resumed job's lines are all in already: no worker is started.
    all_in: bool,
    /// Ctrl-C stopped the job.
    interrupted: bool,
}

impl ControllerSite for InProcess<'_> {
    type Error = JobError;

    async fn workers(&mut self, owner: &rem::ProcId) -> Result<Vec<WorkerProc>, JobError> {
        let spawned = start_workers(
            self.cluster,
            self.req,
            self.plan,
            (self.allow_same_host, self.all_in),
            owner.clone(),
        )
        .await?;
        Ok(WorkerProc::placed(&spawned, &self.live))
    }

    /// Nobody takes an in-process job over; Ctrl-C stops it (it stops with this process).
    async fn hold(
        &mut self,
        _feed: tokio::sync::mpsc::Sender<crate::distrib::controller::Input>,
    ) -> String {
        if tokio::signal::ctrl_c().await.is_err() {
            return std::future::pending().await;
        }
        self.interrupted = true;
        "interrupted".into()
    }

    fn controller_failed(&self, e: ControllerError) -> JobError {
        match e {
            ControllerError::Relay(e) if e.is_connection_lost() => JobError::LostRemd {
                addr: self.cluster.addr.clone(),
                reason: e.root_cause(),
                job: self.plan.job.clone(),
            },
            e => JobError::Controller(e),
        }
    }
}

async fn run_plan(
    cluster: &RemConnection,
    req: &JobRequest,
    mut plan: Plan,
) -> Result<JobOutcome, JobError> {
    let clock = JobClock::at(req.submitted_unix_ms);
    let model_ready_s = clock.now();
    let allow_same_host = cluster.is_embedded() || req.same_host;
    let live = cluster.live_hosts().await?;
    check_hosts(&mut plan, req, allow_same_host, &req.eligible(&live))?;
    // The model goes as REM chunks (no message limit; hosts that have them fetch nothing).
    let shipped = plan
        .ship(&cluster.client)
        .await
        .map_err(|e| cluster.rpc_error(e))?;
    let model_stored_s = clock.now();
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

    let (checkpointer, mut entry, epoch) =
        first_checkpoint(cluster, req, &plan, shipped.hash).await?;
    let mut cfg = controller_config(req, &plan, scene_msg);
    cfg.timeline = Timeline::submitted(model_ready_s, model_stored_s);
    let name = plan.source.display_name();
    let s = &plan.summary;
    let totals = Totals {
        header: plan
            .settings
            .stats_header_of(&name, s.objects, s.primitives, s.unbounded),
        hosts: plan.hosts,
        scene_bytes_sent: shipped.bytes_sent,
    };
    let all_in = plan
        .restored
        .as_ref()
        .is_some_and(|r| r.finished_lines() >= plan.settings.render.height);
    let start = Drive {
        cfg,
        client: cluster.client.clone(),
        relay,
        restored: plan.restored.take(),
        checkpointer,
        epoch: 0,
    };
    let mut site = InProcess {
        cluster,
        req,
        plan: &plan,
        allow_same_host,
        live,
        all_in,
        interrupted: false,
    };
    let ended = match drive::run_controller(&mut site, start, totals).await? {
        Ran::Ended(ended) => ended,
        Ran::Superseded(_) if site.interrupted => {
            return Err(interrupted(cluster, &plan, entry, epoch).await);
        }
        Ran::Superseded(why) => {
            return Err(JobError::Controller(ControllerError::Superseded(why)));
        }
    };

    let stats = ended.stats;
    entry.lines_done = stats.lines.finished;
    entry.state = if ended.finished { "finished" } else { "failed" }.into();
    if ended.finished && !ended.stored {
        // The image is whole here, not in the store: the record says what the store holds,
        // and `--resume` renders the rest into it.
        entry.lines_done = stored_lines(cluster, &plan, &entry).await as u32;
        entry.state = "interrupted".into();
    }
    record_update(cluster, &entry, plan.settings.render.width, epoch).await;
    if ended.finished {
        ended.film.write(&plan.output)?;
        if let (Some(path), Some(p)) = (&req.samples_map, &ended.passes) {
            p.samples_map().write(path)?;
        }
    }
    Ok(JobOutcome {
        job: plan.job,
        output: plan.output,
        finished: ended.finished,
        stored: ended.stored,
        stats,
    })
}

/// How many lines the job's stored checkpoint holds (its header counts them; the record's
/// count if the header cannot be read).
async fn stored_lines(cluster: &RemConnection, plan: &Plan, entry: &proto::JobEntry) -> usize {
    match job_record::header(&cluster.client, &plan.job).await {
        Ok(Some(h)) => h.lines_done as usize,
        _ => entry.lines_done as usize,
    }
}

/// Ends a job that Ctrl-C interrupted: its record `interrupted` with the lines its checkpoint
/// holds (what a `--resume` starts from), and the error that says so. Its workers end with
/// this process's end (the private remd's, or their controller's link to remd).
async fn interrupted(
    cluster: &RemConnection,
    plan: &Plan,
    mut entry: proto::JobEntry,
    epoch: u64,
) -> JobError {
    // The checkpoint's header counts its lines: its segments need not be read.
    let kept = stored_lines(cluster, plan, &entry).await;
    entry.lines_done = kept as u32;
    entry.state = "interrupted".into();
    record_update(cluster, &entry, plan.settings.render.width, epoch).await;
    JobError::Interrupted {
        job: plan.job.clone(),
        kept,
        lines: plan.settings.render.height,
    }
}

/// Writes the job's first checkpoint (of the model with `model_hash`, as its shipping
/// hashed it) and its record (running) at the job's next epoch.
async fn first_checkpoint(
    cluster: &RemConnection,
    req: &JobRequest,
    plan: &Plan,
    model_hash: u64,
) -> Result<(Checkpointer, proto::JobEntry, u64), JobError> {
    let mut checkpointer = Checkpointer::new(
        &plan.job,
        job_spec(req, plan),
        model_hash,
        plan.restored.as_ref(),
    );
    if req.compact_every_save {
        checkpointer = checkpointer.with_slack(None);
    }
    checkpointer
        .save(&cluster.client, "running")
        .await
        .map_err(JobError::FirstCheckpoint)?;
    let entry = proto::JobEntry {
        job: plan.job.clone(),
        scene: plan.source.display_name(),
        state: "running".into(),
        lines_done: checkpointer.lines_done(),
        height: plan.settings.render.height,
        hosts: plan.hosts,
        priority: req.priority,
        started_unix_ms: checkpoint::unix_ms(),
        output: plan.output.display().to_string(),
        ..Default::default()
    };
    let epoch = job_record::next_epoch(&cluster.client, &plan.job)
        .await
        .unwrap_or(1);
    record_update(cluster, &entry, plan.settings.render.width, epoch).await;
    Ok((checkpointer, entry, epoch))
}

/// The controller's settings: it shows what the request asks (a bar or events, a preview).
fn controller_config(req: &JobRequest, plan: &Plan, scene_msg: Vec<u8>) -> ControllerConfig {
    let render = &plan.settings.render;
    ControllerConfig {
        preview: req.preview.clone(),
        preview_every: req.preview_every,
        show_bar: req.show_bar,
        events: req.events,
        // remd's web view shows farm jobs; this one ends with this process.
        web: None,
        clock: JobClock::at(req.submitted_unix_ms),
        ..drive::controller_config(
            &plan.job,
            plan.strategy,
            (render.width, render.height),
            scene_msg,
            req.worker_timeout,
            req.checkpoint_every,
        )
    }
}

/// Checks the plan's host count against the `live` hosts; a resumed job goes on with the
/// hosts that are left, unless `--hosts` says otherwise.
fn check_hosts(
    plan: &mut Plan,
    req: &JobRequest,
    allow_same_host: bool,
    live: &[rem::HostInfo],
) -> Result<(), JobError> {
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
    Ok(())
}

/// Asks REM for the workers (none when a resumed job's lines are `all_in` already).
async fn start_workers(
    cluster: &RemConnection,
    req: &JobRequest,
    plan: &Plan,
    (allow_same_host, all_in): (bool, bool),
    owner: rem::ProcId,
) -> Result<rem::Job, JobError> {
    let rem_job = format!("{}.{}", plan.job, checkpoint::unix_ms() / 1000);
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
    // On a farm the workers hold slots: as many as there are hosts with one free (its
    // workers do not change while it runs; a farm job's follow its share). The private remd
    // of the default set-up runs this job alone: nothing to share.
    let shared = !cluster.is_embedded();
    let spawn = rem::SpawnRequest {
        count: plan.hosts,
        allow_same_host,
        job: Some(rem_job),
        owner: Some(owner),
        avoid_hosts: req.avoid_hosts.clone(),
        slots_min: u32::from(shared),
        slots_max: threads.unwrap_or(0) as u32,
        up_to: shared,
        ..worker_spawn(&req.worker_program, threads, plan.nice)
    };
    // Every slot held (another job's workers, or this job's own from before a lost remd,
    // still winding down): it waits for one, a while.
    let deadline = std::time::Instant::now() + SLOT_WAIT;
    let mut said = false;
    loop {
        match cluster.client.spawn(spawn.clone()).await {
            Err(e) if e.is_exhausted() && std::time::Instant::now() < deadline => {
                if !said {
                    eprintln!("sunray: waiting for a free render slot: {}", e.root_cause());
                    said = true;
                }
                tokio::time::sleep(std::time::Duration::from_millis(250)).await;
            }
            r => return r.map_err(|e| JobError::Spawn(cluster.rpc_error(e))),
        }
    }
}

/// How long a job in this process waits for a free render slot before it gives up (a farm
/// job waits in the queue for as long as it takes).
const SLOT_WAIT: std::time::Duration = std::time::Duration::from_secs(60);

async fn record_update(cluster: &RemConnection, entry: &proto::JobEntry, width: u32, epoch: u64) {
    if let Err(e) = job_record::update(&cluster.client, entry, width, epoch).await {
        eprintln!("sunray: warning: the job's record in REM: {e}");
    }
}
