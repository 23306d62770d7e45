//! What a farm job publishes for remd's web view (`remd --web`). REM is neutral about
//! applications: its page shows what the application stores under two keys of REM's
//! checkpoint store, which the controller writes through its link (fenced by its epoch, as
//! its checkpoint is):
//!
//! - `JOB.web.json` ([`json_key`], at most [`MAX_JSON_BYTES`]): the per-node table
//!   (`nodes`: `columns` and `rows`), the job's history for people (`events`: `unix_ms`,
//!   `kind`, `text`; oldest first, the last [`MAX_EVENTS`], carried over from one controller
//!   to the next) and what the image is (`image`: `width`, `height`, `lines` in it now,
//!   `png_width`, `png_height`, and `full`: the last publication's full-size image) and the
//!   job's timeline (`timeline`: `[name, seconds since submit]` of each step so far, in
//!   order, see [`Timeline::steps`]).
//! - `JOB.web.png` ([`png_key`]): the image so far (lines not yet in are black), shrunk by a
//!   whole factor to at most [`LIVE_SIDE`] pixels a side while the job runs; at the end at
//!   full size if the store takes a blob that large.
//! - `JOB.web.samples.png` ([`view_key`]), for a job rendered to an error: the samples each
//!   pixel took so far, as `--samples-map` draws them, shrunk and sized as the image; named
//!   with a caption in `image.views` ([`Publication::add_view`]).
//!
//! A publication is due at the start, then at most once per [`EVERY`] when the lines in or
//! the events changed, and once at the end. One that fails is tried again after [`RETRY`].
//! The controller takes a [`Publication`] when one is due and its store writer writes it
//! ([`publication`]): the job never waits for the web view.

use super::checkpoint::{unix_ms, Store};
use super::nodes::{NodeStats, Outcome, Stage};
use super::timeline::Timeline;
use crate::film::Film;
pub use publication::Publication;
use publication::Snapshot;
use rem::daemon::web::job_view;
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};
use std::collections::VecDeque;
use std::time::Duration;
use tokio::time::Instant;

/// Events kept: the last this many.
pub const MAX_EVENTS: usize = 100;
/// The largest `JOB.web.json` REM takes.
pub const MAX_JSON_BYTES: usize = 256 << 10;
/// The longest side of the image published while the job runs.
pub const LIVE_SIDE: u32 = 1024;
/// The shortest time between two publications (but the last).
pub const EVERY: Duration = Duration::from_secs(1);
/// How long after a failed publication the next is tried (a remd that does not answer
/// must not hold the controller up every second).
pub const RETRY: Duration = Duration::from_secs(10);
/// How long one write may take before the publication is given up. The controller's actor
/// does not wait for it (its store writer does), but a write whose replica peer hangs (a
/// frozen host) holds the next publication back, and a page a few seconds old is better
/// than none.
const PUT_TIMEOUT: Duration = Duration::from_secs(2);
/// The longest event text, in characters (a worker's error message can be long).
const MAX_TEXT: usize = 300;

/// The key of the page's data (REM's page reads it: [`job_view::view_key`]).
pub fn json_key(job: &str) -> String {
    job_view::view_key(job)
}

/// The key of the page's image ([`job_view::image_key`]).
pub fn png_key(job: &str) -> String {
    job_view::image_key(job)
}

/// The key of the job's other picture `name` (REM's page offers it beside the image:
/// [`job_view::view_image_key`]).
pub fn view_key(job: &str, name: &str) -> String {
    job_view::view_image_key(job, name)
}

/// One line of the job's history.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// When it happened (wall clock).
    pub unix_ms: u64,
    /// What it is, in one machine word: `submitted`, `controller`, `spawned`, `adopted`,
    /// `ready`, `fault`, `silent`, `finished`, `not-stored`, `failed`.
    pub kind: String,
    /// What happened, for people.
    pub text: String,
}

impl Event {
    /// `kind` happening now.
    pub fn now(kind: &str, text: &str) -> Event {
        Event {
            unix_ms: unix_ms(),
            kind: kind.to_string(),
            text: text.to_string(),
        }
    }
}

/// Why a publication failed (the job goes on).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WebError {
    /// The image could not be encoded.
    #[error("encoding the image: {0}")]
    Png(#[from] image::ImageError),
    /// The page's data could not be encoded.
    #[error("encoding the page's data: {0}")]
    Json(#[from] serde_json::Error),
    /// REM refused or failed a write.
    #[error("storing {key}: {source}")]
    Rem {
        /// The key being written.
        key: String,
        /// REM's error.
        source: rem::Error,
    },
    /// A write took longer than its time.
    #[error("storing {0}: no answer in {PUT_TIMEOUT:?}")]
    Timeout(String),
}

impl WebError {
    /// REM refused the write because a newer controller has the job (or it ended).
    pub fn is_fenced(&self) -> bool {
        matches!(self, WebError::Rem { source, .. } if source.is_fenced())
    }
}

/// Replaces whatever an earlier job of the same id left with the page of `job`, just
/// submitted as `title` (`width` x `height`) for `hosts` workers: no nodes yet, a black image
/// and one `submitted` event. So the history its controllers carry on is its own.
pub async fn submitted(
    store: &impl Store,
    job: &str,
    title: &str,
    hosts: u32,
    (width, height): (u32, u32),
) -> Result<(), WebError> {
    let text = format!("submitted: {title}, {hosts} worker(s)");
    let publication = Publication {
        job: job.to_string(),
        events: vec![Event::now("submitted", &text)],
        timeline: Vec::new(),
        rows: Vec::new(),
        image: Snapshot::black(width, height),
        views: Vec::new(),
        lines: 0,
    };
    publication.write(store).await
}

/// The events published in `JOB.web.json` (none if it does not parse), then this
/// controller's start on `host` at `epoch`: `controller moved to HOST, epoch N` when an
/// earlier controller of the job published, else `controller started on HOST, epoch N` (a
/// job id used again starts above epoch 1).
pub async fn history(store: &impl Store, job: &str, host: &str, epoch: u64) -> Vec<Event> {
    #[derive(Deserialize)]
    struct Earlier {
        #[serde(default)]
        events: Vec<Event>,
    }
    let earlier = match store.get(&json_key(job)).await {
        Ok(Some(bytes)) => {
            serde_json::from_slice::<Earlier>(&bytes).map_or(Vec::new(), |e| e.events)
        }
        _ => Vec::new(),
    };
    let text = if earlier.iter().any(|e| e.kind == "controller") {
        format!("controller moved to {host}, epoch {epoch}")
    } else {
        format!("controller started on {host}, epoch {epoch}")
    };
    let mut events = earlier;
    events.push(Event::now("controller", &text));
    events
}

/// The history the job publishes and when it last did.
#[derive(Debug)]
pub struct WebView {
    job: String,
    events: VecDeque<Event>,
    events_changed: bool,
    /// The lines in the image the last publication showed.
    shown: Option<u32>,
    /// No publication before then (but the last).
    not_before: Option<Instant>,
    warned: bool,
    /// The job's steps so far.
    timeline: Timeline,
}

impl WebView {
    /// The web view of `job`, its history going on from `history` (the last [`MAX_EVENTS`]).
    pub fn new(job: &str, history: Vec<Event>) -> WebView {
        let mut view = WebView {
            job: job.to_string(),
            events: VecDeque::with_capacity(MAX_EVENTS),
            events_changed: true,
            shown: None,
            not_before: None,
            warned: false,
            timeline: Timeline::default(),
        };
        history.into_iter().for_each(|e| view.push(e));
        view
    }

    /// Adds `e` (its text cut to [`MAX_TEXT`] characters, so the page stays small whatever
    /// an earlier page held), dropping the oldest beyond [`MAX_EVENTS`].
    fn push(&mut self, mut e: Event) {
        if let Some((cut, _)) = e.text.char_indices().nth(MAX_TEXT) {
            e.text.truncate(cut);
        }
        if self.events.len() == MAX_EVENTS {
            self.events.pop_front();
        }
        self.events.push_back(e);
        self.events_changed = true;
    }

    /// The job's timeline as it stands; a step more makes a publication due.
    pub fn set_timeline(&mut self, timeline: &Timeline) {
        if self.timeline != *timeline {
            self.timeline = timeline.clone();
            self.events_changed = true;
        }
    }

    /// The job's events, oldest first.
    pub fn events(&self) -> impl Iterator<Item = &Event> {
        self.events.iter()
    }

    /// Takes one of the controller's `--events` values: those people care about become a
    /// line of the history (not lines, assignments or checkpoints).
    pub fn on_event(&mut self, v: &Value) {
        let s = |k: &str| v[k].as_str().unwrap_or("?").to_string();
        let n = |k: &str| v[k].as_u64().unwrap_or(0);
        let node = format!("node {} on {}", n("node"), s("host"));
        let (kind, text) = match v["event"].as_str().unwrap_or("") {
            "spawned" if v["adopted"] == true => (
                "adopted",
                format!("{node} taken over from the previous controller"),
            ),
            "spawned" => ("spawned", format!("{node} spawned (pid {})", n("pid"))),
            "ready" => (
                "ready",
                format!(
                    "{node} ready: {} threads on {} cores",
                    n("threads"),
                    n("cores")
                ),
            ),
            "fault" => (
                "fault",
                format!(
                    "{node} failed: {}; {} given back",
                    s("reason"),
                    lines(n("given_back"))
                ),
            ),
            "silent" => (
                "silent",
                format!("{node} went silent; {} given back", lines(n("given_back"))),
            ),
            "finished" => ("finished", format!("finished: {} in", lines(n("done")))),
            "not-stored" => (
                "not-stored",
                format!(
                    "{} in, but the checkpoint store refused the last save: not finished",
                    lines(n("done"))
                ),
            ),
            "failed" => (
                "failed",
                format!("failed: no worker left, {} in", lines(n("done"))),
            ),
            _ => return,
        };
        self.push(Event::now(kind, &text));
    }

    /// The image changed without a line more being done (a pass of a line rendered to an
    /// error): the next publication is due all the same.
    pub fn refined(&mut self) {
        self.events_changed = true;
    }

    /// Whether a publication is due now, with `lines` in the image: the first, then at most
    /// once per [`EVERY`] (after a failure, [`RETRY`]) if anything changed.
    pub fn due(&self, now: Instant, lines: u32) -> bool {
        self.not_before.is_none_or(|t| now >= t)
            && (self.shown != Some(lines) || self.events_changed)
    }

    /// The publication due now with `lines` in the image, or always when `last`: the page's
    /// data and a copy of the image shrunk to [`LIVE_SIDE`] as they are, for
    /// [`Publication::write`] to encode and store (off the controller's actor); the last
    /// one's image is encoded now (whole if its PNG fits `max_bytes`), not copied. The next
    /// is due after [`EVERY`]; [`WebView::failed`] says when one was not stored.
    pub fn take_due(
        &mut self,
        nodes: &[NodeStats],
        film: &Film,
        (lines, last): (u32, bool),
        max_bytes: usize,
    ) -> Option<Publication> {
        if !last && !self.due(Instant::now(), lines) {
            return None;
        }
        (self.shown, self.events_changed) = (Some(lines), false);
        self.not_before = Some(Instant::now() + EVERY);
        Some(Publication {
            job: self.job.clone(),
            events: self.events.iter().cloned().collect(),
            timeline: self.timeline.steps(),
            rows: nodes.iter().map(row).collect(),
            image: Snapshot::of(film, last, max_bytes),
            views: Vec::new(),
            lines,
        })
    }

    /// A publication taken from this view failed with `e`: the next is tried after
    /// [`RETRY`]. Whether to tell: a refusal for a newer epoch always, any other failure the
    /// first time only (the job goes on, and a warning a second says nothing new).
    pub fn failed(&mut self, e: &WebError) -> bool {
        self.shown = None;
        self.events_changed = true;
        self.not_before = Some(Instant::now() + RETRY);
        e.is_fenced() || !std::mem::replace(&mut self.warned, true)
    }

    /// Takes the publication due and writes it at once (see [`WebView::take_due`]); errs
    /// when [`WebView::failed`] says to tell.
    pub async fn publish(
        &mut self,
        store: &impl Store,
        nodes: &[NodeStats],
        film: &Film,
        lines: u32,
        last: bool,
    ) -> Result<(), WebError> {
        let taken = self.take_due(nodes, film, (lines, last), store.max_bytes());
        let Some(publication) = taken else {
            return Ok(());
        };
        match publication.write(store).await {
            Err(e) if self.failed(&e) => Err(e),
            _ => Ok(()),
        }
    }
}

/// The per-node table's columns, as the thesis's (Tables 4.5 to 4.9) but fewer.
const COLUMNS: [&str; 9] = [
    "node",
    "host",
    "state",
    "scanlines",
    "eye rays",
    "secondary rays",
    "intersections",
    "CPU s",
    "elapsed s",
];

fn row(n: &NodeStats) -> Value {
    let state = match (n.outcome, n.stage) {
        (Outcome::Fault, _) => "fault",
        (Outcome::Retired, _) => "retired",
        (_, Stage::Fetching) => "fetching",
        (_, Stage::Building) => "building",
        (Outcome::Silent, _) => "silent",
        (Outcome::Starting, _) => "starting",
        (Outcome::Ok, _) => "ok",
    };
    let centi = |s: f64| (s * 100.0).round() / 100.0;
    json!([
        n.node,
        n.host,
        state,
        n.scanlines,
        n.eye_rays,
        n.secondary_rays,
        n.counters.intersection_tests,
        centi(n.cpu_s),
        centi(n.elapsed_s)
    ])
}

/// `1 line`, `3 lines`.
fn lines(n: u64) -> String {
    format!("{n} line{}", if n == 1 { "" } else { "s" })
}

/// The whole factor that brings the longer side to at most [`LIVE_SIDE`].
pub fn live_factor(width: u32, height: u32) -> u32 {
    width.max(height).div_ceil(LIVE_SIDE).max(1)
}

mod publication;
#[cfg(test)]
mod tests;
