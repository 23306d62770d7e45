//! What the controller does of itself, besides what comes in ([`incoming`](super::incoming)):
//! hand out lines (one Assign per node), the tick (silent workers, checkpoints, the preview,
//! the web view), and winding down when the image is done or no worker is left.

use super::link::WorkerLink;
use super::store_writer::Report;
use super::ControllerError;
use super::{Controller, Input, JobResult};
use crate::distrib::checkpoint::CheckpointError;
use crate::distrib::grants::NodeState;
use crate::distrib::line_passes::LinePasses;
use crate::distrib::messages::{self, proto, Body};
use crate::distrib::nodes::{ControllerCost, Outcome, Stage};
use crate::distrib::web_view::live_factor;
use crate::film::Film;
use serde_json::json;
use std::time::Duration;
use tokio::sync::mpsc;
use tokio::time::Instant;

/// How many times the job's last save is tried ([`Controller::save_final`]).
pub(super) const FINAL_SAVE_TRIES: u32 = 20;
/// The pause between two tries of the last save: with [`FINAL_SAVE_TRIES`], 10 s, longer
/// than a replica's stop in the chaos test (up to 4 s) or a daemon's restart.
pub(super) const FINAL_SAVE_PAUSE: Duration = Duration::from_millis(500);

/// A save goes no sooner after the one before than this many times what that one took: a
/// render to an error's saves write every line's estimates after each pass (149 bytes a
/// pixel; 35 MB a save, 0.3-0.5 s of REM's work on the controller's host, for the built-in
/// scene at 512 x 512, E = 0.01), so at most about a tenth of the time goes to them.
const SAVE_SPACING: u32 = 10;
/// ... but never further apart than this (or `checkpoint_every`, if longer): a save slowed
/// by a stopped replica does not leave the job without one for long after.
const MAX_SAVE_GAP: Duration = Duration::from_secs(10);

/// When the controller last asked for a save, and what the last stored one took.
#[derive(Debug)]
pub(super) struct SaveClock {
    asked: Instant,
    took: Duration,
}

impl SaveClock {
    pub(super) fn new() -> SaveClock {
        SaveClock {
            asked: Instant::now(),
            took: Duration::ZERO,
        }
    }

    /// Whether the next save is due, saves being asked for every `every`.
    fn due(&self, every: Duration) -> bool {
        save_due(self.asked.elapsed(), every, self.took)
    }
}

/// Whether a save is due `since` the last one began, saves being asked for `every` so long
/// and the last one having taken `took`.
fn save_due(since: Duration, every: Duration, took: Duration) -> bool {
    let gap = took
        .saturating_mul(SAVE_SPACING)
        .min(MAX_SAVE_GAP)
        .max(every);
    since >= gap
}

impl<L: WorkerLink> Controller<L> {
    pub(super) fn cost(&self) -> ControllerCost {
        let cpu_s = crate::stats::process_cpu_seconds() - self.cpu_at_start;
        let lines = f64::from(self.lines.rendered.max(1));
        let messages = (self.messages_in + self.messages_out) as f64;
        ControllerCost {
            cpu_s,
            messages_in: self.messages_in,
            messages_out: self.messages_out,
            cpu_ms_per_line: cpu_s * 1000.0 / lines,
            messages_per_line: messages / lines,
        }
    }

    /// The job's result as it stands (the image and figures are copies).
    pub(super) fn result(&mut self, finished: bool, stored: bool) -> JobResult {
        let film = self.film.clone();
        let passes = self.passes.clone();
        self.result_with((finished, stored), film, passes)
    }

    /// The job's result at its end: the image and the pixels' estimates are moved out, not
    /// copied.
    pub(super) fn into_result(mut self, finished: bool, stored: bool) -> JobResult {
        let film = std::mem::replace(&mut self.film, Film::new(0, 0));
        let passes = self.passes.take();
        self.result_with((finished, stored), film, passes)
    }

    fn result_with(
        &mut self,
        (finished, stored): (bool, bool),
        film: Film,
        passes: Option<LinePasses>,
    ) -> JobResult {
        let counts = self.table.counts();
        self.lines.requeued = counts.requeued;
        self.lines.released = counts.released;
        self.lines.duplicated = counts.duplicated;
        self.lines.dropped = counts.dropped;
        self.lines.finished = self.table.done();
        JobResult {
            film,
            nodes: self.nodes.clone(),
            counters: self.counters,
            lines: self.lines.clone(),
            elapsed_s: self.started.elapsed().as_secs_f64(),
            finished,
            stored,
            cost: self.cost(),
            timeline: self.timeline.clone(),
            passes,
        }
    }

    pub(super) fn timeout(&self) -> Duration {
        self.cfg
            .worker_timeout
            .unwrap_or_else(|| Duration::from_secs_f64((20.0 * self.max_line_s).max(10.0)))
    }

    pub(super) fn on_tick(&mut self) {
        let now = Instant::now();
        let mut silent = self.table.expire(now, self.timeout());
        // A worker says Ready as soon as it is attached; one that has not within the timeout
        // hangs (or its host is stuck) and must not keep the job waiting for it.
        if self.started.elapsed() > self.timeout() {
            for i in 0..self.nodes.len() {
                if self.nodes[i].outcome == Outcome::Starting && !self.exited[i] {
                    let held = self.table.silence(i);
                    silent.push((i, held));
                }
            }
        }
        for (i, held) in silent {
            let n = &mut self.nodes[i];
            n.outcome = Outcome::Silent;
            n.lines_given_back += held as u64;
            self.view.event(
                json!({"event": "silent", "node": i + 1, "host": n.host, "given_back": held}),
            );
        }
        if self.unsaved && self.saves.due(self.cfg.checkpoint_every) {
            self.saves.asked = Instant::now();
            self.unsaved = false;
            self.writer.save("running");
        }
        self.view.preview(&self.film, false);
        self.view.set_workers(self.table.active_nodes());
        self.publish(false);
    }

    /// Hands the job's publication for remd's web view to the store writer if it has one
    /// and one is due (or `last`; the first tick is the start).
    pub(super) fn publish(&mut self, last: bool) {
        let done = self.table.done();
        let Some(web) = self.view.web_mut() else {
            return;
        };
        web.set_timeline(&self.timeline);
        let max_bytes = self.link.max_bytes();
        if let Some(mut p) = web.take_due(&self.nodes, &self.film, (done, last), max_bytes) {
            if let Some(passes) = &self.passes {
                let a = passes.adaptive();
                let caption = format!(
                    "samples per pixel so far: black {}, white {} (log scale)",
                    a.min_samples, a.max_samples
                );
                // While the job runs, at the size the image is published (no full-size film).
                let step = if last {
                    1
                } else {
                    live_factor(self.film.width, self.film.height)
                };
                let map = passes.samples_map_every(step);
                p.add_view(("samples", &caption), &map, last, max_bytes);
            }
            self.writer.publish(p);
        }
    }

    /// Saves the checkpoint in `state` and waits for it (the end of the job: the image is
    /// the user's once stored); whether it was stored.
    pub(super) async fn save_now(&mut self, state: &str) -> bool {
        self.saves.asked = Instant::now();
        let id = self.writer.save(state);
        while let Some(report) = self.writer.reports.recv().await {
            let answers = report.save_id() == Some(id);
            let saved = matches!(report, Report::Saved { .. });
            self.on_report(report);
            if answers {
                return saved;
            }
        }
        false
    }

    /// The job's last save, in `state`, tried again while it fails, up to
    /// [`FINAL_SAVE_TRIES`] times [`FINAL_SAVE_PAUSE`] apart: the lines a failed save held go
    /// in the next save, and after the last there is none, so a last save refused for a
    /// moment (a replica stopped or restarting) left a finished job's stored checkpoint
    /// without its last lines (seen in the chaos test: 62 of 64). True once stored.
    pub(super) async fn save_final(&mut self, state: &str) -> bool {
        for _ in 0..FINAL_SAVE_TRIES {
            if self.save_now(state).await {
                return true;
            }
            if self.superseded.is_some() {
                return false;
            }
            tokio::time::sleep(FINAL_SAVE_PAUSE).await;
        }
        false
    }

    /// What came of a write. A failure never stops the job: a checkpoint's is a warning
    /// (its lines go in the next save), a publication's is one the first time; a refusal
    /// for a newer epoch stands this controller down.
    pub(super) fn on_report(&mut self, report: Report) {
        match report {
            Report::Saved {
                state, lines, took, ..
            } => {
                self.saves.took = took;
                self.view
                    .event(json!({"event": "checkpoint", "state": state, "lines": lines}));
            }
            Report::SaveFailed {
                error: CheckpointError::Rem(e),
                ..
            } if e.is_fenced() => self.superseded = Some(e.to_string()),
            Report::SaveFailed { error, .. } => {
                self.unsaved = true;
                self.view
                    .note(&format!("sunray: warning: checkpoint: {error}"));
            }
            Report::Published => {}
            Report::PublishFailed(e) => {
                let tell = self.view.web_mut().is_some_and(|w| w.failed(&e));
                if e.is_fenced() {
                    self.superseded = Some(e.to_string());
                } else if tell {
                    let error = e.to_string();
                    self.view
                        .note(&format!("sunray: warning: web view: {error}"));
                    self.view
                        .event(json!({"event": "warning", "about": "web view", "error": error}));
                }
            }
        }
    }

    /// Sends out whatever the table can hand out now: one Assign per node with every line it
    /// gets, or as many as the relay's message limit needs.
    pub(super) async fn dispatch(&mut self) -> Result<(), ControllerError> {
        let now = Instant::now();
        let mut out = self.table.assign(now);
        let min_age = Duration::from_secs_f64(2.0 * self.max_line_s + 0.25);
        out.extend(self.table.duplicate_stragglers(now, min_age));
        for node in 0..self.procs.len() {
            let sparse = self.nodes[node].sparse_passes;
            let lines: Vec<proto::LineGrant> = out
                .iter()
                .filter(|a| a.node == node)
                .map(|a| {
                    let (estimates, columns) = self
                        .passes
                        .as_mut()
                        .map(|p| p.grant_bytes(a.line, a.pass, sparse))
                        .unwrap_or_default();
                    proto::LineGrant {
                        line: a.line,
                        grant: a.grant,
                        duplicate: a.duplicate,
                        pass: a.pass,
                        estimates,
                        columns,
                    }
                })
                .collect();
            let echo_s = self.stamps_to_echo[node].unwrap_or(0.0);
            for msg in messages::assigns(lines, echo_s, self.link.max_message()) {
                let first = !self.assigned_once[node];
                match self.link.send(&self.procs[node], msg).await {
                    Ok(()) => {
                        self.messages_out += 1;
                        if first {
                            self.assigned_once[node] = true;
                            self.view
                                .event(json!({"event": "assign", "node": node + 1, "first": true}));
                        }
                    }
                    Err(rem::Error::Closed) => return Err(rem::Error::Closed.into()),
                    Err(e) => {
                        self.on_gone(node, format!("cannot send: {e}"), false);
                        break;
                    }
                }
            }
        }
        // Lines handed out later (when some came back to the queue) answer no message.
        self.stamps_to_echo.fill(None);
        Ok(())
    }

    pub(super) fn no_worker_left(&mut self) -> bool {
        if self.table.live_nodes() == 0 {
            // With a crew the site starts workers as the job's share allows: none for now is
            // a job waiting in the queue, unless its workers keep failing.
            return self
                .cfg
                .crew
                .as_ref()
                .is_none_or(|c| c.view().faults >= super::FAULTS_WITH_A_CREW);
        }
        if self.table.active_nodes() > 0 {
            self.all_silent_since = None;
            return false;
        }
        let since = *self.all_silent_since.get_or_insert_with(Instant::now);
        since.elapsed() > self.timeout()
    }

    /// Tells every worker still there to stop, waits a bounded time for them to exit
    /// (`finish_grace`; `fetch_grace` for one still fetching its scene; late completions are
    /// counted as dropped), then kills the rest.
    pub(super) async fn wind_down(&mut self, inbox: &mut mpsc::Receiver<Input>) {
        self.finishing = true;
        let stop = messages::encode(Body::NoMoreWork(proto::NoMoreWork {}));
        for i in 0..self.procs.len() {
            if !self.exited[i] && self.link.send(&self.procs[i], stop.clone()).await.is_ok() {
                self.messages_out += 1;
            }
        }
        // Asked again after every message and at every deadline: a worker that finishes
        // building meanwhile says so, sees NoMoreWork and exits, and is waited for like the
        // others; one still fetching is waited for longer (its keeper needs the whole model).
        let began = Instant::now();
        loop {
            let until = (0..self.procs.len())
                .filter(|&i| self.waits_for(i))
                .map(|i| match self.nodes[i].stage {
                    Stage::Fetching => began + self.cfg.fetch_grace,
                    _ => began + self.cfg.finish_grace,
                })
                .filter(|&d| d > Instant::now())
                .min();
            let Some(until) = until else { break };
            match tokio::time::timeout_at(until, inbox.recv()).await {
                Ok(Some(Input::Relay(Ok(incoming)))) => self.on_incoming(incoming),
                // The job is done: workers started meanwhile are not needed.
                Ok(Some(Input::Workers(late, _))) => {
                    for w in late {
                        self.link.kill(&w.proc_id).await;
                    }
                }
                Ok(Some(Input::Retire { .. })) => {}
                Ok(_) => break,
                Err(_) => {}
            }
        }
        for i in 0..self.procs.len() {
            if !self.exited[i] {
                // One still building was not needed, not silent: its keeper goes on.
                if self.waits_for(i) {
                    self.nodes[i].outcome = Outcome::Silent;
                }
                self.link.kill(&self.procs[i]).await;
            }
        }
    }

    fn waits_for(&self, i: usize) -> bool {
        waited_for(
            self.exited[i],
            self.table.node_state(i),
            self.nodes[i].stage,
        )
    }
}

/// Whether the wind-down waits for a worker to exit: one that has not, is active (a silent
/// one is not waited for) and is not building its scene. A worker building has told how its
/// model came, and its host's keeper (a process group of its own, with the whole model)
/// finishes the prepared scene whether the worker is stopped or not; one still fetching is
/// waited for, so that its keeper gets the whole model.
pub(super) fn waited_for(exited: bool, state: Option<NodeState>, stage: Stage) -> bool {
    !exited && state == Some(NodeState::Active) && stage != Stage::Building
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saves_that_take_long_come_further_apart() {
        let ms = Duration::from_millis;
        let every = ms(2000);
        // Quick saves: every 2 s.
        assert!(!save_due(ms(1999), every, ms(50)));
        assert!(save_due(ms(2000), every, ms(50)));
        // A save of 0.4 s: the next after 4 s.
        assert!(!save_due(ms(3999), every, ms(400)));
        assert!(save_due(ms(4000), every, ms(400)));
        // A save held 30 s by a stopped replica: the next 10 s after, not 300.
        assert!(!save_due(ms(9_999), every, ms(30_000)));
        assert!(save_due(ms(10_000), every, ms(30_000)));
        // Asked for less often than the cap: as asked.
        assert!(!save_due(ms(25_000), ms(60_000), ms(30_000)));
    }
}
