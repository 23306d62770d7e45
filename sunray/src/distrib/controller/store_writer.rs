//! The controller's writes to REM's store, off its actor: two tasks, one for the checkpoint
//! and one for the web view's publications. A replica peer that is slow or frozen delays
//! what is durable and what the page shows, never a line grant or the judgement of a silent
//! worker (the actor only hands work over and reads what came of it).
//!
//! Each kind has a mailbox of one: the newest request of a kind replaces the one not yet
//! taken (a checkpoint's state, a publication), except the lines finished since the last
//! save, which add up (each line once: with a target error a line's later pass replaces its
//! earlier one, counters summed, so they are bounded by the image). What came of a request
//! comes back as a [`Report`] on a small bounded channel the actor reads.

use super::link::WorkerLink;
use crate::distrib::checkpoint::{keep_latest, CheckpointError, Checkpointer};
use crate::distrib::messages::proto::FinishedLine;
use crate::distrib::web_view::{Publication, WebError};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};
use tokio::sync::{mpsc, Notify};
use tokio::task::JoinHandle;

/// What came of a request.
#[derive(Debug)]
pub(super) enum Report {
    /// Save `id` stored the checkpoint in `state`, with `lines` lines in it, in `took`.
    Saved {
        id: u64,
        state: String,
        lines: u32,
        took: Duration,
    },
    /// Save `id` failed (the next save tries its lines again).
    SaveFailed { id: u64, error: CheckpointError },
    /// A publication was stored.
    Published,
    /// A publication failed.
    PublishFailed(WebError),
}

impl Report {
    /// The save this report answers, if it answers one.
    pub(super) fn save_id(&self) -> Option<u64> {
        match self {
            Report::Saved { id, .. } | Report::SaveFailed { id, .. } => Some(*id),
            _ => None,
        }
    }
}

/// A save asked for.
struct SaveRequest {
    id: u64,
    state: String,
}

/// What waits to be taken by the two tasks.
#[derive(Default)]
struct Mailbox {
    /// Lines in since the save task last took them (each line's latest record), and how
    /// many of them are finished.
    lines: BTreeMap<u32, FinishedLine>,
    finished: u32,
    save: Option<SaveRequest>,
    publication: Option<Publication>,
    /// No more requests: each task ends once its mailbox is empty.
    closed: bool,
}

struct Shared {
    mailbox: Mutex<Mailbox>,
    saves: Notify,
    publications: Notify,
}

impl Shared {
    fn mailbox(&self) -> MutexGuard<'_, Mailbox> {
        // Nothing in the mailbox is left half-changed by a panic elsewhere.
        self.mailbox.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// The actor's side: requests go in, [`Report`]s come out of `reports`.
pub(super) struct StoreWriter {
    shared: Arc<Shared>,
    /// What came of the requests.
    pub(super) reports: mpsc::Receiver<Report>,
    tasks: Vec<JoinHandle<()>>,
    next_id: u64,
}

impl StoreWriter {
    /// Starts the two tasks on `link`'s store; `checkpointed` (if any) is set to the lines
    /// in the checkpoint after each save.
    pub(super) fn start<L: WorkerLink>(
        link: Arc<L>,
        checkpointer: Checkpointer,
        checkpointed: Option<Arc<AtomicU32>>,
    ) -> StoreWriter {
        let shared = Arc::new(Shared {
            mailbox: Mutex::new(Mailbox::default()),
            saves: Notify::new(),
            publications: Notify::new(),
        });
        let (tx, reports) = mpsc::channel(8);
        let tasks = vec![
            tokio::spawn(save_task(
                shared.clone(),
                link.clone(),
                checkpointer,
                checkpointed,
                tx.clone(),
            )),
            tokio::spawn(publish_task(shared.clone(), link, tx)),
        ];
        StoreWriter {
            shared,
            reports,
            tasks,
            next_id: 0,
        }
    }

    /// A line in, for the next save: `finished`, or a pass after which it needs another.
    pub(super) fn record(&self, line: FinishedLine, finished: bool) {
        let mut m = self.shared.mailbox();
        keep_latest(&mut m.lines, line);
        m.finished += u32::from(finished);
    }

    /// Asks for a save in `state` (replacing one not yet begun); its id, for the
    /// [`Report`] that answers it.
    pub(super) fn save(&mut self, state: &str) -> u64 {
        self.next_id += 1;
        self.shared.mailbox().save = Some(SaveRequest {
            id: self.next_id,
            state: state.to_string(),
        });
        self.shared.saves.notify_one();
        self.next_id
    }

    /// Hands a publication over (replacing one not yet begun).
    pub(super) fn publish(&self, publication: Publication) {
        self.shared.mailbox().publication = Some(publication);
        self.shared.publications.notify_one();
    }

    /// No more requests: waits for the tasks to do what they were given; the reports they
    /// sent meanwhile (one per request at most, so few).
    pub(super) async fn close(&mut self) -> Vec<Report> {
        self.shared.mailbox().closed = true;
        self.shared.saves.notify_one();
        self.shared.publications.notify_one();
        // The tasks end when their mailbox is empty, and drop their senders then.
        let mut reports = Vec::new();
        while let Some(report) = self.reports.recv().await {
            reports.push(report);
        }
        for t in self.tasks.drain(..) {
            let _ = t.await;
        }
        reports
    }
}

impl Drop for StoreWriter {
    /// A controller that ends early (superseded, its relay lost) writes nothing more.
    fn drop(&mut self) {
        for t in &self.tasks {
            t.abort();
        }
    }
}

async fn save_task<L: WorkerLink>(
    shared: Arc<Shared>,
    link: Arc<L>,
    mut checkpointer: Checkpointer,
    checkpointed: Option<Arc<AtomicU32>>,
    reports: mpsc::Sender<Report>,
) {
    loop {
        let (lines, finished, save, closed) = {
            let mut m = shared.mailbox();
            let lines = std::mem::take(&mut m.lines);
            (
                lines,
                std::mem::take(&mut m.finished),
                m.save.take(),
                m.closed,
            )
        };
        checkpointer.record_lines(lines, finished);
        if let Some(SaveRequest { id, state }) = save {
            let began = Instant::now();
            let report = match checkpointer.save(&*link, &state).await {
                Ok(()) => {
                    let lines = checkpointer.lines_done();
                    if let Some(c) = &checkpointed {
                        c.store(lines, Ordering::Relaxed);
                    }
                    Report::Saved {
                        id,
                        state,
                        lines,
                        took: began.elapsed(),
                    }
                }
                Err(error) => Report::SaveFailed { id, error },
            };
            if reports.send(report).await.is_err() {
                return;
            }
            // A request may have come during the write.
            continue;
        }
        if closed {
            return;
        }
        shared.saves.notified().await;
    }
}

async fn publish_task<L: WorkerLink>(
    shared: Arc<Shared>,
    link: Arc<L>,
    reports: mpsc::Sender<Report>,
) {
    loop {
        let (publication, closed) = {
            let mut m = shared.mailbox();
            (m.publication.take(), m.closed)
        };
        if let Some(p) = publication {
            let report = match p.write(&*link).await {
                Ok(()) => Report::Published,
                Err(e) => Report::PublishFailed(e),
            };
            if reports.send(report).await.is_err() {
                return;
            }
            continue;
        }
        if closed {
            return;
        }
        shared.publications.notified().await;
    }
}
