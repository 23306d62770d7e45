//! What a running job shows: a progress bar (lines done, lines per second, workers alive,
//! ETA), machine-readable events (`--events`: one JSON object per line on stderr, for
//! scripts and tests), the `--preview` image rewritten every few seconds, and for a farm
//! job the history remd's web view shows ([`WebView`]).

use crate::distrib::web_view::WebView;
use crate::film::Film;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The controller's progress output: the bar, the `--events` stream, the preview file and
/// the web view's history.
pub struct ProgressView {
    bar: Option<indicatif::ProgressBar>,
    web: Option<WebView>,
    events: bool,
    preview: Option<PathBuf>,
    preview_every: Duration,
    last_preview: Instant,
}

impl ProgressView {
    /// A view of a job of `total` lines, `done` of them already in. The bar is drawn only
    /// when asked for and events are off.
    pub fn new(
        total: u32,
        done: u32,
        show_bar: bool,
        events: bool,
        preview: Option<PathBuf>,
        preview_every: Duration,
    ) -> ProgressView {
        let bar = (show_bar && !events).then(|| {
            let b = indicatif::ProgressBar::new(u64::from(total));
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{bar:40} {pos}/{len} lines  {per_sec}  {msg}  eta {eta}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b.set_position(u64::from(done));
            b.reset_eta();
            b
        });
        ProgressView {
            bar,
            web: None,
            events,
            preview,
            preview_every,
            last_preview: Instant::now(),
        }
    }

    /// Also keeps the job's history for remd's web view (`None`: no web view).
    pub fn with_web(self, web: Option<WebView>) -> ProgressView {
        ProgressView { web, ..self }
    }

    /// The web view, if the job has one.
    pub fn web_mut(&mut self) -> Option<&mut WebView> {
        self.web.as_mut()
    }

    /// Prints an event when `--events` is on, stamped with the wall clock (`unix_ms`), and
    /// gives it to the web view.
    pub fn event(&mut self, mut value: serde_json::Value) {
        if let Some(web) = &mut self.web {
            web.on_event(&value);
        }
        if self.events {
            if let Some(map) = value.as_object_mut() {
                map.insert(
                    "unix_ms".into(),
                    crate::distrib::checkpoint::unix_ms().into(),
                );
            }
            eprintln!("{value}");
        }
    }

    /// A human message, printed above the bar.
    pub fn note(&self, text: &str) {
        match &self.bar {
            Some(b) => b.println(text),
            None if !self.events => eprintln!("{text}"),
            None => {}
        }
    }

    /// Moves the bar to `done` lines.
    pub fn set_done(&self, done: u32) {
        if let Some(b) = &self.bar {
            b.set_position(u64::from(done));
        }
    }

    /// Shows how many workers are alive beside the bar.
    pub fn set_workers(&self, alive: usize) {
        if let Some(b) = &self.bar {
            b.set_message(format!("{alive} worker(s)"));
        }
    }

    /// Writes the partial image if a preview is due (or `force`).
    pub fn preview(&mut self, film: &Film, force: bool) {
        let Some(path) = &self.preview else { return };
        if !force && self.last_preview.elapsed() < self.preview_every {
            return;
        }
        self.last_preview = Instant::now();
        if let Err(e) = film.write(path) {
            self.note(&format!("sunray: warning: preview {}: {e}", path.display()));
        }
    }

    /// Removes the bar at the end of the job.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}
