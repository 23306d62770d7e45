//! What the web view shows of the farm, as JSON rows: hosts (with a few minutes of load per
//! core) and jobs (with lines per second, ETA and workers alive). One sampler task per daemon
//! makes a [`FarmView`] every second and shares it (`watch`), so a page open in ten browsers
//! costs the daemon what one costs. Hosts come from the membership table (local, cheap);
//! jobs ask every live daemon (`ListJobs` and `Ps` fan out), so they are listed only while
//! someone looks (a request or an open stream in the last [`DEMAND_WINDOW`]).

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::Serialize;
use tokio::sync::watch;

use crate::auth::identity::Identity;
use crate::daemon::ops::queue::queue_of;
use crate::daemon::ops::Daemon;
use crate::store::job_store::{is_ended, unix_ms};
use crate::wire::proto::{HostInfo, JobRecord, ProcessInfo, QueueReply};

/// How often the sampler makes a new view.
pub const TICK: Duration = Duration::from_secs(1);

/// Load samples kept per host: 5 minutes at one per 2 s.
pub const HISTORY: usize = 150;

/// How long after the last request the sampler keeps listing jobs.
pub const DEMAND_WINDOW: Duration = Duration::from_secs(15);

/// Progress samples kept per job, at most [`RATE_WINDOW`] old: the rate is over them.
const RATE_SAMPLES: usize = 20;
const RATE_WINDOW: Duration = Duration::from_secs(30);

/// Most jobs tracked for rates (the newest first).
const MAX_TRACKED_JOBS: usize = 4096;

/// One host as the page shows it.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct HostRow {
    /// Its name in the cluster.
    pub name: String,
    /// Where its daemon listens.
    pub addr: String,
    /// Alive in the membership table.
    pub alive: bool,
    /// Taking new work (false while it shuts down).
    pub accepting: bool,
    /// Milliseconds since this daemon heard of it (`None`: never).
    pub last_heard_ms: Option<u64>,
    /// Its core count.
    pub cores: u32,
    /// Cores it offers (a cgroup's CPU limit inside a container).
    pub capacity: f64,
    /// What placement ranks by.
    pub load_per_core: f64,
    /// Fraction of CPU time busy, 0..1.
    pub busy: f64,
    /// Memory free.
    pub mem_free_bytes: u64,
    /// Memory in all.
    pub mem_total_bytes: u64,
    /// Processes REM runs there.
    pub processes: u32,
    /// Render slots it lends the farm, and those held.
    pub slots: u32,
    /// See `slots`.
    pub slots_used: u32,
    /// Load per core every 2 s, oldest first, at most [`HISTORY`].
    pub history: Vec<f64>,
}

/// One job as the page shows it.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct JobRow {
    /// The job id.
    pub id: String,
    /// Its owner.
    pub user: String,
    /// What it is, for people (the application's).
    pub title: String,
    /// queued, running, recovering, finished, failed or cancelled.
    pub state: String,
    /// Raised each time its controller was restarted.
    pub epoch: u64,
    /// The process running it now.
    pub controller: String,
    /// The host of that process.
    pub controller_host: String,
    /// Work done, in the application's units (SunRay: lines).
    pub done: u64,
    /// Work in all.
    pub total: u64,
    /// Over the last ~20 s (`None` until some time has passed).
    pub lines_per_s: Option<f64>,
    /// Seconds left at that rate.
    pub eta_s: Option<f64>,
    /// Its processes running now, besides the controller.
    pub workers_alive: u32,
    /// Its priority in the farm's queue.
    pub priority: u32,
    /// Render slots its processes hold (as its record says).
    pub slots: u32,
    /// Its place in the farm's queue while it waits for its first slot (`None`: it runs,
    /// or has ended).
    pub queue_position: Option<u32>,
    /// When it was submitted.
    pub created_unix_ms: u64,
    /// When its record was last written.
    pub updated_unix_ms: u64,
    /// Why it failed or was cancelled.
    pub message: String,
}

/// The farm at one moment.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FarmView {
    /// When it was made.
    pub unix_ms: u64,
    /// Every host this daemon knows, itself first.
    pub hosts: Vec<HostRow>,
    /// Every user's jobs (each viewer sees its own: [`FarmView::jobs_for`]); `None` when
    /// nobody has asked lately, or the listing failed.
    #[serde(skip)]
    pub jobs: Option<Vec<JobRow>>,
}

impl FarmView {
    /// The jobs `who` may see: its own, or every one for an admin.
    pub fn jobs_for(&self, who: &Identity) -> Option<Vec<JobRow>> {
        self.jobs.as_ref().map(|jobs| {
            jobs.iter()
                .filter(|j| who.admin || j.user == who.user)
                .cloned()
                .collect()
        })
    }
}

/// The sampler's memory between ticks: load histories and progress samples.
#[derive(Default)]
pub struct History {
    loads: HashMap<String, VecDeque<f32>>,
    progress: HashMap<(String, String), VecDeque<(Instant, u64)>>,
    ticks: u64,
}

impl History {
    /// Rows of `hosts`, recording their load every other call.
    pub fn hosts(&mut self, hosts: &[HostInfo]) -> Vec<HostRow> {
        self.ticks += 1;
        let sample = self.ticks % 2 == 1;
        self.loads
            .retain(|name, _| hosts.iter().any(|h| &h.name == name));
        hosts
            .iter()
            .map(|h| {
                let load = h.load.unwrap_or_default();
                let history = self.loads.entry(h.name.clone()).or_default();
                if sample {
                    if history.len() == HISTORY {
                        history.pop_front();
                    }
                    history.push_back(if h.alive {
                        load.load_per_core as f32
                    } else {
                        0.0
                    });
                }
                HostRow {
                    name: h.name.clone(),
                    addr: h.addr.clone(),
                    alive: h.alive,
                    accepting: h.accepting,
                    last_heard_ms: (h.last_heard_ms != u64::MAX).then_some(h.last_heard_ms),
                    cores: load.cores,
                    capacity: load.capacity,
                    load_per_core: load.load_per_core,
                    busy: round3(load.cpu_busy),
                    mem_free_bytes: load.mem_free_bytes,
                    mem_total_bytes: load.mem_total_bytes,
                    processes: load.rem_processes,
                    slots: load.slots,
                    slots_used: load.slots_used,
                    history: history.iter().map(|v| round3(f64::from(*v))).collect(),
                }
            })
            .collect()
    }

    /// Rows of `records` at `now`, with the rate of each from the samples so far.
    pub fn jobs(
        &mut self,
        records: Vec<JobRecord>,
        procs: &[ProcessInfo],
        queue: &QueueReply,
        now: Instant,
    ) -> Vec<JobRow> {
        let mut workers: BTreeMap<&str, u32> = BTreeMap::new();
        for p in procs
            .iter()
            .filter(|p| p.state == "running" && p.job_record.is_empty())
        {
            // A job's processes are tagged `ID.SUFFIX` (SunRay: `ID.wEPOCH`); ids may hold dots.
            if let Some((job, _)) = p.job.rsplit_once('.') {
                *workers.entry(job).or_default() += 1;
            }
        }
        let keys: Vec<(String, String)> = records
            .iter()
            .take(MAX_TRACKED_JOBS)
            .map(|r| (r.user.clone(), r.id.clone()))
            .collect();
        self.progress.retain(|k, _| keys.contains(k));
        let mut rows: Vec<JobRow> = records
            .into_iter()
            .map(|r| {
                let key = (r.user.clone(), r.id.clone());
                let samples = self.progress.entry(key).or_default();
                if samples.back().is_none_or(|(_, d)| *d != r.progress_done) {
                    if samples.len() == RATE_SAMPLES {
                        samples.pop_front();
                    }
                    samples.push_back((now, r.progress_done));
                }
                while samples.len() > 1
                    && samples
                        .front()
                        .is_some_and(|(t, _)| now.duration_since(*t) > RATE_WINDOW)
                {
                    samples.pop_front();
                }
                let ended = is_ended(&r.state);
                let lines_per_s = rate(samples, now).filter(|_| !ended);
                let left = r.progress_total.saturating_sub(r.progress_done) as f64;
                let eta_s = lines_per_s.filter(|v| *v > 0.0).map(|v| left / v);
                let waiting = queue
                    .jobs
                    .iter()
                    .find(|q| q.id == r.id && q.user == r.user)
                    .map(|q| q.queue_position)
                    .filter(|&p| p > 0);
                JobRow {
                    workers_alive: workers.get(r.id.as_str()).copied().unwrap_or(0),
                    priority: r.priority,
                    slots: r.slots,
                    queue_position: waiting,
                    id: r.id,
                    user: r.user,
                    title: r.title,
                    state: r.state,
                    epoch: r.epoch,
                    controller: r.controller,
                    controller_host: r.controller_host,
                    done: r.progress_done,
                    total: r.progress_total,
                    lines_per_s,
                    eta_s,
                    created_unix_ms: r.created_unix_ms,
                    updated_unix_ms: r.updated_unix_ms,
                    message: r.message,
                }
            })
            .collect();
        // Running jobs first, then the newest.
        rows.sort_by(|a, b| {
            (
                is_ended(&a.state),
                std::cmp::Reverse(a.created_unix_ms),
                &a.id,
            )
                .cmp(&(
                    is_ended(&b.state),
                    std::cmp::Reverse(b.created_unix_ms),
                    &b.id,
                ))
        });
        rows
    }
}

/// `v` to three decimals (what a page shows; f32 samples print shorter).
fn round3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// Lines per second from the oldest sample to now's (the newest), if time passed.
fn rate(samples: &VecDeque<(Instant, u64)>, now: Instant) -> Option<f64> {
    let (t0, d0) = *samples.front()?;
    let (_, d1) = *samples.back()?;
    let dt = now.duration_since(t0).as_secs_f64();
    (dt >= 0.5).then(|| d1.saturating_sub(d0) as f64 / dt)
}

/// Marks that someone looked at the jobs (keeps the sampler listing them).
#[derive(Clone, Default)]
pub struct Demand(Arc<AtomicU64>);

impl Demand {
    /// Someone looks now.
    pub fn touch(&self) {
        self.0
            .store(unix_ms(std::time::SystemTime::now()), Ordering::Relaxed);
    }

    fn recent(&self) -> bool {
        let last = self.0.load(Ordering::Relaxed);
        unix_ms(std::time::SystemTime::now()).saturating_sub(last)
            < DEMAND_WINDOW.as_millis() as u64
    }
}

/// Runs the sampler of `daemon` until it shuts down, publishing each view on `out`.
pub async fn sample(daemon: Arc<Daemon>, demand: Demand, out: watch::Sender<Arc<FarmView>>) {
    let mut history = History::default();
    let admin = Identity {
        user: "admin".into(),
        admin: true,
    };
    let mut tick = tokio::time::interval(TICK);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    loop {
        tokio::select! {
            _ = tick.tick() => {}
            _ = daemon.stop.cancelled() => return,
        }
        let hosts = history.hosts(&daemon.membership.hosts());
        let jobs = if demand.recent() {
            let listing = async {
                let records = daemon.list_jobs(&admin).await?;
                let procs = daemon.ps().await?;
                crate::error::Result::<_>::Ok((records, procs))
            };
            let listed = tokio::time::timeout(TICK * 3, listing).await;
            match listed {
                Ok(Ok((records, procs))) => {
                    let hosts = daemon.membership.hosts();
                    let queue = queue_of(records.clone(), &hosts, daemon.limits.user_slots);
                    Some(history.jobs(records, &procs, &queue, Instant::now()))
                }
                Ok(Err(e)) => {
                    tracing::debug!("web view: listing jobs: {e}");
                    None
                }
                Err(_) => None,
            }
        } else {
            None
        };
        let view = FarmView {
            unix_ms: unix_ms(std::time::SystemTime::now()),
            hosts,
            jobs,
        };
        // Nobody holds a receiver only when the web server has stopped.
        if out.send(Arc::new(view)).is_err() {
            return;
        }
    }
}

#[cfg(test)]
mod tests;
