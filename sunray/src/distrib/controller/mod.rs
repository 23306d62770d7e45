//! The controller actor (thesis Figure 4.7): a tokio task that owns the grant table, the
//! image, the node statistics and the checkpoint. It is fed by the REM relay (worker
//! messages and job events) through a bounded channel, hands out lines, takes completions
//! (first one wins), gives back the lines of failed or silent workers, duplicates
//! stragglers at the end, checkpoints every few seconds and, when every line is in, tells
//! the workers to stop. The image is the user's as soon as it is stored: the handle's
//! `image` has the job's result then, before the workers have wound down.
//!
//! # Layout
//! - [`incoming`]: what the actor is fed ([`Input`]); what the relay delivers (worker
//!   messages, job events).
//! - [`resume`]: what a job resumed from its checkpoint starts from.
//! - [`actions`]: what the controller does of itself (Assign, the tick, winding down).
//! - [`crew`]: the live workers and their slots, for the farm's share keeper, which adds
//!   workers ([`Input::Workers`]) and retires them ([`Input::Retire`]) while the job runs;
//!   the workers themselves ([`WorkerProc`]).
//! - [`staff`]: workers joining the running job, and retiring from it.
//! - [`link`]: how it reaches the workers and REM's store (REM, or a fake in tests).
//! - [`store_writer`]: the checkpoint and web view writes, on tasks of their own so that a
//!   slow store never holds up a grant or the judgement of a silent worker.

mod actions;
pub mod crew;
mod incoming;
pub use incoming::Input;
pub mod link;
mod resume;
mod staff;
mod store_writer;
#[cfg(test)]
mod tests;

use crate::distrib::checkpoint::{Checkpointer, Restored};
use crate::distrib::grants::GrantTable;
use crate::distrib::line_passes::LinePasses;
use crate::distrib::nodes::{ControllerCost, LineCounts, NodeStats};
use crate::distrib::progress::ProgressView;
use crate::distrib::strategy::Strategy;
use crate::distrib::timeline::{JobClock, Timeline};
use crate::distrib::web_view::{self, WebView};
use crate::film::Film;
use crate::render::adaptive::Adaptive;
use crate::stats::Counters;
pub use crew::{load_per_core, WorkerProc};
use link::{RemLink, WorkerLink};
use rem::{ProcId, RelayReceiver, RelaySender, RemClient};
use serde_json::json;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;
use store_writer::StoreWriter;
use tokio::sync::{mpsc, oneshot};
use tokio::time::Instant;

/// How the controller runs.
#[derive(Clone, Debug)]
pub struct ControllerConfig {
    /// The job id: the key of its checkpoint and the name in events and logs.
    pub job: String,
    /// How lines are handed out: SunRay I blocks, SunRay II interleaved or SunRay III dynamic.
    pub strategy: Strategy,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels: the number of lines to hand out.
    pub height: u32,
    /// The encoded Scene message every worker gets first.
    pub scene: Vec<u8>,
    /// A worker whose oldest line is older than this is silent; `None` = 10 s or 20 times
    /// the slowest line seen, whichever is longer.
    pub worker_timeout: Option<Duration>,
    /// How often the grant table and finished lines are checkpointed (`--checkpoint-ms`).
    pub checkpoint_every: Duration,
    /// Where to rewrite the partial image (`--preview FILE`); `None` writes no preview.
    pub preview: Option<std::path::PathBuf>,
    /// How often the preview is rewritten (`--preview-ms`).
    pub preview_every: Duration,
    /// Draw a progress bar on stderr (a terminal, and not `--quiet`).
    pub show_bar: bool,
    /// Print JSON events, one per line, on stderr instead of the bar (`--events`).
    pub events: bool,
    /// How long finished workers get to exit before they are killed.
    pub finish_grace: Duration,
    /// How long the end waits for a worker still fetching its scene (its host's keeper, which
    /// a job's end does not stop, needs the whole model to keep the scene for the next job).
    pub fetch_grace: Duration,
    /// Set to the lines in the checkpoint after each save (for whoever reports progress).
    pub checkpointed: Option<std::sync::Arc<std::sync::atomic::AtomicU32>>,
    /// The encoded Adopt message that workers taken over from a previous controller get
    /// instead of the Scene (they have it).
    pub adopt: Option<Vec<u8>>,
    /// `Some(history)`: publish the job for remd's web view (a farm job), its events going on
    /// from `history`; `None` (a job in this process, tests): publish nothing.
    pub web: Option<Vec<web_view::Event>>,
    /// The origin of the job's timeline (its submit).
    pub clock: JobClock,
    /// The job's steps before the actor starts (the controller's own start).
    pub timeline: Timeline,
    /// The job's target error (its lines go out a pass at a time), or `None` (each line once).
    pub adaptive: Option<Adaptive>,
    /// `Some`: the site adds and retires workers while the job runs (the farm's queue), and
    /// sees them here; the job then ends with no worker left only after
    /// [`FAULTS_WITH_A_CREW`] faults. `None`: its workers are those it starts with.
    pub crew: Option<crew::Crew>,
}

/// Faults after which a job whose site adds workers ends when none is left (its controller
/// is then started again by REM, as a job without one is at its first).
pub const FAULTS_WITH_A_CREW: u32 = 4;

/// The end of a job.
#[derive(Debug)]
pub struct JobResult {
    /// The image assembled from the accepted lines (and those of a resumed run).
    pub film: Film,
    /// One row per worker for the per-node table (thesis Table 4.3).
    pub nodes: Vec<NodeStats>,
    /// Over every line of the image, those of a resumed run included.
    pub counters: Counters,
    /// How many lines were resumed, rendered, requeued and duplicated.
    pub lines: LineCounts,
    /// Wall-clock seconds from the actor's start to its end.
    pub elapsed_s: f64,
    /// False when no worker was left to finish the image.
    pub finished: bool,
    /// Whether the job's last checkpoint was stored ([`Controller::save_final`]): a job
    /// finished but not stored has its whole image here, and only part of it on the farm.
    pub stored: bool,
    /// The controller's own CPU time and message counts, in total and per line.
    pub cost: ControllerCost,
    /// The job's steps, in seconds since it was submitted.
    pub timeline: Timeline,
    /// With a target error: what each pixel took.
    pub passes: Option<LinePasses>,
}

/// Why the controller could not run the job to its end (a job that ends unfinished is not an
/// error).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ControllerError {
    /// The REM relay failed (remd went away or refused a message); shown as one line, the
    /// innermost cause, not the transport's chain.
    #[error("lost the relay to remd: {}", .0.root_cause())]
    Relay(rem::Error),
    /// The actor's task panicked or was cancelled; the text is the join error.
    #[error("the controller task failed: {0}")]
    Task(String),
    /// REM refused a checkpoint because a newer controller (a higher epoch) has the job:
    /// this one stands down.
    #[error("a newer controller has the job: {0}")]
    Superseded(String),
}

impl From<rem::Error> for ControllerError {
    fn from(e: rem::Error) -> Self {
        ControllerError::Relay(e)
    }
}

/// A handle to the running controller: feed it, or wait for its result.
pub struct ControllerHandle {
    /// Feeds the actor. If every sender drops before the image is done, the job ends with
    /// [`ControllerError::Relay`].
    pub tx: mpsc::Sender<Input>,
    /// The actor's task; its value is the job's result.
    pub task: tokio::task::JoinHandle<Result<JobResult, ControllerError>>,
    /// The job's result as it is when its finished image is stored, before the workers
    /// wind down; closed without one when the image was not stored.
    pub image: oneshot::Receiver<JobResult>,
}

impl ControllerHandle {
    /// Drops this handle's sender and waits for the actor's result (a panic becomes
    /// [`ControllerError::Task`]).
    pub async fn join(self) -> Result<JobResult, ControllerError> {
        self.split().1.await
    }

    /// The job's result when its image is stored, and (as [`join`](Self::join)) at its end.
    pub fn split(
        self,
    ) -> (
        oneshot::Receiver<JobResult>,
        impl std::future::Future<Output = Result<JobResult, ControllerError>>,
    ) {
        let ControllerHandle { tx, task, image } = self;
        let joined = async move {
            drop(tx);
            task.await
                .unwrap_or_else(|e| Err(ControllerError::Task(e.to_string())))
        };
        (image, joined)
    }
}

/// Everything the actor starts from.
pub struct Start {
    /// How the job runs.
    pub cfg: ControllerConfig,
    /// The REM client: stores checkpoints and kills workers.
    pub client: RemClient,
    /// The relay half that sends messages to workers.
    pub sender: RelaySender,
    /// The relay half that receives worker messages and job events (fed to the actor by its own
    /// task).
    pub receiver: RelayReceiver,
    /// The workers REM spawned for the job, in the order of the per-node table.
    pub workers: Vec<WorkerProc>,
    /// Lines and state from the checkpoint of an earlier run (`--resume`).
    pub restored: Option<Restored>,
    /// Where checkpoints are written.
    pub checkpointer: Checkpointer,
    /// The job's epoch when the farm runs the controller (0: none; see [`RemLink::epoch`]).
    pub epoch: u64,
}

/// Starts the actor and the task that feeds it from the relay.
pub fn spawn(start: Start) -> ControllerHandle {
    let link = RemLink {
        client: start.client,
        sender: start.sender,
        epoch: start.epoch,
        job: start.cfg.job.clone(),
    };
    let handle = spawn_with(
        start.cfg,
        link,
        start.workers,
        start.restored,
        start.checkpointer,
    );
    let feed = handle.tx.clone();
    let mut receiver = start.receiver;
    tokio::spawn(async move {
        loop {
            let item = receiver.recv().await;
            let end = item.is_err();
            if feed.send(Input::Relay(item)).await.is_err() || end {
                return;
            }
        }
    });
    handle
}

/// Starts the actor on any [`WorkerLink`]; what it is fed goes to the handle's `tx`.
pub fn spawn_with<L: WorkerLink>(
    cfg: ControllerConfig,
    link: L,
    workers: Vec<WorkerProc>,
    restored: Option<Restored>,
    checkpointer: Checkpointer,
) -> ControllerHandle {
    let (tx, rx) = mpsc::channel(256);
    let (image_tx, image) = oneshot::channel();
    let mut c = Controller::new(cfg, link, workers, restored, checkpointer);
    c.image_stored = Some(image_tx);
    ControllerHandle {
        tx,
        task: tokio::spawn(c.run(rx)),
        image,
    }
}

struct Controller<L> {
    cfg: ControllerConfig,
    link: Arc<L>,
    procs: Vec<ProcId>,
    by_proc: HashMap<String, usize>,
    table: GrantTable,
    film: Film,
    /// With a target error: the lines between their passes.
    passes: Option<LinePasses>,
    nodes: Vec<NodeStats>,
    exited: Vec<bool>,
    finishing: bool,
    /// Writes the checkpoint and the web view's publications.
    writer: StoreWriter,
    /// Lines finished since the last save was asked for (or one failed).
    unsaved: bool,
    /// When saves are due ([`actions::SaveClock`]: no more often than a tenth of the time).
    saves: actions::SaveClock,
    counters: Counters,
    lines: LineCounts,
    max_line_s: f64,
    started: Instant,
    cpu_at_start: f64,
    messages_in: u64,
    messages_out: u64,
    /// The clock stamp of the Request or Done just taken from each node, echoed in the
    /// Assign that answers it (the next dispatch), so the worker can time its delay.
    stamps_to_echo: Vec<Option<f64>>,
    view: ProgressView,
    all_silent_since: Option<Instant>,
    /// Set when REM refused a checkpoint for a newer epoch.
    superseded: Option<String>,
    /// Nodes that got their first Assign (an `assign` event marks it).
    assigned_once: Vec<bool>,
    /// Nodes taken over from the previous controller.
    adopted: Vec<bool>,
    /// The job's steps so far.
    timeline: Timeline,
    /// Told the job's result once its finished image is stored.
    image_stored: Option<oneshot::Sender<JobResult>>,
    /// Nodes told to stop to give their slots back (not faults when they exit).
    retiring: Vec<bool>,
    /// The farm's slots each node holds.
    slots: Vec<u32>,
    /// Nodes refused at their Ready (another image version), to be told to stop.
    refused: Vec<usize>,
}

impl<L: WorkerLink> Controller<L> {
    fn new(
        cfg: ControllerConfig,
        link: L,
        workers: Vec<WorkerProc>,
        restored: Option<Restored>,
        checkpointer: Checkpointer,
    ) -> Controller<L> {
        let film = match &restored {
            Some(r) => r.film(cfg.width, cfg.height),
            None => Film::new(cfg.width, cfg.height),
        };
        let resume::Resumed {
            table,
            passes,
            counters,
            resumed,
            records,
        } = resume::resumed(&cfg, workers.len(), restored.as_ref());
        let spawned = Some(cfg.clock.now());
        let timeline = cfg.timeline.clone();
        let link = Arc::new(link);
        let writer = StoreWriter::start(link.clone(), checkpointer, cfg.checkpointed.clone());
        let unsaved = !records.is_empty();
        for (line, finished) in records {
            writer.record(line, finished);
        }
        let nodes = workers
            .iter()
            .enumerate()
            .map(|(i, w)| w.node_row(i, spawned))
            .collect();
        let view = ProgressView::new(
            cfg.height,
            resumed,
            cfg.show_bar,
            cfg.events,
            cfg.preview.clone(),
            cfg.preview_every,
        )
        .with_web(cfg.web.clone().map(|h| WebView::new(&cfg.job, h)));
        Controller {
            table,
            passes,
            by_proc: workers
                .iter()
                .enumerate()
                .map(|(i, w)| (w.proc_id.to_string(), i))
                .collect(),
            procs: workers.iter().map(|w| w.proc_id.clone()).collect(),
            exited: vec![false; workers.len()],
            lines: LineCounts {
                total: cfg.height,
                resumed,
                ..Default::default()
            },
            cfg,
            link,
            film,
            nodes,
            finishing: false,
            writer,
            unsaved,
            saves: actions::SaveClock::new(),
            counters,
            max_line_s: 0.0,
            started: Instant::now(),
            cpu_at_start: crate::stats::process_cpu_seconds(),
            messages_in: 0,
            messages_out: 0,
            stamps_to_echo: vec![None; workers.len()],
            view,
            all_silent_since: None,
            superseded: None,
            assigned_once: vec![false; workers.len()],
            adopted: workers.iter().map(|w| w.adopted).collect(),
            timeline,
            image_stored: None,
            retiring: vec![false; workers.len()],
            slots: workers.iter().map(|w| w.slots).collect(),
            refused: Vec::new(),
        }
    }

    async fn run(mut self, mut inbox: mpsc::Receiver<Input>) -> Result<JobResult, ControllerError> {
        for (i, w) in self.nodes.iter().enumerate() {
            if let Some(crew) = &self.cfg.crew {
                crew.joined(i, &w.host, self.slots[i]);
            }
            self.view
                .event(json!({"event": "spawned", "node": i + 1, "proc": w.proc_id,
                "host": w.host, "pid": w.pid, "adopted": self.adopted[i]}));
        }
        for i in 0..self.procs.len() {
            let first = match &self.cfg.adopt {
                Some(adopt) if self.adopted[i] => adopt.clone(),
                _ => self.cfg.scene.clone(),
            };
            if let Err(e) = self.link.send(&self.procs[i], first).await {
                self.on_gone(i, format!("cannot send the scene: {e}"), false);
            }
        }
        let mut tick = tokio::time::interval(Duration::from_millis(100));
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        while !self.table.is_finished() {
            tokio::select! {
                input = inbox.recv() => {
                    self.on_input(input.ok_or(rem::Error::Closed)?).await?;
                }
                Some(report) = self.writer.reports.recv() => self.on_report(report),
                _ = tick.tick() => {
                    // What came while the actor was busy is read before anyone is judged
                    // silent: silence is the workers', not the controller's own stall.
                    while let Ok(input) = inbox.try_recv() {
                        self.on_input(input).await?;
                    }
                    self.on_tick()
                }
            }
            self.dispatch().await?;
            if let Some(why) = self.superseded.take() {
                return Err(ControllerError::Superseded(why));
            }
            if self.no_worker_left() {
                break;
            }
        }
        let finished = self.table.is_finished();
        let stored = self
            .save_final(if finished { "finished" } else { "failed" })
            .await;
        if finished && stored {
            self.timeline.image_stored = Some(self.cfg.clock.now());
            if let Some(tell) = self.image_stored.take() {
                let mut now = self.result(finished, stored);
                now.timeline.finished = now.timeline.image_stored;
                let _ = tell.send(now);
            }
        }
        self.view.preview(&self.film, true);
        self.wind_down(&mut inbox).await;
        self.view.finish();
        self.timeline.finished = Some(self.cfg.clock.now());
        self.view
            .event(json!({"event": end_event(finished, stored), "done": self.table.done()}));
        self.publish(true);
        for report in self.writer.close().await {
            self.on_report(report);
        }
        Ok(self.into_result(finished, stored))
    }

    /// One item of the inbox: a relay item is handled; the relay's failure ends the job.
    async fn on_input(&mut self, input: Input) -> Result<(), ControllerError> {
        match input {
            Input::Relay(Ok(incoming)) => {
                self.on_incoming(incoming);
                self.stop_refused().await;
            }
            Input::Relay(Err(e)) => return Err(e.into()),
            Input::Workers(workers, done) => {
                self.add_workers(workers).await;
                done.map(|d| d.send(()));
            }
            Input::Retire {
                slots,
                keep_one,
                done,
            } => {
                self.retire(slots, keep_one).await;
                done.map(|d| d.send(()));
            }
        }
        Ok(())
    }
}

/// The web view's event for a job's end: `finished` only when every line is in and the last
/// checkpoint holds them; `not-stored` when every line is in but the store refused the last
/// save (the job is not done: REM starts another controller, or `submit` marks it
/// interrupted); `failed` when lines are missing.
fn end_event(finished: bool, stored: bool) -> &'static str {
    match (finished, stored) {
        (true, true) => "finished",
        (true, false) => "not-stored",
        (false, _) => "failed",
    }
}
