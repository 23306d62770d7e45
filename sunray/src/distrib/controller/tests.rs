//! The controller's rules without processes: a recording [`WorkerLink`] in place of REM, the
//! workers played by the test, tokio's clock paused (so timeouts pass instantly and in order).

use super::link::WorkerLink;
use super::{spawn_with, ControllerConfig, ControllerHandle, Input, JobResult, WorkerProc};
use crate::distrib::checkpoint::{Checkpointer, Restored, Store};
use crate::distrib::messages::{self, proto, Body};
use crate::distrib::nodes::Outcome;
use crate::distrib::strategy::Strategy;
use crate::distrib::timeline::{JobClock, Timeline};
use rem::{EventKind, Incoming, JobEvent, ProcId};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;

mod checkpoints;
mod crew;
mod passes;
mod stall;
mod timeline;
mod web;
mod writer;

const WIDTH: u32 = 4;
const JOB: &str = "job-under-test";

/// The job spec checkpointed for an image of `height` lines (a checkpoint is only read back
/// with render settings that match its lines).
fn spec(height: u32) -> proto::JobSpec {
    spec_with(height, None)
}

/// [`spec`] of a job rendered to the error `adaptive` asks (when given).
fn spec_with(height: u32, adaptive: Option<crate::render::adaptive::Adaptive>) -> proto::JobSpec {
    let settings = crate::render::Settings {
        render: crate::render::RenderOptions {
            width: WIDTH,
            height,
            samples: 1,
            trace: Default::default(),
            adaptive,
            sampler: Default::default(),
        },
        accel: Default::default(),
        mailbox: true,
    }
    .to_proto();
    proto::JobSpec {
        settings: Some(settings),
        ..Default::default()
    }
}

/// What the controller did: messages sent (decoded), processes killed, checkpoints stored.
#[derive(Default)]
struct Record {
    sent: Vec<(String, Body)>,
    killed: Vec<String>,
    store: HashMap<String, Vec<u8>>,
    /// The key of every `put` begun, in order.
    puts: Vec<String>,
    /// How long each `put` takes (a store held up by a stopped replica).
    put_takes: Duration,
    /// How many of the next `put`s fail (a replica stopped or restarting refuses them).
    failing_puts: u32,
    /// The relay's message limit, when not 1 MiB: a larger message is refused.
    max_message: Option<usize>,
}

#[derive(Clone, Default)]
struct FakeLink(Arc<Mutex<Record>>);

impl Store for FakeLink {
    async fn put(&self, key: &str, data: Vec<u8>) -> Result<(), rem::Error> {
        let takes = {
            let mut r = self.0.lock().unwrap();
            r.puts.push(key.to_string());
            if r.failing_puts > 0 {
                r.failing_puts -= 1;
                return Err(rem::Error::Closed);
            }
            r.put_takes
        };
        tokio::time::sleep(takes).await;
        self.0.lock().unwrap().store.insert(key.to_string(), data);
        Ok(())
    }
    async fn get(&self, key: &str) -> Result<Option<Vec<u8>>, rem::Error> {
        Ok(self.0.lock().unwrap().store.get(key).cloned())
    }
    fn max_bytes(&self) -> usize {
        1 << 20
    }
}

impl WorkerLink for FakeLink {
    async fn send(&self, to: &ProcId, payload: Vec<u8>) -> Result<(), rem::Error> {
        let limit = self.max_message();
        if payload.len() > limit {
            let size = payload.len();
            return Err(rem::Error::TooLarge { size, limit });
        }
        let body = messages::decode(&payload).unwrap();
        self.0.lock().unwrap().sent.push((to.to_string(), body));
        Ok(())
    }
    async fn kill(&self, proc: &ProcId) {
        self.0.lock().unwrap().killed.push(proc.to_string());
    }
    fn max_message(&self) -> usize {
        self.0.lock().unwrap().max_message.unwrap_or(1 << 20)
    }
}

impl FakeLink {
    /// A link whose relay refuses messages over `limit` bytes.
    fn with_max_message(limit: usize) -> FakeLink {
        let link = FakeLink::default();
        link.0.lock().unwrap().max_message = Some(limit);
        link
    }

    /// Takes the line grants assigned to `proc` since the last call.
    fn take_grants(&self, proc: &ProcId) -> Vec<proto::LineGrant> {
        let mut r = self.0.lock().unwrap();
        let mut grants = Vec::new();
        r.sent.retain(|(to, body)| match body {
            Body::Assign(a) if to == proc.as_str() => {
                grants.extend(a.lines.iter().cloned());
                false
            }
            _ => true,
        });
        grants
    }

    fn got(&self, proc: &ProcId, pred: impl Fn(&Body) -> bool) -> bool {
        let r = self.0.lock().unwrap();
        r.sent.iter().any(|(to, b)| to == proc.as_str() && pred(b))
    }
}

/// A job of `height` lines on `n` workers, with a 1 s worker timeout.
struct Job {
    link: FakeLink,
    procs: Vec<ProcId>,
    handle: ControllerHandle,
}

impl Job {
    fn start(height: u32, n: usize, restored: Option<Restored>) -> Job {
        Job::start_on(FakeLink::default(), height, n, restored)
    }

    fn start_on(link: FakeLink, height: u32, n: usize, restored: Option<Restored>) -> Job {
        Job::launch(link, height, n, restored, None)
    }

    /// A job whose configuration's `web` is `web` (see [`ControllerConfig::web`]).
    fn launch(
        link: FakeLink,
        height: u32,
        n: usize,
        restored: Option<Restored>,
        web: Option<Vec<crate::distrib::web_view::Event>>,
    ) -> Job {
        Job::configured(link, height, n, restored, |cfg| cfg.web = web)
    }

    /// A job whose configuration `edit` changes.
    fn configured(
        link: FakeLink,
        height: u32,
        n: usize,
        restored: Option<Restored>,
        edit: impl FnOnce(&mut ControllerConfig),
    ) -> Job {
        let procs: Vec<ProcId> = (0..n).map(|i| ProcId::new(&format!("h{i}"), 1)).collect();
        let workers = procs
            .iter()
            .map(|p| WorkerProc {
                proc_id: p.clone(),
                host: p.host().to_string(),
                pid: 100,
                load_at_start: None,
                adopted: false,
                slots: 1,
            })
            .collect();
        let mut cfg = ControllerConfig {
            job: JOB.into(),
            strategy: Strategy::Dynamic,
            width: WIDTH,
            height,
            scene: messages::encode(Body::NoMoreWork(proto::NoMoreWork {})),
            worker_timeout: Some(Duration::from_secs(1)),
            checkpoint_every: Duration::from_millis(500),
            preview: None,
            preview_every: Duration::from_secs(1),
            show_bar: false,
            events: false,
            finish_grace: Duration::from_millis(200),
            fetch_grace: Duration::from_millis(200),
            checkpointed: None,
            adopt: None,
            web: None,
            clock: JobClock::at(0),
            timeline: Timeline::default(),
            adaptive: None,
            crew: None,
        };
        edit(&mut cfg);
        let spec = spec_with(height, cfg.adaptive);
        let checkpointer = Checkpointer::new(JOB, spec, 7, restored.as_ref());
        let handle = spawn_with(cfg, link.clone(), workers, restored, checkpointer);
        Job {
            link,
            procs,
            handle,
        }
    }

    async fn feed(&self, incoming: Incoming) {
        self.handle
            .tx
            .send(Input::Relay(Ok(incoming)))
            .await
            .unwrap();
        // Let the actor run (the paused clock moves on only when everything waits).
        tokio::time::sleep(Duration::from_millis(1)).await;
    }

    async fn say(&self, node: usize, body: Body) {
        let from = self.procs[node].to_string();
        let payload = messages::encode(body);
        self.feed(Incoming::Message { from, payload }).await;
    }

    /// Worker `node` starts: Ready, then asks for `window` lines.
    async fn ready(&self, node: usize, window: u32) {
        self.starts(node, window, true).await;
    }

    /// The same for a worker of an earlier build, which takes later passes whole.
    async fn ready_earlier_build(&self, node: usize, window: u32) {
        self.starts(node, window, false).await;
    }

    async fn starts(&self, node: usize, window: u32, sparse_passes: bool) {
        let ready = proto::Ready {
            sparse_passes,
            ..Default::default()
        };
        self.say(node, Body::Ready(ready)).await;
        let request = proto::Request {
            window,
            ..Default::default()
        };
        self.say(node, Body::Request(request)).await;
    }

    /// Worker `node` renders line `line` under `grant` (every pixel = the line number).
    async fn done(&self, node: usize, line: u32, grant: u64) {
        let done = proto::Done {
            line,
            grant,
            pixels: messages::pixels_to_bytes(&pixels(line)),
            counters: Some(proto::Counters {
                eye: u64::from(WIDTH),
                ..Default::default()
            }),
            window: 2,
            ..Default::default()
        };
        self.say(node, Body::Done(done)).await;
    }

    /// Worker `node` answers everything it is given until the job ends.
    async fn serve_until_done(&self, node: usize) {
        for _ in 0..10_000 {
            if self.handle.task.is_finished() {
                return;
            }
            for g in self.link.take_grants(&self.procs[node]) {
                self.done(node, g.line, g.grant).await;
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        panic!("the job did not end");
    }

    async fn exits(&self, node: usize, code: Option<i32>, signal: Option<i32>) {
        let mut ev = JobEvent {
            proc_id: self.procs[node].to_string(),
            host: self.procs[node].host().to_string(),
            exit_code: code,
            signal,
            ..Default::default()
        };
        ev.set_kind(EventKind::Exited);
        self.feed(Incoming::Event(ev)).await;
    }

    /// Waits for the job's end (its input stays open, as the relay's would).
    async fn end(self) -> (JobResult, FakeLink) {
        let ControllerHandle { tx, task, .. } = self.handle;
        let result = task.await.unwrap().unwrap();
        drop(tx);
        (result, self.link)
    }
}

fn pixels(line: u32) -> Vec<[f32; 3]> {
    vec![[line as f32; 3]; WIDTH as usize]
}

/// Every line of the image holds what its worker rendered for it.
fn assert_image_complete(r: &JobResult, height: u32) {
    assert!(r.finished);
    for y in 0..height {
        let w = WIDTH as usize;
        let row = &r.film.pixels[y as usize * w..(y as usize + 1) * w];
        assert_eq!(row, pixels(y).as_slice(), "line {y}");
    }
}

#[tokio::test(start_paused = true)]
async fn a_worker_that_dies_gives_its_lines_back_to_the_others() {
    let job = Job::start(12, 2, None);
    job.ready(0, 3).await;
    job.ready(1, 3).await;
    let held = job.link.take_grants(&job.procs[0]);
    assert_eq!(held.len(), 3, "node 1 was given its window");
    job.exits(0, None, Some(9)).await;
    job.serve_until_done(1).await;
    let (r, link) = job.end().await;
    assert_image_complete(&r, 12);
    assert_eq!(r.nodes[0].outcome, Outcome::Fault);
    assert_eq!(r.nodes[0].lines_given_back, 3);
    assert_eq!(r.nodes[1].scanlines, 12, "node 2 rendered every line");
    assert_eq!(r.lines.requeued, 3);
    assert_eq!(r.counters.eye, 12 * u64::from(WIDTH));
    // The survivor was told to stop; the dead one needs no kill.
    assert!(link.got(&job_proc(1), |b| matches!(b, Body::NoMoreWork(_))));
    assert!(!link
        .0
        .lock()
        .unwrap()
        .killed
        .contains(&job_proc(0).to_string()));
}

fn job_proc(node: usize) -> ProcId {
    ProcId::new(&format!("h{node}"), 1)
}

#[tokio::test(start_paused = true)]
async fn a_silent_worker_is_passed_over_and_its_late_line_is_dropped() {
    let job = Job::start(8, 2, None);
    job.ready(0, 1).await;
    job.ready(1, 1).await;
    let held = job.link.take_grants(&job.procs[0]);
    assert_eq!(held.len(), 1);
    // Node 1 says nothing for longer than the 1 s timeout while node 2 works.
    let late = held[0].clone();
    for _ in 0..3 {
        for g in job.link.take_grants(&job.procs[1]) {
            job.done(1, g.line, g.grant).await;
        }
        tokio::time::sleep(Duration::from_millis(600)).await;
    }
    // Its line went back to the queue and node 2 took it; the late copy must not count.
    job.serve_while_given(1).await;
    job.done(0, late.line, late.grant).await;
    job.serve_until_done(1).await;
    let (r, link) = job.end().await;
    assert_image_complete(&r, 8);
    assert!(r.lines.requeued >= 1, "{:?}", r.lines);
    assert_eq!(r.lines.rendered, 8);
    assert_eq!(r.lines.dropped, 1, "first completion wins: {:?}", r.lines);
    // Neither worker exited by itself: both were killed after the grace period.
    let killed = &link.0.lock().unwrap().killed;
    assert_eq!(killed.len(), 2, "{killed:?}");
}

impl Job {
    /// Worker `node` answers what it is given until it is given nothing more.
    async fn serve_while_given(&self, node: usize) {
        loop {
            let grants = self.link.take_grants(&self.procs[node]);
            if grants.is_empty() {
                return;
            }
            for g in grants {
                self.done(node, g.line, g.grant).await;
            }
        }
    }
}

#[tokio::test(start_paused = true)]
async fn forged_and_duplicate_completions_do_not_touch_the_image() {
    let job = Job::start(4, 2, None);
    job.ready(0, 4).await;
    job.ready(1, 4).await;
    let mine = job.link.take_grants(&job.procs[0]);
    // Node 2 claims node 1's lines with grants it was never given, and pixels of its own.
    for g in &mine {
        let forged = proto::Done {
            line: g.line,
            grant: g.grant + 1000,
            pixels: messages::pixels_to_bytes(&[[99.0; 3]; WIDTH as usize]),
            window: 1,
            ..Default::default()
        };
        job.say(1, Body::Done(forged)).await;
    }
    // A line of the wrong width is refused too.
    if let Some(g) = mine.first() {
        let short = proto::Done {
            line: g.line,
            grant: g.grant,
            pixels: vec![0; 12],
            window: 1,
            ..Default::default()
        };
        job.say(0, Body::Done(short)).await;
    }
    let serve = async {
        for g in mine {
            job.done(0, g.line, g.grant).await;
        }
    };
    serve.await;
    job.serve_until_done(1).await;
    let (r, _) = job.end().await;
    assert_image_complete(&r, 4);
    assert_eq!(r.lines.rendered, 4);
}

#[tokio::test(start_paused = true)]
async fn a_job_whose_only_worker_never_says_ready_ends_after_the_timeout() {
    let job = Job::start(4, 1, None);
    let (r, link) = job.end().await;
    assert!(!r.finished);
    assert_eq!(r.nodes[0].outcome, Outcome::Silent);
    assert_eq!(
        link.0.lock().unwrap().killed.len(),
        1,
        "the hung worker is killed"
    );
}

#[tokio::test(start_paused = true)]
async fn a_worker_of_another_image_version_gets_no_line_and_is_told_to_stop() {
    use crate::render::image_version::IMAGE_VERSION;
    let job = Job::start(6, 2, None);
    let newer = proto::Ready {
        image_version: IMAGE_VERSION + 1,
        ..Default::default()
    };
    job.say(0, Body::Ready(newer)).await;
    let request = proto::Request {
        window: 3,
        ..Default::default()
    };
    job.say(0, Body::Request(request)).await;
    // A worker of a build before the field (image_version 0) renders version 1's pixels.
    job.ready(1, 3).await;
    assert!(job.link.take_grants(&job.procs[0]).is_empty());
    assert!(job
        .link
        .got(&job.procs[0], |b| matches!(b, Body::Retire(_))));
    job.serve_until_done(1).await;
    let (r, _) = job.end().await;
    assert_image_complete(&r, 6);
    assert_eq!(r.nodes[0].outcome, Outcome::Fault);
    let why = r.nodes[0].fault.clone().unwrap_or_default();
    assert!(
        why.contains(&format!("image version {}", IMAGE_VERSION + 1)),
        "{why}"
    );
    assert_eq!(r.nodes[1].scanlines, 6);
}
