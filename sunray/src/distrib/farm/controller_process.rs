//! `sunray controller`: a farm job's controller, a process REM starts (and starts again, at a
//! higher epoch, when it exits unfinished, stalls or loses its host). It reads the job from
//! REM (its record, `JOB.scene` and the checkpoint), takes over the workers of its
//! predecessors that still run (an Adopt message; they keep rendering the lines they hold),
//! starts more on the live hosts up to the count asked (never failing for too few: as many
//! as there are, at least one), runs the controller actor
//! unchanged in its rules, and keeps its record fresh (state, lines in the checkpoint, its
//! own process and host) every [`LEASE_WRITE`]: REM restarts a controller that stops writing.
//!
//! Every write carries the epoch REM gave it (`REM_JOB_EPOCH`); once a newer controller has
//! the job REM refuses them, and this one stands down at once ([`ControllerEnd::Superseded`]).

use super::{scene_key, stats_key, FarmError};
use crate::distrib::checkpoint::{self, Checkpointer, Fenced, Store};
use crate::distrib::controller::{self, ControllerConfig, ControllerError, Start, WorkerProc};
use crate::distrib::job::{self, worker_env};
use crate::distrib::job_record;
use crate::distrib::messages::{self, proto, Body};
use crate::distrib::strategy::Strategy;
use crate::distrib::web_view;
use crate::render::Settings;
use prost::Message;
use rem::RemClient;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// How often the controller writes its record (REM's lease is several times longer).
pub const LEASE_WRITE: Duration = Duration::from_secs(1);

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
    let (job, epoch) = job_from_env()?;
    let client = RemClient::from_env().await?;
    let relay = RemClient::attach_from_env().await?;
    let me = relay.id().clone();
    let host = relay.host().to_string();
    let mut record = own_record(&client, &job, epoch).await?;
    let stored = |reason: &str| FarmError::Stored {
        job: job.clone(),
        reason: reason.to_string(),
    };
    let scene_bytes = client
        .get_checkpoint(&scene_key(&job))
        .await?
        .ok_or_else(|| stored("its scene is not in REM's store"))?;
    let scene = proto::Scene::decode(scene_bytes.as_slice())
        .map_err(|e| stored(&format!("its stored scene does not decode: {e}")))?;
    let restored = checkpoint::load(&client, &job)
        .await?
        .ok_or_else(|| stored("it has no checkpoint"))?;
    if scene.model_hash != restored.header.model_hash {
        return Err(stored("its stored scene is not the checkpoint's"));
    }
    let spec = restored.header.spec.clone().unwrap_or_default();
    let settings = scene
        .settings
        .as_ref()
        .map(Settings::from_proto)
        .transpose()
        .map_err(|e| stored(&e.to_string()))?
        .ok_or_else(|| stored("its stored scene has no render settings"))?;
    let (width, height) = (settings.render.width, settings.render.height);

    record.state = "running".into();
    record.controller = me.to_string();
    record.controller_host = host.clone();
    record.progress_done = restored.lines.len() as u64;
    if record.title.is_empty() {
        record.title = job_record::title(&job_record::from_record(&record).scene, width, height);
    }
    put_record(&client, &record, &job).await?;

    let all_in = restored.lines.len() as u32 >= height;
    let live: Vec<rem::HostInfo> = client
        .hosts()
        .await?
        .into_iter()
        .filter(|h| h.alive && h.accepting)
        .collect();
    let want = spec.hosts.max(1);
    // Never "too few hosts" here: as many workers as there are live hosts, at least one.
    let count = if spec.same_host {
        want
    } else {
        want.min(live.len().max(1) as u32)
    };
    // The previous controllers' workers that still run are taken over (they keep their
    // lines and their scene, and REM sends their events here now); new ones make up the
    // rest, on other hosts than theirs.
    let mut workers = if all_in {
        Vec::new()
    } else {
        take_over_workers(&client, &job, epoch, &me, &live).await
    };
    let more = count.saturating_sub(workers.len() as u32);
    if !all_in && more > 0 {
        let avoid: Vec<String> = workers.iter().map(|w| w.host.clone()).collect();
        let free = live.iter().filter(|h| !avoid.contains(&h.name)).count() as u32;
        let more = if spec.same_host { more } else { more.min(free) };
        let placed = match more {
            0 => Ok(Vec::new()),
            _ => {
                start_workers(
                    &client,
                    &opts,
                    &spec,
                    (&job, epoch),
                    more,
                    &me,
                    &live,
                    avoid,
                )
                .await
            }
        };
        match placed {
            Ok(placed) => workers.extend(placed),
            // The taken-over workers can finish the job alone.
            Err(e) if !workers.is_empty() => {
                eprintln!("sunray controller: warning: no new workers: {e}");
            }
            Err(e) => return Err(e),
        }
    }
    let checkpointed = Arc::new(AtomicU32::new(restored.lines.len() as u32));
    let strategy = Strategy::from_name(&spec.strategy).unwrap_or(Strategy::Dynamic);
    let cfg = ControllerConfig {
        job: job.clone(),
        strategy,
        width,
        height,
        scene: messages::encode(Body::Scene(proto::Scene {
            epoch,
            ..scene.clone()
        })),
        worker_timeout: opts.worker_timeout,
        checkpoint_every: opts.checkpoint_every,
        preview: None,
        preview_every: Duration::from_secs(3600),
        show_bar: false,
        // Its events go to REM's log of this process (`rem logs`): what happened, when.
        events: true,
        finish_grace: Duration::from_secs(3),
        checkpointed: Some(checkpointed.clone()),
        adopt: Some(messages::encode(Body::Adopt(proto::Adopt {
            job: job.clone(),
            epoch,
        }))),
        // What remd's web view shows, going on from the earlier controllers' history.
        web: Some(web_view::history(&client, &job, &host, epoch).await),
    };
    let checkpointer = Checkpointer::new(
        &job,
        spec.clone(),
        restored.header.model_hash,
        Some(&restored),
    );
    let (sender, receiver) = relay.split();
    let handle = controller::spawn(Start {
        cfg,
        client: client.clone(),
        sender,
        receiver,
        workers,
        restored: Some(restored),
        checkpointer,
        epoch,
    });
    let lease = keep_lease(&client, &mut record, &checkpointed, &job);
    let result = tokio::select! {
        r = handle.join() => r,
        e = lease => return Ok(ControllerEnd::Superseded(e.to_string())),
    };
    let result = match result {
        Ok(r) => r,
        Err(ControllerError::Superseded(why)) => return Ok(ControllerEnd::Superseded(why)),
        Err(e) => return Err(stored(&e.to_string())),
    };
    if !result.finished {
        return Ok(ControllerEnd::Unfinished);
    }
    // The scene's part of the totals, as `sunray render` and the in-process job give it,
    // from the counts `submit` stored (the model is not decoded here).
    let entry = job_record::from_record(&record);
    let header = settings.stats_header_of(
        &entry.scene,
        entry.scene_objects as usize,
        entry.scene_primitives as usize,
        entry.scene_unbounded as usize,
    );
    let stats = job::job_stats(
        &job,
        strategy,
        count,
        header,
        result,
        entry.scene_bytes_sent,
    );
    let json = serde_json::to_vec_pretty(&stats).map_err(|e| stored(&e.to_string()))?;
    Fenced {
        client: &client,
        epoch,
        job: &job,
    }
    .put(&stats_key(&job), json)
    .await
    .map_err(|e| match e {
        e if e.is_fenced() => FarmError::Superseded {
            job: job.clone(),
            reason: e.to_string(),
        },
        e => FarmError::Rem(e),
    })?;
    let mut entry = entry;
    entry.summary = stats.summary();
    record.app = entry.encode_to_vec();
    record.state = "finished".into();
    record.progress_done = u64::from(height);
    record.message.clear();
    put_record(&client, &record, &job).await?;
    Ok(ControllerEnd::Finished)
}

/// The job's record at this epoch, waiting briefly for the write of whoever started this
/// process; a newer epoch means this controller is not needed.
async fn own_record(
    client: &RemClient,
    job: &str,
    epoch: u64,
) -> Result<rem::JobRecord, FarmError> {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
    loop {
        match job_record::find(client, job).await? {
            Some(r) if r.epoch > epoch => {
                return Err(FarmError::Superseded {
                    job: job.to_string(),
                    reason: format!(
                        "the job is at epoch {}, this controller's is {epoch}",
                        r.epoch
                    ),
                })
            }
            Some(mut r) if r.epoch == epoch || tokio::time::Instant::now() > deadline => {
                r.epoch = epoch;
                return Ok(r);
            }
            None if tokio::time::Instant::now() > deadline => {
                return Err(FarmError::NoRecord(job.to_string()))
            }
            _ => tokio::time::sleep(Duration::from_millis(100)).await,
        }
    }
}

/// Writes the record; a refusal for a newer epoch (or an ended job) is [`FarmError::Superseded`].
async fn put_record(
    client: &RemClient,
    record: &rem::JobRecord,
    job: &str,
) -> Result<(), FarmError> {
    match client.put_job(record.clone()).await {
        Ok(_) => Ok(()),
        Err(e) if e.is_fenced() => Err(FarmError::Superseded {
            job: job.to_string(),
            reason: e.to_string(),
        }),
        Err(e) => Err(e.into()),
    }
}

/// Writes the record with the checkpoint's progress every [`LEASE_WRITE`]; returns only when
/// REM refuses it for a newer epoch or an ended job (a cancel).
async fn keep_lease(
    client: &RemClient,
    record: &mut rem::JobRecord,
    checkpointed: &AtomicU32,
    job: &str,
) -> FarmError {
    loop {
        tokio::time::sleep(LEASE_WRITE).await;
        record.progress_done = u64::from(checkpointed.load(Ordering::Relaxed));
        match put_record(client, record, job).await {
            Err(e @ FarmError::Superseded { .. }) => return e,
            // A daemon that does not answer now may later: the lease is REM's to judge.
            Err(e) => eprintln!("sunray controller: warning: the job's record: {e}"),
            Ok(()) => {}
        }
    }
}

/// The running workers of this job's earlier controllers (REM jobs `JOB.wE`, E < `epoch`),
/// adopted in REM by this controller (`me`): their Exited and Lost events come here now. A
/// worker that exits meanwhile is left out.
async fn take_over_workers(
    client: &RemClient,
    job: &str,
    epoch: u64,
    me: &rem::ProcId,
    live: &[rem::HostInfo],
) -> Vec<WorkerProc> {
    let Ok(procs) = client.ps().await else {
        return Vec::new();
    };
    let prefix = format!("{job}.w");
    let mut workers = Vec::new();
    let running = procs.iter().filter(|p| p.state == "running").filter(|p| {
        p.job
            .strip_prefix(&prefix)
            .and_then(|e| e.parse::<u64>().ok())
            .is_some_and(|e| e < epoch)
    });
    for p in running {
        let Some(proc_id) = rem::ProcId::parse(&p.proc_id) else {
            continue;
        };
        match client.adopt(&proc_id, me).await {
            Ok(_) => workers.push(WorkerProc {
                proc_id,
                host: p.host.clone(),
                pid: p.pid,
                load_at_start: controller::load_per_core(live, &p.host),
                adopted: true,
            }),
            Err(e) => eprintln!("sunray controller: not taking over {proc_id}: {e}"),
        }
    }
    workers
}

/// Starts `count` workers owned by this controller (`me`), not on `avoid_hosts`.
#[allow(clippy::too_many_arguments)]
async fn start_workers(
    client: &RemClient,
    opts: &ControllerOptions,
    spec: &proto::JobSpec,
    (job, epoch): (&str, u64),
    count: u32,
    me: &rem::ProcId,
    live: &[rem::HostInfo],
    avoid_hosts: Vec<String>,
) -> Result<Vec<WorkerProc>, FarmError> {
    let mut args = vec!["worker".to_string()];
    if spec.threads > 0 {
        args.extend(["--threads".to_string(), spec.threads.to_string()]);
    }
    let spawned = client
        .spawn(rem::SpawnRequest {
            program: opts.worker_program.display().to_string(),
            args,
            env: worker_env(std::env::vars()),
            nice: spec.nice.then_some(10),
            count,
            allow_same_host: spec.same_host,
            job: Some(format!("{job}.w{epoch}")),
            owner: Some(me.clone()),
            host: None,
            avoid_hosts,
        })
        .await?;
    Ok(WorkerProc::placed(&spawned, live))
}
