//! What the actor is fed ([`Input`]), and its handling of what the relay delivers: worker
//! messages (Ready, Request, Done, WorkerError), job events (Exited, Lost) and undeliverable
//! notices.

use super::link::WorkerLink;
use super::{Controller, WorkerProc};
use crate::distrib::grants::Completion;
use crate::distrib::line_passes::Decided;
use crate::distrib::messages::{self, proto, Body};
use crate::distrib::nodes::{Outcome, Stage};
use crate::distrib::timeline;
use crate::render::adaptive::PixelEstimate;
use crate::render::image_version;
use crate::stats::Counters;
use rem::{EventKind, Incoming};
use serde_json::json;
use tokio::sync::oneshot;

/// What a Done brings: a line's pixels, or with a target error its estimates after a pass.
enum Payload {
    Pixels(Vec<[f32; 3]>),
    Estimates(Vec<PixelEstimate>),
}

/// What the actor is fed.
#[derive(Debug)]
pub enum Input {
    /// An item from the REM relay: a worker message, a job event, or the relay's failure (which
    /// ends the feed).
    Relay(rem::Result<Incoming>),
    /// Workers started for the job while it runs: they get the Scene and join the table
    /// (told on the oneshot once they have).
    Workers(Vec<WorkerProc>, Option<oneshot::Sender<()>>),
    /// Give back at least `slots` of the job's slots: the newest workers are told to stop
    /// and their lines go back to the queue; one stays when `keep_one`.
    Retire {
        /// Slots to give back.
        slots: u32,
        /// Keep the last worker (the job still has a share).
        keep_one: bool,
        /// Told once they are retired.
        done: Option<oneshot::Sender<()>>,
    },
}

impl<L: WorkerLink> Controller<L> {
    pub(super) fn on_incoming(&mut self, incoming: Incoming) {
        match incoming {
            Incoming::Message { from, payload } => {
                self.messages_in += 1;
                let Some(&i) = self.by_proc.get(&from) else {
                    return;
                };
                match messages::decode(&payload) {
                    Ok(body) => self.on_message(i, body),
                    Err(e) => self
                        .view
                        .event(json!({"event": "bad-message", "node": i + 1,
                        "error": e.to_string()})),
                }
            }
            Incoming::Event(ev) => {
                let Some(&i) = self.by_proc.get(&ev.proc_id) else {
                    return;
                };
                let (reason, clean) = match ev.kind() {
                    EventKind::Exited => match (ev.exit_code, ev.signal) {
                        (_, Some(sig)) => (format!("killed by signal {sig}"), false),
                        (Some(code), _) => (format!("exited with code {code}"), code == 0),
                        _ => ("exited".to_string(), false),
                    },
                    EventKind::Lost => (format!("host {} lost", ev.host), false),
                    _ => return,
                };
                self.on_gone(i, reason, clean);
            }
            Incoming::Undeliverable { to, reason } => {
                if let Some(&i) = self.by_proc.get(&to) {
                    self.on_gone(i, format!("unreachable: {reason}"), false);
                }
            }
        }
    }

    fn on_message(&mut self, i: usize, body: Body) {
        let n = &mut self.nodes[i];
        match body {
            Body::Ready(r) => {
                n.host = if r.host.is_empty() {
                    n.host.clone()
                } else {
                    r.host
                };
                if let Some(theirs) = image_version::other_than_ours(r.image_version) {
                    // Its lines would not be the bytes this build renders: none for it.
                    let why = format!(
                        "its sunray renders image version {theirs}, the job's pixels are \
                         version {}",
                        image_version::IMAGE_VERSION
                    );
                    if let Some(crew) = &self.cfg.crew {
                        crew.refused(&self.nodes[i].host);
                    }
                    self.on_gone(i, why, false);
                    self.refused.push(i);
                    return;
                }
                (n.cores, n.threads) = (r.cores, r.threads);
                n.sparse_passes = r.sparse_passes;
                if !n.rem_load {
                    n.load_at_start = r.load_avg;
                }
                if n.outcome == Outcome::Starting {
                    n.outcome = Outcome::Ok;
                }
                self.view
                    .event(json!({"event": "ready", "node": i + 1, "host": n.host,
                    "cores": r.cores, "threads": r.threads, "pid": r.pid}));
            }
            Body::Preparing(p) => {
                n.stage = match p.stage() {
                    proto::preparing::Stage::Fetching => Stage::Fetching,
                    proto::preparing::Stage::Building => Stage::Building,
                };
                if let Some(f) = &p.fetch {
                    n.scene_came(f);
                }
            }
            Body::Request(r) => {
                n.stage = Stage::Rendering;
                if let Some(s) = &r.steps {
                    let now = self.cfg.clock.now();
                    n.timeline
                        .worker_reported(now, r.stamp_s, s.scene_ready_s, s.accel_ready_s);
                }
                n.preprocess_s = r.preprocess_s;
                if let Some(f) = &r.scene {
                    n.scene_came(f);
                }
                self.table.release(i, &r.released);
                self.stamps_to_echo[i] = Some(r.stamp_s);
                self.table.set_window(i, r.window);
            }
            Body::Done(d) => self.on_done(i, d),
            Body::WorkerError(e) => {
                self.view.note(&format!(
                    "sunray: worker {} ({}): {}",
                    i + 1,
                    n.host,
                    e.message
                ));
                n.fault = Some(e.message);
            }
            _ => {}
        }
    }

    /// The line's pixels, or with a target error its estimates after the pass; `None` for a
    /// copy of a later pass no longer awaited, whose pixels are not decoded (against what:
    /// the line's estimates here have moved on). A pass carrying its pixels alone
    /// ([`proto::Done::columns`]) is made the whole line's, which its record keeps.
    fn payload(&self, d: &mut proto::Done) -> Result<Option<Payload>, messages::MessageError> {
        let Some(p) = &self.passes else {
            let px = messages::pixels_from_bytes(&d.pixels, self.cfg.width)?;
            return Ok(Some(Payload::Pixels(px)));
        };
        if d.columns.is_empty() {
            return p.decode(&d.estimates).map(|e| Some(Payload::Estimates(e)));
        }
        if !self.table.awaits(d.line, d.pass) {
            return Ok(None);
        }
        let after = p.decode_picked(d.line, d.pass, &d.columns, &d.estimates)?;
        d.estimates = messages::estimates_to_bytes(&after);
        d.columns.clear();
        Ok(Some(Payload::Estimates(after)))
    }

    fn on_done(&mut self, i: usize, mut d: proto::Done) {
        // Lines it will not render, whatever became of this one.
        self.table.release(i, &d.released);
        let payload = match self.payload(&mut d) {
            Ok(p) => p,
            Err(e) => {
                self.view.event(json!({"event": "bad-line", "node": i + 1,
                    "line": d.line, "error": e.to_string()}));
                return;
            }
        };
        let n = &mut self.nodes[i];
        if let Some(c) = &d.clock {
            (n.cpu_s, n.elapsed_s, n.preprocess_s, n.render_s) =
                (c.cpu_s, c.elapsed_s, c.preprocess_s, c.render_s);
            (n.wait_s, n.first_wait_s, n.tail_wait_s) = (c.wait_s, c.first_wait_s, c.tail_wait_s);
        }
        if n.outcome == Outcome::Silent {
            n.outcome = Outcome::Ok;
        }
        // Grant 0: a line granted by the job's previous controller to a worker taken over.
        let completion = if d.grant == 0 {
            self.table.complete_inherited(i, d.line, d.pass)
        } else {
            self.table.complete(i, d.grant, d.line, d.pass)
        };
        match (completion, payload) {
            (Completion::Accepted, Some(payload)) => {
                let proto_counters = d.counters.unwrap_or_default();
                let c = Counters::from(&proto_counters);
                self.max_line_s = self.max_line_s.max(proto_counters.line_s);
                let (pixels, more, waiting, decided, settled) = match payload {
                    Payload::Pixels(px) => (px, false, false, Vec::new(), Vec::new()),
                    Payload::Estimates(e) => match self.passes.as_mut() {
                        Some(p) => {
                            let got = p.pass_in(d.line, e);
                            (got.pixels, got.more, got.waiting, got.decided, got.settled)
                        }
                        None => Default::default(),
                    },
                };
                if more {
                    let first = self.passes.as_ref().is_some_and(|p| p.next_passes_first());
                    self.table.another_pass(d.line, first);
                    if let Some(web) = self.view.web_mut() {
                        web.refined();
                    }
                }
                self.film.set_line(d.line, &pixels);
                n.add_line(&c);
                n.finished_at_s = self.started.elapsed().as_secs_f64();
                let now = self.cfg.clock.now();
                timeline::first(&mut n.timeline.first_line, now);
                timeline::first(&mut self.timeline.first_line, now);
                self.timeline.last_line = Some(now);
                self.counters += c;
                self.lines.rendered += 1;
                // A line of a render to an error whose pixels are all done is recorded
                // settled: its pixels and what each took, not its estimates.
                let (pixels_bytes, estimates) = if settled.is_empty() {
                    (d.pixels, d.estimates)
                } else {
                    (messages::pixels_to_bytes(&pixels), Vec::new())
                };
                self.writer.record(
                    proto::FinishedLine {
                        line: d.line,
                        pixels: pixels_bytes,
                        counters: Some(proto_counters),
                        pass: d.pass,
                        estimates,
                        settled,
                    },
                    !more && !waiting,
                );
                self.lines_decided(decided);
                self.unsaved = true;
                let done = self.table.done();
                self.view.set_done(done);
                self.view
                    .event(json!({"event": "line", "node": i + 1, "line": d.line,
                    "pass": d.pass, "done": done, "total": self.cfg.height}));
            }
            // (Accepted with no payload cannot be: a pass not awaited is not accepted.)
            (Completion::Duplicate | Completion::Accepted, _) => n.dropped += 1,
            (Completion::Unknown, _) => {}
        }
        self.stamps_to_echo[i] = Some(d.stamp_s);
        self.table.set_window(i, d.window);
    }

    /// Lines decided now that their neighbourhoods have their first samples: each goes on
    /// with its next pass or is finished, and its record in the checkpoint holds the decision
    /// (the same pass, no counters of its own: nothing was rendered).
    fn lines_decided(&mut self, decided: Vec<Decided>) {
        for l in decided {
            let pass = self.table.pass(l.line);
            if l.more {
                let first = self.passes.as_ref().is_some_and(|p| p.next_passes_first());
                self.table.another_pass(l.line, first);
                if let Some(web) = self.view.web_mut() {
                    web.refined();
                }
            }
            let finished = !l.more;
            self.writer.record(l.record(pass), finished);
        }
        let done = self.table.done();
        self.view.set_done(done);
    }

    /// Node `i`'s process exited, its host was lost, or it cannot be reached. `clean`: it
    /// exited with code 0, which is a fault only before it was told to stop.
    pub(super) fn on_gone(&mut self, i: usize, reason: String, clean: bool) {
        if self.exited[i] {
            return;
        }
        self.exited[i] = true;
        let held = self.table.node_gone(i);
        let n = &mut self.nodes[i];
        n.lines_given_back += held as u64;
        // A retired worker's exit is no fault, whatever its code: it was told to stop.
        if self.retiring[i] {
            n.outcome = super::super::nodes::Outcome::Retired;
            return;
        }
        if let Some(crew) = &self.cfg.crew {
            crew.left(i, !(self.finishing && clean));
        }
        if self.finishing && clean {
            return;
        }
        n.outcome = Outcome::Fault;
        let why = match &n.fault {
            Some(f) => format!("{reason}: {f}"),
            None => reason,
        };
        self.view.note(&format!(
            "sunray: node {} ({}) FAULT: {why}; {held} line(s) go back to the queue",
            i + 1,
            n.host
        ));
        self.view.event(
            json!({"event": "fault", "node": i + 1, "host": n.host, "reason": why,
            "given_back": held}),
        );
        n.fault = Some(why);
    }
}
