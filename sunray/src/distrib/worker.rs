//! The worker (`sunray worker`, the process REM starts): attaches to its local remd, says
//! Ready, receives the compiled model through REM (no shared file system), builds its
//! accelerator, then loops: request, render, report.
//!
//! It keeps one line in flight per render thread plus one prefetched, so a thread need not
//! wait for the network: it asks for `threads + 1` lines once, then for one more with each
//! completion. When lines are quicker than the round trip to the controller and a thread
//! still had to wait, it asks for one extra line ([`Window`]), up to [`MAX_WINDOW`]. With
//! nothing to do it sends `Request(0)` now and then, which tells it (by an Undeliverable
//! notice) when its controller is gone. It obeys only its job's owner.

use super::messages::{self, proto, Body, Settings};
use super::pool::{LineJob, PoolScene, RenderPool, Rendered};
use crate::accel::Accel;
use crate::scene::Scene;
use crate::stats::process_cpu_seconds;
use rem::{Incoming, ProcId, Relay, RelayReceiver, RelaySender};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

/// How a worker runs.
#[derive(Clone, Debug)]
pub struct WorkerConfig {
    /// Render threads; `None` = every core of this host.
    pub threads: Option<usize>,
    /// How often an idle worker checks that its controller is still there.
    pub idle_probe: Duration,
    /// Extra time per line (test and benchmark hook: a slow worker).
    pub line_delay: Duration,
}

impl Default for WorkerConfig {
    fn default() -> Self {
        WorkerConfig {
            threads: None,
            idle_probe: Duration::from_secs(2),
            line_delay: Duration::ZERO,
        }
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WorkerError {
    #[error("REM: {0}")]
    Rem(#[from] rem::Error),
    #[error("no job owner (REM_OWNER_ID is not set): workers are started by `sunray submit`")]
    NoOwner,
    #[error("the controller is gone")]
    ControllerGone,
    #[error("bad scene from the controller: {0}")]
    BadScene(String),
    #[error("cannot start render threads: {0}")]
    Threads(std::io::Error),
}

/// Runs a worker until the controller says NoMoreWork (Ok) or goes away (Err).
pub async fn run(cfg: WorkerConfig) -> Result<(), WorkerError> {
    let started = Instant::now();
    let relay = Relay::attach_from_env().await?;
    let owner = relay.owner().cloned().ok_or(WorkerError::NoOwner)?;
    let host = relay.host().to_string();
    let (sender, receiver) = relay.split();
    let link = Link {
        sender,
        owner: owner.clone(),
    };
    let mut inbox = spawn_reader(receiver);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = cfg.threads.unwrap_or(cores).max(1);
    link.send(Body::Ready(proto::Ready {
        host,
        cores: cores as u32,
        load_avg: load_average(),
        pid: std::process::id(),
        threads: threads as u32,
    }))
    .await?;

    let scene_msg = loop {
        match next_from_owner(&mut inbox, &owner).await? {
            Body::Scene(s) => break s,
            Body::NoMoreWork(_) => return Ok(()),
            _ => {}
        }
    };
    let t_pre = Instant::now();
    let prepared = tokio::task::spawn_blocking(move || prepare(scene_msg))
        .await
        .map_err(|e| WorkerError::BadScene(format!("preparing the scene panicked: {e}")))?;
    let (scene, accel, settings) = match prepared {
        Ok(p) => p,
        Err(e) => {
            let _ = link
                .send(Body::WorkerError(proto::WorkerError {
                    message: e.to_string(),
                }))
                .await;
            return Err(e);
        }
    };
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
    link.send(Body::Request(proto::Request {
        lines: threads as u32 + 1,
        preprocess_s,
    }))
    .await?;

    let mut outstanding = 0usize;
    let (mut wait_s, mut first_wait_s) = (0.0, 0.0);
    let mut window = Window::new(threads);
    let mut probe = tokio::time::interval(cfg.idle_probe);
    probe.tick().await;
    loop {
        tokio::select! {
            body = next_from_owner(&mut inbox, &owner) => match body? {
                Body::Assign(a) if pool.submit(LineJob { line: a.line, grant: a.grant }) => {
                    outstanding += 1;
                }
                Body::NoMoreWork(_) => return Ok(()),
                _ => {}
            },
            r = results.recv() => {
                let Some(r) = r else { return Err(WorkerError::BadScene("render threads stopped".into())) };
                outstanding = outstanding.saturating_sub(1);
                if r.first {
                    first_wait_s += r.wait_s;
                } else {
                    wait_s += r.wait_s;
                }
                let want = window.after(&r);
                let mut counters = proto::Counters::from(&r.counters);
                counters.line_s = r.line_s;
                link.send(Body::Done(proto::Done {
                    line: r.job.line,
                    grant: r.job.grant,
                    pixels: messages::pixels_to_bytes(&r.pixels),
                    counters: Some(counters),
                    want,
                    clock: Some(proto::NodeClock {
                        cpu_s: process_cpu_seconds(),
                        elapsed_s: started.elapsed().as_secs_f64(),
                        preprocess_s,
                        render_s: render_start.elapsed().as_secs_f64(),
                        wait_s,
                        first_wait_s,
                    }),
                }))
                .await?;
            }
            _ = probe.tick() => {
                if outstanding == 0 {
                    link.send(Body::Request(proto::Request { lines: 0, preprocess_s })).await?;
                }
            }
        }
    }
}

/// The most lines a worker holds at once.
pub const MAX_WINDOW: u32 = 64;

/// How many lines a worker keeps: `threads + 1`, doubled (up to [`MAX_WINDOW`]) each time a
/// thread had to wait for its next line longer than a quarter of a line's render time, so
/// the window quickly covers a round trip that is longer than a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub lines: u32,
}

impl Window {
    pub fn new(threads: usize) -> Window {
        Window {
            lines: (threads as u32).saturating_add(1).min(MAX_WINDOW),
        }
    }

    /// Lines to ask for after `r` is done: 1, or more to grow the window.
    pub fn after(&mut self, r: &Rendered) -> u32 {
        let starved = !r.first && r.wait_s > 0.25 * r.line_s;
        let grow = if starved {
            self.lines.min(MAX_WINDOW - self.lines)
        } else {
            0
        };
        self.lines += grow;
        1 + grow
    }
}

/// Decodes the model and settings and builds the accelerator.
fn prepare(msg: proto::Scene) -> Result<(Arc<Scene>, Arc<Accel>, Settings), WorkerError> {
    let settings = msg
        .settings
        .as_ref()
        .ok_or_else(|| WorkerError::BadScene("no render settings".into()))
        .and_then(|s| Settings::from_proto(s).map_err(|e| WorkerError::BadScene(e.to_string())))?;
    let world = yari::modelfile::from_bytes(&msg.model)
        .map_err(|e| WorkerError::BadScene(e.to_string()))?;
    let scene = Scene::new(world);
    let accel = Accel::build(&scene.prims, &settings.accel);
    Ok((Arc::new(scene), Arc::new(accel), settings))
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

    fn rendered(first: bool, wait_s: f64, line_s: f64) -> Rendered {
        Rendered {
            job: LineJob { line: 0, grant: 1 },
            pixels: Vec::new(),
            counters: Counters::default(),
            line_s,
            wait_s,
            first,
        }
    }

    #[test]
    fn the_window_grows_only_when_a_thread_starved() {
        let mut w = Window::new(2);
        assert_eq!(w.lines, 3);
        assert_eq!(w.after(&rendered(true, 1.0, 0.01)), 1, "start-up wait");
        assert_eq!(w.after(&rendered(false, 0.001, 0.01)), 1, "short wait");
        assert_eq!(w.after(&rendered(false, 0.005, 0.01)), 4, "doubled: 3 more");
        assert_eq!(w.lines, 6);
        for _ in 0..10 {
            w.after(&rendered(false, 1.0, 0.01));
        }
        assert_eq!(w.lines, MAX_WINDOW);
        let mut w = Window::new(100);
        assert_eq!(w.lines, MAX_WINDOW);
        assert_eq!(w.after(&rendered(false, 1.0, 0.01)), 1, "capped");
    }
}
