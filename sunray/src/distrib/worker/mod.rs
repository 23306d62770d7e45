//! The worker (`sunray worker`, the process REM starts): attaches to its local remd, says
//! Ready, receives the compiled model through REM (no shared file system), builds its
//! accelerator, then loops: request, render, report.
//!
//! It holds a window of lines (rendering, queued, or on their way), so its render threads
//! need not wait for the network: `threads + 1` at first, then as many as its threads render
//! while a report travels to the controller and a new line comes back ([`Window`], from the
//! measured delay and line time). Each Request and Done says the window it wants now. With
//! nothing to do it repeats its Request now and then, which tells it (by an Undeliverable
//! notice) when its controller is gone. It obeys only its job's owner.
//!
//! The Scene message is not trusted: a model that does not decode, or render settings out of
//! their bounds (`render::settings`, checked before anything is allocated), make the worker
//! tell its controller why (a WorkerError message, waited for until its remd has it) and exit
//! with an error.

use super::messages::{self, proto, Body};
use super::model_chunks;
use super::pool::{LineJob, PoolScene, RenderPool, Rendered};
use super::window::{Window, MIN_COVER_S};
use crate::accel::Accel;
use crate::render::Settings;
use crate::scene::Scene;
use crate::stats::process_cpu_seconds;
use owner::{confirmed, Heard, Owner};
use rem::{Incoming, ProcId, RelayReceiver, RelaySender, RemClient};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

mod owner;

/// How long a farm job's worker waits for a new controller: longer than REM's lease (10 s)
/// and its settling (1.5 s), plus a controller's start.
pub const ADOPT_WAIT: Duration = Duration::from_secs(30);

/// How a worker runs.
#[derive(Clone, Debug)]
pub struct WorkerConfig {
    /// Render threads; `None` = every core of this host.
    pub threads: Option<usize>,
    /// How often an idle worker checks that its controller is still there.
    pub idle_probe: Duration,
    /// Extra time per line (test and benchmark hook: a slow worker).
    pub line_delay: Duration,
    /// Time to wait before saying Ready (test hook: a worker that hangs while starting).
    pub ready_delay: Duration,
    /// How long a farm job's worker whose controller is gone waits for a successor's Adopt.
    pub adopt_wait: Duration,
}

impl Default for WorkerConfig {
    fn default() -> Self {
        WorkerConfig {
            threads: None,
            idle_probe: Duration::from_secs(2),
            line_delay: Duration::ZERO,
            ready_delay: Duration::ZERO,
            adopt_wait: ADOPT_WAIT,
        }
    }
}

/// Why a worker stopped before the controller said NoMoreWork.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WorkerError {
    /// The relay or REM itself failed (a closed relay included).
    #[error("REM: {0}")]
    Rem(#[from] rem::Error),
    /// Started outside a job: REM_OWNER_ID is not set, so there is no controller to talk to.
    #[error("no job owner (REM_OWNER_ID is not set): workers are started by `sunray submit`")]
    NoOwner,
    /// A message to the controller came back undeliverable.
    #[error("the controller is gone")]
    ControllerGone,
    /// The Scene message could not be turned into a renderable scene (or the render
    /// threads stopped on it).
    #[error("bad scene from the controller: {0}")]
    BadScene(String),
    /// The OS refused a render thread.
    #[error("cannot start render threads: {0}")]
    Threads(std::io::Error),
}

/// Runs a worker until the controller says NoMoreWork (Ok) or goes away (Err).
pub async fn run(cfg: WorkerConfig) -> Result<(), WorkerError> {
    let started = Instant::now();
    let relay = RemClient::attach_from_env().await?;
    let owner = relay.owner().cloned().ok_or(WorkerError::NoOwner)?;
    let me = relay.id().clone();
    let host = relay.host().to_string();
    let (sender, receiver) = relay.split();
    let mut link = Link {
        sender,
        owner: owner.clone(),
    };
    let mut inbox = spawn_reader(receiver);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = cfg.threads.unwrap_or(cores).max(1);
    tokio::time::sleep(cfg.ready_delay).await;
    let ready = proto::Ready {
        host,
        cores: cores as u32,
        load_avg: load_average(),
        pid: std::process::id(),
        threads: threads as u32,
    };
    link.send(Body::Ready(ready.clone())).await?;

    let scene_msg = loop {
        match next_from_owner(&mut inbox, &owner).await? {
            Body::Scene(s) => break s,
            Body::NoMoreWork(_) => return Ok(()),
            _ => {}
        }
    };
    let mut owner = Owner::new(owner, &scene_msg);
    let mut records: Option<RemClient> = None;
    // Settings out of bounds are refused before anything is fetched or allocated for them.
    if let Err(e) = settings_of(&scene_msg) {
        report(&link, &me, &mut inbox, &e).await;
        return Err(e);
    }
    // The model, through this host's remd (cached there for the next worker or job).
    let fetched = match RemClient::from_env().await {
        Ok(client) => model_chunks::fetch_scene(&client, &scene_msg)
            .await
            .map_err(|e| WorkerError::BadScene(format!("cannot get the scene's model: {e}"))),
        Err(e) => Err(WorkerError::Rem(e)),
    };
    let (scene, mut scene_fetch) = match fetched {
        Ok(f) => f,
        Err(e) => {
            report(&link, &me, &mut inbox, &e).await;
            return Err(e);
        }
    };
    let t_pre = Instant::now();
    let prepared = tokio::task::spawn_blocking(move || prepare(scene_msg, scene))
        .await
        .unwrap_or_else(|e| {
            Err(WorkerError::BadScene(format!(
                "preparing the scene panicked: {e}"
            )))
        });
    let (scene, accel, settings, accel_cached) = match prepared {
        Ok(p) => p,
        Err(e) => {
            report(&link, &me, &mut inbox, &e).await;
            return Err(e);
        }
    };
    scene_fetch.accel_cached = accel_cached;
    let preprocess_s = t_pre.elapsed().as_secs_f64();
    let render_start = Instant::now();
    let (results_tx, mut results) = mpsc::unbounded_channel::<Rendered>();
    let pool = RenderPool::start(
        PoolScene {
            scene,
            accel,
            opts: settings.render,
            mailbox: settings.mailbox,
            delay: cfg.line_delay,
        },
        threads,
        results_tx,
    )
    .map_err(WorkerError::Threads)?;
    let mut window = Window::new(threads);
    let clock = || started.elapsed().as_secs_f64();
    // A Request for work, stamped now, giving back `released`.
    let request = |window: &mut Window, released: Vec<u64>| {
        let now = clock();
        Body::Request(proto::Request {
            window: window.lines(now),
            preprocess_s,
            stamp_s: now,
            released,
            scene: Some(scene_fetch),
        })
    };
    link.send(request(&mut window, Vec::new())).await?;

    let mut held = 0usize;
    let mut waits = Waits::default();
    let mut probe = tokio::time::interval(cfg.idle_probe);
    probe.tick().await;
    // Until a line is done, how long the first lines take bounds the window.
    let mut first_lines_at: Option<Instant> = None;
    let mut first_check = tokio::time::interval(Duration::from_secs_f64(MIN_COVER_S));
    first_check.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    loop {
        tokio::select! {
            item = inbox.recv() => {
                let incoming = item.ok_or(WorkerError::Rem(rem::Error::Closed))??;
                match owner.hear(incoming) {
                    Heard::Body(Body::Assign(a)) => {
                        let now = clock();
                        // Duplicates are not an answer to the worker's room but to an empty queue.
                        if a.echo_s > 0.0 && a.lines.iter().any(|l| !l.duplicate) {
                            window.delay(now, now - a.echo_s);
                        }
                        pool.set_queue_target(window.queued(now) as usize);
                        first_lines_at.get_or_insert_with(Instant::now);
                        for l in a.lines {
                            let job = LineJob {
                                line: l.line,
                                grant: l.grant,
                                duplicate: l.duplicate,
                                generation: owner.generation,
                            };
                            if pool.submit(job) {
                                held += 1;
                            }
                        }
                    }
                    Heard::Body(Body::NoMoreWork(_)) => return Ok(()),
                    Heard::Body(_) | Heard::Nothing => {}
                    Heard::Gone if owner.succeedable() => {
                        owner.orphaned.get_or_insert_with(tokio::time::Instant::now);
                    }
                    Heard::Gone => return Err(WorkerError::ControllerGone),
                    Heard::Adopt(from, adopt) => {
                        if !owner.newer_claim(&from, &adopt) {
                            continue;
                        }
                        if records.is_none() {
                            records = RemClient::from_env().await.ok();
                        }
                        let Some(r) = &records else { continue };
                        if !confirmed(r, &from, &adopt).await {
                            continue;
                        }
                        let kept = owner.take_over(from, adopt.epoch);
                        link.owner = owner.id.clone();
                        let again = proto::Ready {
                            load_avg: load_average(),
                            ..ready.clone()
                        };
                        link.send(Body::Ready(again)).await?;
                        for done in kept {
                            link.send(Body::Done(done)).await?;
                        }
                        link.send(request(&mut window, Vec::new())).await?;
                    }
                }
            }
            r = results.recv() => {
                let Some(r) = r else { return Err(WorkerError::BadScene("render threads stopped".into())) };
                held = held.saturating_sub(1);
                waits.add(&r);
                window.line_done(r.cycle_s);
                let now = clock();
                let released = give_back(&pool, &window, now, &mut held, owner.generation);
                let mut counters = proto::Counters::from(&r.counters);
                counters.line_s = r.line_s;
                let done = proto::Done {
                    line: r.job.line,
                    grant: r.job.grant,
                    pixels: messages::pixels_to_bytes(&r.pixels),
                    counters: Some(counters),
                    window: window.lines(now),
                    clock: Some(proto::NodeClock {
                        cpu_s: process_cpu_seconds(),
                        elapsed_s: clock(),
                        preprocess_s,
                        render_s: render_start.elapsed().as_secs_f64(),
                        wait_s: waits.fresh_s,
                        first_wait_s: waits.first_s,
                        tail_wait_s: waits.tail_s,
                    }),
                    stamp_s: r.finished.saturating_duration_since(started).as_secs_f64(),
                    released,
                };
                if let Some(done) = owner.report(done, r.job.generation) {
                    link.send(Body::Done(done)).await?;
                }
            }
            _ = first_check.tick(), if !window.has_line_time() && owner.orphaned.is_none() => {
                if let Some(at) = first_lines_at {
                    window.first_lines_running(at.elapsed().as_secs_f64());
                    let now = clock();
                    let released = give_back(&pool, &window, now, &mut held, owner.generation);
                    if !released.is_empty() {
                        link.send(request(&mut window, released)).await?;
                    }
                }
            }
            _ = probe.tick() => {
                if let Some(since) = owner.orphaned {
                    if since.elapsed() >= cfg.adopt_wait {
                        return Err(WorkerError::ControllerGone);
                    }
                } else if held == 0 {
                    link.send(request(&mut window, Vec::new())).await?;
                }
            }
        }
    }
}

/// Sets the pool's queue target from the window and takes back the queued lines beyond it
/// ([`Window::excess`]); returns the grants to report: those of the current controller (a
/// line granted by an earlier one is simply dropped: its successor has it queued).
fn give_back(
    pool: &RenderPool,
    window: &Window,
    now: f64,
    held: &mut usize,
    generation: u32,
) -> Vec<u64> {
    pool.set_queue_target(window.queued(now) as usize);
    let back = pool.take_back(window.excess(pool.queued(), now));
    *held = held.saturating_sub(back.len());
    back.into_iter()
        .filter(|job| job.generation == generation)
        .map(|job| job.grant)
        .collect()
}

/// The render threads' waits for their next line, summed over threads, by what ended them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Waits {
    /// For each thread's first line (start-up: at least one round trip).
    first_s: f64,
    /// For a fresh line: waiting for work.
    fresh_s: f64,
    /// For a duplicate: the tail, when no fresh line was left.
    tail_s: f64,
}

impl Waits {
    fn add(&mut self, r: &Rendered) {
        let sum = if r.first {
            &mut self.first_s
        } else if r.job.duplicate {
            &mut self.tail_s
        } else {
            &mut self.fresh_s
        };
        *sum += r.wait_s;
    }
}

/// How long a worker that cannot go on waits for its WorkerError to leave before it exits.
const REPORT_WAIT: Duration = Duration::from_secs(5);

/// What a worker sends itself to learn that its remd has taken what it sent before.
const FLUSH_MARKER: &[u8] = b"sunray-worker-flush";

/// Tells the controller why this worker cannot go on (a WorkerError message), and waits, at
/// most [`REPORT_WAIT`], until the local remd has taken the message: sending only queues it in
/// this process, which is about to exit. The wait is for a marker the worker sends itself
/// after the error; remd routes one process's messages in order, so when the marker is back
/// the error has left.
async fn report(
    link: &Link,
    me: &ProcId,
    inbox: &mut mpsc::Receiver<rem::Result<Incoming>>,
    error: &WorkerError,
) {
    let message = Body::WorkerError(proto::WorkerError {
        message: error.to_string(),
    });
    if link.send(message).await.is_err() || link.sender.send(me, FLUSH_MARKER).await.is_err() {
        return;
    }
    let flushed = async {
        loop {
            match inbox.recv().await {
                None | Some(Err(_)) => return,
                Some(Ok(Incoming::Message { from, payload }))
                    if from == me.as_str() && payload == FLUSH_MARKER =>
                {
                    return
                }
                Some(Ok(Incoming::Undeliverable { to, .. })) if to == me.as_str() => return,
                Some(Ok(_)) => {}
            }
        }
    };
    let _ = tokio::time::timeout(REPORT_WAIT, flushed).await;
}

/// The Scene's render settings, checked against their bounds.
fn settings_of(msg: &proto::Scene) -> Result<Settings, WorkerError> {
    msg.settings
        .as_ref()
        .ok_or_else(|| WorkerError::BadScene("no render settings".into()))
        .and_then(|s| Settings::from_proto(s).map_err(|e| WorkerError::BadScene(e.to_string())))
}

/// Builds the accelerator of the decoded scene with the Scene's settings (checked against
/// their bounds before the model was fetched), or reads the one a worker before built on
/// this host (from REM's process cache, `REM_CACHE_DIR`); whether it was read.
fn prepare(
    msg: proto::Scene,
    mut scene: Scene,
) -> Result<(Arc<Scene>, Arc<Accel>, Settings, bool), WorkerError> {
    let settings = settings_of(&msg)?;
    let dir = std::env::var_os(rem::wire::env::CACHE_DIR).map(std::path::PathBuf::from);
    let (accel, provenance) = crate::accel::cache::build_or_load(
        &mut scene.prims,
        &settings.accel,
        msg.model_hash,
        dir.as_deref(),
    );
    if let Some(w) = provenance.warning {
        eprintln!("sunray worker: warning: {w}");
    }
    Ok((
        Arc::new(scene),
        Arc::new(accel),
        settings,
        provenance.cached,
    ))
}

/// The sending side, addressed to the owner.
struct Link {
    sender: RelaySender,
    owner: ProcId,
}

impl Link {
    async fn send(&self, body: Body) -> Result<(), WorkerError> {
        self.sender
            .send(&self.owner, messages::encode(body))
            .await
            .map_err(WorkerError::from)
    }
}

/// Moves relay deliveries into a channel, so the main loop can select on it safely.
fn spawn_reader(mut receiver: RelayReceiver) -> mpsc::Receiver<rem::Result<Incoming>> {
    let (tx, rx) = mpsc::channel(256);
    tokio::spawn(async move {
        loop {
            let item = receiver.recv().await;
            let end = item.is_err();
            if tx.send(item).await.is_err() || end {
                return;
            }
        }
    });
    rx
}

/// The next message from the owner; other senders, events and garbage are skipped.
async fn next_from_owner(
    inbox: &mut mpsc::Receiver<rem::Result<Incoming>>,
    owner: &ProcId,
) -> Result<Body, WorkerError> {
    loop {
        match inbox.recv().await {
            None => return Err(WorkerError::Rem(rem::Error::Closed)),
            Some(Err(e)) => return Err(e.into()),
            Some(Ok(Incoming::Message { from, payload })) if from == owner.as_str() => {
                if let Ok(body) = messages::decode(&payload) {
                    return Ok(body);
                }
            }
            Some(Ok(Incoming::Undeliverable { to, .. })) if to == owner.as_str() => {
                return Err(WorkerError::ControllerGone)
            }
            Some(Ok(_)) => {}
        }
    }
}

/// The host's 1-minute load average (0 when unknown).
pub fn load_average() -> f64 {
    let mut avg = [0f64; 3];
    // SAFETY: getloadavg writes at most `nelem` doubles into the array we pass.
    let n = unsafe { libc::getloadavg(avg.as_mut_ptr(), 3) };
    if n >= 1 {
        avg[0]
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::Counters;

    fn rendered(first: bool, duplicate: bool, wait_s: f64) -> Rendered {
        Rendered {
            job: LineJob {
                line: 0,
                grant: 1,
                duplicate,
                generation: 0,
            },
            pixels: Vec::new(),
            counters: Counters::default(),
            line_s: 0.001,
            cycle_s: 0.001,
            wait_s,
            first,
            finished: Instant::now(),
        }
    }

    #[test]
    fn waits_are_split_into_start_up_work_and_tail() {
        let mut w = Waits::default();
        w.add(&rendered(true, false, 1.0));
        w.add(&rendered(true, true, 2.0));
        w.add(&rendered(false, false, 0.25));
        w.add(&rendered(false, false, 0.5));
        w.add(&rendered(false, true, 4.0));
        assert_eq!(
            w,
            Waits {
                first_s: 3.0,
                fresh_s: 0.75,
                tail_s: 4.0
            }
        );
    }
}
