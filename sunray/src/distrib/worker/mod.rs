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
//!
//! # Layout
//! - [`owner`]: whom the worker answers to, and a farm job's takeover by a new controller.
//! - [`prepared_scene`]: the scene mapped from the host's prepared scene, or made by a
//!   keeper that a job's end does not interrupt.
//! - [`render_loop`]: the loop once the scene is ready: Assign, render, Done.

use super::messages::{self, proto, Body};
use super::model_chunks;
use super::pool::{PoolScene, RenderPool, Rendered};
use super::window::Window;
use crate::accel::Accel;
use crate::render::Settings;
use crate::scene::Scene;
use owner::Owner;
use rem::{Incoming, ProcId, RelayReceiver, RelaySender, RemClient};
use render_loop::{RenderLoop, Waits};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

mod owner;
mod prepared_scene;
mod render_loop;

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
    /// The image version its Ready says instead of this build's, on every host (`None`) or
    /// on the one named (test hook: a host of another build).
    pub says_image_version: Option<(Option<String>, u32)>,
}

impl Default for WorkerConfig {
    fn default() -> Self {
        WorkerConfig {
            threads: None,
            idle_probe: Duration::from_secs(2),
            line_delay: Duration::ZERO,
            ready_delay: Duration::ZERO,
            adopt_wait: ADOPT_WAIT,
            says_image_version: None,
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

/// How many threads render: the slots REM granted (`REM_SLOTS`, when the worker holds
/// slots), never more than `--threads`; else `--threads`, else every core.
fn render_threads(asked: Option<usize>, slots: Option<&str>, cores: usize) -> usize {
    let granted = slots
        .and_then(|s| s.parse::<usize>().ok())
        .filter(|&n| n > 0);
    match (asked, granted) {
        (Some(t), Some(g)) => t.min(g),
        (None, Some(g)) => g,
        (t, None) => t.unwrap_or(cores),
    }
    .max(1)
}

/// Runs a worker until the controller says NoMoreWork (Ok) or goes away (Err).
pub async fn run(cfg: WorkerConfig) -> Result<(), WorkerError> {
    let started = Instant::now();
    let relay = RemClient::attach_from_env().await?;
    let owner = relay.owner().cloned().ok_or(WorkerError::NoOwner)?;
    let me = relay.id().clone();
    let host = relay.host().to_string();
    let (sender, receiver) = relay.split();
    let link = Link {
        sender,
        owner: owner.clone(),
    };
    let mut inbox = spawn_reader(receiver);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let slots = std::env::var(rem::wire::env::SLOTS).ok();
    let threads = render_threads(cfg.threads, slots.as_deref(), cores);
    tokio::time::sleep(cfg.ready_delay).await;
    let image_version = match &cfg.says_image_version {
        Some((only, v)) if only.as_ref().is_none_or(|h| *h == host) => *v,
        _ => crate::render::image_version::IMAGE_VERSION,
    };
    let ready = proto::Ready {
        host,
        cores: cores as u32,
        load_avg: load_average(),
        pid: std::process::id(),
        threads: threads as u32,
        sparse_passes: true,
        image_version,
    };
    link.send(Body::Ready(ready.clone())).await?;

    let scene_msg = loop {
        match next_from_owner(&mut inbox, &owner).await? {
            Body::Scene(s) => break s,
            Body::NoMoreWork(_) | Body::Retire(_) => return Ok(()),
            _ => {}
        }
    };
    let owner = Owner::new(owner, &scene_msg);
    let ready_scene = match ready_scene(scene_msg, &link).await {
        Ok(r) => r,
        Err(e) => {
            report(&link, &me, &mut inbox, &e).await;
            return Err(e);
        }
    };
    let render_start = Instant::now();
    let (results_tx, results) = mpsc::unbounded_channel::<Rendered>();
    let pool = RenderPool::start(
        PoolScene {
            scene: ready_scene.scene,
            accel: ready_scene.accel,
            opts: ready_scene.settings.render,
            mailbox: ready_scene.settings.mailbox,
            delay: cfg.line_delay,
        },
        threads,
        results_tx,
    )
    .map_err(WorkerError::Threads)?;
    let render_loop = RenderLoop {
        link,
        owner,
        records: None,
        pool,
        window: Window::new(threads),
        held: 0,
        waits: Waits::default(),
        first_lines_at: None,
        started,
        render_start,
        preprocess_s: ready_scene.preprocess_s,
        scene_fetch: ready_scene.fetch,
        steps: proto::WorkerSteps {
            scene_ready_s: (ready_scene.scene_at - started).as_secs_f64(),
            accel_ready_s: (render_start - started).as_secs_f64(),
        },
        ready,
        retiring: false,
    };
    render_loop
        .run(&mut inbox, results, cfg.idle_probe, cfg.adopt_wait)
        .await
}

/// A scene ready to render.
struct ReadyScene {
    scene: Arc<Scene>,
    accel: Arc<Accel>,
    settings: Settings,
    /// How its model came (and whether the accelerator was read from the cache).
    fetch: proto::SceneFetch,
    /// Decoding the model and building the accelerator, in seconds.
    preprocess_s: f64,
    /// When the model was decoded.
    scene_at: Instant,
}

/// The Scene message made ready: its settings checked (before anything is fetched or
/// allocated for them); then the host's prepared scene mapped, as it is or once a keeper
/// made it ([`prepared_scene`]); failing that, its model fetched through this host's remd
/// (cached there for the next worker or job) and its accelerator built or read. The
/// controller hears of each stage (Preparing), so a node that renders nothing says why.
async fn ready_scene(scene_msg: proto::Scene, link: &Link) -> Result<ReadyScene, WorkerError> {
    let t0 = Instant::now();
    if let Some(path) = prepared_scene::path_of(&scene_msg)? {
        if let Some(ready) = prepared_scene::ready(&scene_msg, path, t0, link).await {
            return Ok(ready);
        }
    }
    link.preparing(proto::preparing::Stage::Fetching, None)
        .await?;
    let client = RemClient::from_env().await?;
    let (scene, mut fetch) = model_chunks::fetch_scene(&client, &scene_msg)
        .await
        .map_err(|e| WorkerError::BadScene(format!("cannot get the scene's model: {e}")))?;
    let t_pre = Instant::now();
    link.preparing(proto::preparing::Stage::Building, Some(&fetch))
        .await?;
    let (scene, accel, settings, accel_cached) =
        tokio::task::spawn_blocking(move || prepare(scene_msg, scene))
            .await
            .unwrap_or_else(|e| {
                Err(WorkerError::BadScene(format!(
                    "preparing the scene panicked: {e}"
                )))
            })?;
    fetch.accel_cached = accel_cached;
    fetch.scene_ready_s = t0.elapsed().as_secs_f64();
    Ok(ReadyScene {
        scene,
        accel,
        settings,
        fetch,
        preprocess_s: t_pre.elapsed().as_secs_f64(),
        scene_at: t_pre,
    })
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

    /// Tells the controller what the worker is doing before its first Request (and, once
    /// the model is in, how it came).
    async fn preparing(
        &self,
        stage: proto::preparing::Stage,
        fetch: Option<&proto::SceneFetch>,
    ) -> Result<(), WorkerError> {
        self.send(Body::Preparing(proto::Preparing {
            stage: stage as i32,
            fetch: fetch.cloned(),
        }))
        .await
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
    use super::render_threads;

    #[test]
    fn a_worker_renders_with_the_slots_it_was_granted() {
        assert_eq!(
            render_threads(None, None, 8),
            8,
            "every core outside the farm"
        );
        assert_eq!(render_threads(Some(3), None, 8), 3);
        assert_eq!(render_threads(None, Some("2"), 8), 2, "REM's grant");
        assert_eq!(
            render_threads(Some(4), Some("2"), 8),
            2,
            "never more than granted"
        );
        assert_eq!(render_threads(Some(1), Some("2"), 8), 1, "nor than asked");
        assert_eq!(render_threads(None, Some("junk"), 8), 8);
        assert_eq!(render_threads(None, Some("0"), 0), 1);
    }
}
