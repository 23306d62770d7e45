//! The worker's loop once its scene is ready: it takes Assigns into its render threads,
//! reports each line rendered (Done), keeps its [`Window`] of lines, asks again when idle,
//! and follows a farm job's takeover by a new controller (Adopt).

use super::owner::{confirmed, Heard, Owner};
use super::{load_average, Link, WorkerError};
use crate::distrib::messages::{self, proto, Body};
use crate::distrib::pool::{LineJob, RenderPool, Rendered};
use crate::distrib::window::{Window, MIN_COVER_S};
use crate::render::adaptive::PixelEstimate;
use crate::render::columns::Columns;
use crate::stats::process_cpu_seconds;
use rem::{Incoming, RemClient};
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

/// The worker's state while it renders.
pub(super) struct RenderLoop {
    /// Addressed to the current owner.
    pub(super) link: Link,
    /// Whom the worker answers to.
    pub(super) owner: Owner,
    /// A client for REM's job records, to check an Adopt (made at the first one).
    pub(super) records: Option<RemClient>,
    /// The render threads.
    pub(super) pool: RenderPool,
    /// How many lines to hold.
    pub(super) window: Window,
    /// Lines held (rendering or queued).
    pub(super) held: usize,
    /// The render threads' waits so far.
    pub(super) waits: Waits,
    /// When the first lines came: until a line is done, how long they take bounds the window.
    pub(super) first_lines_at: Option<Instant>,
    /// When the worker started (its clock's zero).
    pub(super) started: Instant,
    /// When the accelerator was ready.
    pub(super) render_start: Instant,
    /// Decoding the model and building the accelerator, in seconds.
    pub(super) preprocess_s: f64,
    /// How the scene's model came (with every Request).
    pub(super) scene_fetch: proto::SceneFetch,
    /// When the scene and the accelerator were ready (with every Request).
    pub(super) steps: proto::WorkerSteps,
    /// What the worker said when it started (said again to a new owner).
    pub(super) ready: proto::Ready,
    /// Told to retire: it takes no more lines and exits once those it renders are in.
    pub(super) retiring: bool,
}

/// Whether the loop goes on.
enum Flow {
    Go,
    Stop,
}

impl RenderLoop {
    /// Runs until the owner says NoMoreWork (Ok) or is gone for good (Err).
    pub(super) async fn run(
        mut self,
        inbox: &mut mpsc::Receiver<rem::Result<Incoming>>,
        mut results: mpsc::UnboundedReceiver<Rendered>,
        idle_probe: Duration,
        adopt_wait: Duration,
    ) -> Result<(), WorkerError> {
        let first = self.request(Vec::new());
        self.link.send(first).await?;
        let mut probe = tokio::time::interval(idle_probe);
        probe.tick().await;
        let mut first_check = tokio::time::interval(Duration::from_secs_f64(MIN_COVER_S));
        first_check.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        loop {
            tokio::select! {
                item = inbox.recv() => {
                    let incoming = item.ok_or(WorkerError::Rem(rem::Error::Closed))??;
                    if let Flow::Stop = self.on_incoming(incoming).await? {
                        return Ok(());
                    }
                }
                r = results.recv() => {
                    let Some(r) = r else { return Err(WorkerError::BadScene("render threads stopped".into())) };
                    self.on_rendered(r).await?;
                    if self.retiring && self.held == 0 {
                        return Ok(());
                    }
                }
                _ = first_check.tick(), if !self.window.has_line_time() && self.owner.orphaned.is_none() => {
                    self.on_first_check().await?;
                }
                _ = probe.tick() => {
                    if let Some(since) = self.owner.orphaned {
                        if since.elapsed() >= adopt_wait {
                            return Err(WorkerError::ControllerGone);
                        }
                    } else if self.held == 0 {
                        let again = self.request(Vec::new());
                        self.link.send(again).await?;
                    }
                }
            }
        }
    }

    /// Seconds since the worker started.
    fn clock(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// A Request for work, stamped now, giving back `released`.
    fn request(&mut self, released: Vec<u64>) -> Body {
        let now = self.clock();
        Body::Request(proto::Request {
            window: if self.retiring {
                0
            } else {
                self.window.lines(now)
            },
            preprocess_s: self.preprocess_s,
            stamp_s: now,
            released,
            scene: Some(self.scene_fetch),
            steps: Some(self.steps),
        })
    }

    /// A delivery from the relay.
    async fn on_incoming(&mut self, incoming: Incoming) -> Result<Flow, WorkerError> {
        match self.owner.hear(incoming) {
            Heard::Body(Body::Assign(a)) => self.on_assign(a),
            Heard::Body(Body::NoMoreWork(_)) => return Ok(Flow::Stop),
            Heard::Body(Body::Retire(_)) => return self.retire().await,
            Heard::Body(_) | Heard::Nothing => {}
            Heard::Gone if self.owner.succeedable() => {
                self.owner
                    .orphaned
                    .get_or_insert_with(tokio::time::Instant::now);
            }
            Heard::Gone => return Err(WorkerError::ControllerGone),
            Heard::Adopt(from, adopt) => self.on_adopt(from, adopt).await?,
        }
        Ok(Flow::Go)
    }

    /// Lines to render: into the pool's queue.
    fn on_assign(&mut self, a: proto::Assign) {
        let now = self.clock();
        // Duplicates are not an answer to the worker's room but to an empty queue.
        if a.echo_s > 0.0 && a.lines.iter().any(|l| !l.duplicate) {
            self.window.delay(now, now - a.echo_s);
        }
        self.pool.set_queue_target(self.window.queued(now) as usize);
        self.first_lines_at.get_or_insert_with(Instant::now);
        for l in a.lines {
            let (estimates, columns) = match self.grant_estimates(&l) {
                Ok(got) => got,
                Err(e) => {
                    // Its grant times out at the controller, which hands it again.
                    tracing::warn!(line = l.line, "assigned line dropped: {e}");
                    continue;
                }
            };
            let job = LineJob {
                line: l.line,
                pass: l.pass,
                estimates,
                columns,
                grant: l.grant,
                duplicate: l.duplicate,
                generation: self.owner.generation,
            };
            if self.pool.submit(job) {
                self.held += 1;
            }
        }
    }

    /// The estimates a grant of a later pass carries, checked: the whole line's, or those of
    /// the pixels its bitmap names with the bitmap (none for a first pass or a fixed count).
    fn grant_estimates(
        &self,
        l: &proto::LineGrant,
    ) -> Result<(Vec<PixelEstimate>, Option<Columns>), String> {
        let opts = self.pool.options();
        let (Some(a), 1..) = (&opts.adaptive, l.pass) else {
            return Ok((Vec::new(), None));
        };
        if l.columns.is_empty() {
            let e = messages::estimates_from_bytes(&l.estimates, opts.width, a);
            return e.map(|e| (e, None)).map_err(|e| e.to_string());
        }
        let columns = Columns::from_bytes(&l.columns, opts.width)?;
        let e = messages::picked_estimates_from_bytes(&l.estimates, &columns, opts.width, a);
        e.map(|e| (e, Some(columns))).map_err(|e| e.to_string())
    }

    /// A claim to the job by a new controller: once REM's record confirms it, the worker
    /// says Ready to it, hands it the lines rendered meanwhile and asks for work.
    async fn on_adopt(
        &mut self,
        from: rem::ProcId,
        adopt: proto::Adopt,
    ) -> Result<(), WorkerError> {
        if !self.owner.newer_claim(&from, &adopt) {
            return Ok(());
        }
        if self.records.is_none() {
            self.records = RemClient::from_env().await.ok();
        }
        let Some(r) = &self.records else {
            return Ok(());
        };
        if !confirmed(r, &from, &adopt).await {
            return Ok(());
        }
        let kept = self.owner.take_over(from, adopt.epoch);
        self.link.owner = self.owner.id.clone();
        let again = proto::Ready {
            load_avg: load_average(),
            ..self.ready.clone()
        };
        self.link.send(Body::Ready(again)).await?;
        for done in kept {
            self.link.send(Body::Done(done)).await?;
        }
        let request = self.request(Vec::new());
        self.link.send(request).await
    }

    /// Told to retire: the queued lines go back unstarted; it stops now if it renders none,
    /// else once those are in.
    async fn retire(&mut self) -> Result<Flow, WorkerError> {
        self.retiring = true;
        let released = self.take_back(self.pool.queued());
        let request = self.request(released);
        self.link.send(request).await?;
        Ok(if self.held == 0 { Flow::Stop } else { Flow::Go })
    }

    /// A line rendered: its Done (held back while the worker has no owner).
    async fn on_rendered(&mut self, r: Rendered) -> Result<(), WorkerError> {
        self.held = self.held.saturating_sub(1);
        self.waits.add(&r);
        self.window.line_done(r.cycle_s);
        let now = self.clock();
        let released = self.give_back(now);
        let mut counters = proto::Counters::from(&r.counters);
        counters.line_s = r.line_s;
        let done = proto::Done {
            line: r.job.line,
            grant: r.job.grant,
            pixels: messages::pixels_to_bytes(&r.pixels),
            pass: r.job.pass,
            estimates: messages::estimates_to_bytes(&r.estimates),
            columns: r
                .job
                .columns
                .as_ref()
                .map(Columns::to_bytes)
                .unwrap_or_default(),
            counters: Some(counters),
            window: if self.retiring {
                0
            } else {
                self.window.lines(now)
            },
            clock: Some(proto::NodeClock {
                cpu_s: process_cpu_seconds(),
                elapsed_s: self.clock(),
                preprocess_s: self.preprocess_s,
                render_s: self.render_start.elapsed().as_secs_f64(),
                wait_s: self.waits.fresh_s,
                first_wait_s: self.waits.first_s,
                tail_wait_s: self.waits.tail_s,
            }),
            stamp_s: r
                .finished
                .saturating_duration_since(self.started)
                .as_secs_f64(),
            released,
        };
        if let Some(done) = self.owner.report(done, r.job.generation) {
            self.link.send(Body::Done(done)).await?;
        }
        Ok(())
    }

    /// Before any line is done: how long the first lines have been running bounds the
    /// window; lines beyond it go back.
    async fn on_first_check(&mut self) -> Result<(), WorkerError> {
        let Some(at) = self.first_lines_at else {
            return Ok(());
        };
        self.window.first_lines_running(at.elapsed().as_secs_f64());
        let now = self.clock();
        let released = self.give_back(now);
        if !released.is_empty() {
            let request = self.request(released);
            self.link.send(request).await?;
        }
        Ok(())
    }

    /// Sets the pool's queue target from the window and takes back the queued lines beyond
    /// it ([`Window::excess`]); returns the grants to report: those of the current
    /// controller (a line granted by an earlier one is simply dropped: its successor has it
    /// queued).
    fn give_back(&mut self, now: f64) -> Vec<u64> {
        self.pool.set_queue_target(self.window.queued(now) as usize);
        self.take_back(self.window.excess(self.pool.queued(), now))
    }

    /// Takes the last `n` queued lines back from the render threads; returns the grants to
    /// report: those of the current controller (a line granted by an earlier one is simply
    /// dropped: its successor has it queued).
    fn take_back(&mut self, n: usize) -> Vec<u64> {
        let back = self.pool.take_back(n);
        self.held = self.held.saturating_sub(back.len());
        back.into_iter()
            .filter(|job| job.generation == self.owner.generation)
            .map(|job| job.grant)
            .collect()
    }
}

/// The render threads' waits for their next line, summed over threads, by what ended them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Waits {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::Counters;

    fn rendered(first: bool, duplicate: bool, wait_s: f64) -> Rendered {
        Rendered {
            job: LineJob {
                line: 0,
                pass: 0,
                estimates: Vec::new(),
                columns: None,
                grant: 1,
                duplicate,
                generation: 0,
            },
            pixels: Vec::new(),
            estimates: Vec::new(),
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
