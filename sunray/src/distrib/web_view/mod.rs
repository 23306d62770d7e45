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
//!   job's timeline (`timeline`: seconds since submit of each step so far, see
//!   [`Timeline`]).
//! - `JOB.web.png` ([`png_key`]): the image so far (lines not yet in are black), shrunk by a
//!   whole factor to at most [`LIVE_SIDE`] pixels a side while the job runs; at the end at
//!   full size if the store takes a blob that large.
//!
//! A publication is due at the start, then at most once per [`EVERY`] when the lines in or
//! the events changed, and once at the end. One that fails is tried again after [`RETRY`];
//! the job never waits for it longer than a write's timeout.

use super::checkpoint::{unix_ms, Store};
use super::nodes::{NodeStats, Outcome, Stage};
use super::timeline::Timeline;
use crate::film::Film;
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
/// How long one write may take before the publication is given up. Short: the actor waits
/// for it, and a write whose replica peer hangs (a frozen host) would otherwise add seconds
/// to the checkpoint's own wait, until every worker looks silent (the compose cluster's
/// hung-host test saw that once with 2 s).
const PUT_TIMEOUT: Duration = Duration::from_millis(500);
/// The longest event text, in characters (a worker's error message can be long).
const MAX_TEXT: usize = 300;

/// The key of the page's data.
pub fn json_key(job: &str) -> String {
    format!("{job}.web.json")
}

/// The key of the page's image.
pub fn png_key(job: &str) -> String {
    format!("{job}.web.png")
}

/// One line of the job's history.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// When it happened (wall clock).
    pub unix_ms: u64,
    /// What it is, in one machine word: `submitted`, `controller`, `spawned`, `adopted`,
    /// `ready`, `fault`, `silent`, `finished`, `failed`.
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
    let view = WebView::new(job, vec![Event::now("submitted", &text)]);
    view.write(
        store,
        &[],
        Picture::black(width, height)?,
        (width, height),
        0,
    )
    .await
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
            "failed" => (
                "failed",
                format!("failed: no worker left, {} in", lines(n("done"))),
            ),
            _ => return,
        };
        self.push(Event::now(kind, &text));
    }

    /// Whether a publication is due now, with `lines` in the image: the first, then at most
    /// once per [`EVERY`] (after a failure, [`RETRY`]) if anything changed.
    pub fn due(&self, now: Instant, lines: u32) -> bool {
        self.not_before.is_none_or(|t| now >= t)
            && (self.shown != Some(lines) || self.events_changed)
    }

    /// Writes the image and the page's data if due, or always when `last`. Errs on a
    /// refusal for a newer epoch and on the first failure of any other kind; later ones pass
    /// in silence (the job goes on, and a warning a second says nothing new).
    pub async fn publish(
        &mut self,
        store: &impl Store,
        nodes: &[NodeStats],
        film: &Film,
        lines: u32,
        last: bool,
    ) -> Result<(), WebError> {
        if !last && !self.due(Instant::now(), lines) {
            return Ok(());
        }
        let size = (film.width, film.height);
        let result = match Picture::of(film, last, store.max_bytes()) {
            Ok(picture) => self.write(store, nodes, picture, size, lines).await,
            Err(e) => Err(e),
        };
        let wait = if result.is_ok() {
            (self.shown, self.events_changed) = (Some(lines), false);
            EVERY
        } else {
            RETRY
        };
        self.not_before = Some(Instant::now() + wait);
        match result {
            Err(e) if !e.is_fenced() && std::mem::replace(&mut self.warned, true) => Ok(()),
            r => r,
        }
    }

    /// Writes the image (of a `width` x `height` film), then the page's data (so the data
    /// never describes an image not yet stored).
    async fn write(
        &self,
        store: &impl Store,
        nodes: &[NodeStats],
        picture: Picture,
        (width, height): (u32, u32),
        lines: u32,
    ) -> Result<(), WebError> {
        let about = json!({"width": width, "height": height, "lines": lines,
            "full": picture.full, "png_width": picture.width, "png_height": picture.height});
        let page = self.page(nodes, about)?;
        put(store, png_key(&self.job), picture.png).await?;
        put(store, json_key(&self.job), page).await
    }

    /// The page's data, under [`MAX_JSON_BYTES`] (rows of the table are left out if there
    /// are thousands of nodes).
    fn page(&self, nodes: &[NodeStats], about: Value) -> Result<Vec<u8>, WebError> {
        let mut rows: Vec<Value> = nodes.iter().map(row).collect();
        loop {
            let page = json!({
                "nodes": {"columns": COLUMNS, "rows": rows},
                "events": self.events,
                "image": about,
                "timeline": self.timeline,
            });
            let bytes = serde_json::to_vec(&page)?;
            if bytes.len() <= MAX_JSON_BYTES || rows.is_empty() {
                return Ok(bytes);
            }
            rows.truncate(rows.len() / 2);
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

/// The image as published.
struct Picture {
    png: Vec<u8>,
    /// The finished job's image at full size (only in the last publication).
    full: bool,
    width: u32,
    height: u32,
}

impl Picture {
    fn new(film: &Film, full: bool) -> Result<Picture, WebError> {
        let (width, height) = (film.width, film.height);
        let png = film.to_png()?;
        Ok(Picture {
            png,
            full,
            width,
            height,
        })
    }

    /// `film` shrunk to [`LIVE_SIDE`] while the job runs; at the end at full size if its
    /// PNG fits `max_bytes`.
    fn of(film: &Film, last: bool, max_bytes: usize) -> Result<Picture, WebError> {
        if last {
            let whole = Picture::new(film, true)?;
            if whole.png.len() <= max_bytes {
                return Ok(whole);
            }
        }
        match live_factor(film.width, film.height) {
            1 => Picture::new(film, false),
            f => Picture::new(&film.downscaled(f), false),
        }
    }

    /// A black `width` x `height` image as it is published while the job runs (without
    /// making a film that large).
    fn black(width: u32, height: u32) -> Result<Picture, WebError> {
        let f = live_factor(width, height);
        Picture::new(&Film::new(width.div_ceil(f), height.div_ceil(f)), false)
    }
}

/// The whole factor that brings the longer side to at most [`LIVE_SIDE`].
fn live_factor(width: u32, height: u32) -> u32 {
    width.max(height).div_ceil(LIVE_SIDE).max(1)
}

async fn put(store: &impl Store, key: String, data: Vec<u8>) -> Result<(), WebError> {
    match tokio::time::timeout(PUT_TIMEOUT, store.put(&key, data)).await {
        Ok(Ok(())) => Ok(()),
        Ok(Err(source)) => Err(WebError::Rem { key, source }),
        Err(_) => Err(WebError::Timeout(key)),
    }
}

#[cfg(test)]
mod tests;
