//! Following a farm job from any host: `watch` (its state and lines until it ends, through
//! controller moves), `fetch` (the finished image, from its last checkpoint) and `cancel`.

use super::tail::ControllerTail;
use super::FarmError;
use crate::distrib::checkpoint;
use crate::distrib::job_record;
use crate::film::Format;
use rem::store::job_store::is_ended;
use rem::{JobRecord, RemClient};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// How often `watch` reads the job's record: every [`POLL_FIRST`] after a change (the job's
/// start included), twice as long each time nothing changed, up to [`POLL`]. A short job's
/// end is seen within a few tens of milliseconds (a fixed cost of every job, DESIGN section
/// 10), a long job costs its remd a read every quarter second.
pub const POLL: Duration = Duration::from_millis(250);
/// The first wait after a change of the record (see [`POLL`]).
pub const POLL_FIRST: Duration = Duration::from_millis(20);

/// How a watched job ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Ended {
    /// Every line is in; the record carries the per-node table.
    Finished {
        /// The per-node table and totals, as `submit` prints them.
        summary: String,
    },
    /// Failed, with REM's reason.
    Failed(String),
    /// Cancelled by its owner.
    Cancelled(String),
}

/// How `watch` shows the job.
#[derive(Clone, Debug, Default)]
pub struct WatchView {
    /// Draw a progress bar on stderr.
    pub bar: bool,
    /// Print JSON events on stderr (state, controller and progress changes).
    pub events: bool,
    /// Show the controller's own output, as `submit` with the controller in-process does:
    /// its JSON events (with `events`; they also move the bar) and its warnings.
    pub controller_output: bool,
    /// Rewrite the partial image (from the checkpoint) to this file every so often.
    pub preview: Option<(PathBuf, Duration)>,
}

/// What changed between two records of the same job, as events.
pub fn changes(before: Option<&JobRecord>, now: &JobRecord) -> Vec<serde_json::Value> {
    let mut out = Vec::new();
    let moved = before.is_none_or(|b| b.epoch != now.epoch || b.controller != now.controller);
    if moved && !now.controller.is_empty() {
        out.push(json!({"event": "controller", "epoch": now.epoch,
            "host": now.controller_host, "proc": now.controller}));
    }
    if before.is_none_or(|b| b.state != now.state) {
        out.push(
            json!({"event": "state", "state": now.state, "epoch": now.epoch,
            "message": now.message}),
        );
    }
    if before.is_none_or(|b| b.progress_done != now.progress_done) {
        out.push(json!({"event": "progress", "done": now.progress_done,
            "total": now.progress_total}));
    }
    out
}

/// Follows job `job` through the remd at `addr` until it ends.
pub async fn watch(
    client: &RemClient,
    addr: &str,
    job: &str,
    view: WatchView,
) -> Result<Ended, FarmError> {
    let mut last: Option<JobRecord> = None;
    let mut shown = Shown::new(job, &view);
    let mut tail = ControllerTail::default();
    let mut preview = view.preview.clone().map(PreviewWriter::new);
    let mut wait = POLL_FIRST;
    loop {
        let found = job_record::find(client, job)
            .await
            .map_err(|e| FarmError::from_rem(e, addr, job))?;
        let Some(now) = found else {
            shown.abandon();
            // Seen, then gone: every host that kept it was lost with it.
            return match last {
                Some(_) => Ok(Ended::Failed(
                    "no live host holds its record any more: the hosts that kept it were lost"
                        .into(),
                )),
                None => Err(FarmError::NoRecord(job.to_string())),
            };
        };
        for ev in changes(last.as_ref(), &now) {
            if view.events {
                shown.line(&ev.to_string());
            }
        }
        if view.controller_output && !now.controller.is_empty() {
            for line in tail.read(client, &now.controller).await {
                shown.controller_line(&line);
            }
        }
        shown.record(&now);
        if is_ended(&now.state) {
            if view.controller_output {
                for line in tail.flush() {
                    shown.controller_line(&line);
                }
            }
            shown.finish();
            return Ok(match now.state.as_str() {
                "finished" => Ended::Finished {
                    summary: job_record::from_record(&now).summary,
                },
                "cancelled" => Ended::Cancelled(now.message),
                _ => Ended::Failed(now.message),
            });
        }
        if let Some(p) = &mut preview {
            p.maybe_write(client, job, now.progress_done).await;
        }
        wait = if last.as_ref() == Some(&now) {
            (wait * 2).min(POLL)
        } else {
            POLL_FIRST
        };
        last = Some(now);
        tokio::time::sleep(wait).await;
    }
}

/// What `watch` draws: the bar (moved by the record and the controller's line events) and
/// lines printed above it.
struct Shown {
    bar: Option<indicatif::ProgressBar>,
    events: bool,
    done: u64,
}

impl Shown {
    fn new(job: &str, view: &WatchView) -> Shown {
        let bar = view.bar.then(|| {
            let b = indicatif::ProgressBar::new(0);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{prefix} [{bar:40}] {pos}/{len} lines {msg}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b.set_prefix(job.to_string());
            b
        });
        Shown {
            bar,
            events: view.events,
            done: 0,
        }
    }

    fn line(&self, text: &str) {
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{text}")),
            None => eprintln!("{text}"),
        }
    }

    /// A line of the controller's stderr: an event (shown with `--events`) or a warning.
    fn controller_line(&mut self, text: &str) {
        match serde_json::from_str::<serde_json::Value>(text) {
            Ok(v) if v.get("event").is_some() => {
                if v["event"] == "line" {
                    self.done = self.done.max(v["done"].as_u64().unwrap_or(0));
                    if let Some(b) = &self.bar {
                        b.set_position(b.position().max(self.done));
                    }
                }
                if self.events {
                    self.line(text);
                }
            }
            _ => self.line(text),
        }
    }

    fn record(&mut self, now: &JobRecord) {
        if let Some(b) = &self.bar {
            b.set_length(now.progress_total);
            b.set_position(now.progress_done.max(self.done));
            b.set_message(format!(
                "{} (epoch {}, {})",
                now.state, now.epoch, now.controller_host
            ));
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }

    fn abandon(&self) {
        if let Some(b) = &self.bar {
            b.abandon();
        }
    }
}

/// `submit --preview` for a farm job: the partial image from the checkpoint, rewritten when
/// the checkpoint has grown and the period has passed.
struct PreviewWriter {
    path: PathBuf,
    every: Duration,
    at: Option<tokio::time::Instant>,
    lines: Option<u64>,
}

impl PreviewWriter {
    fn new((path, every): (PathBuf, Duration)) -> PreviewWriter {
        PreviewWriter {
            path,
            every,
            at: None,
            lines: None,
        }
    }

    async fn maybe_write(&mut self, client: &RemClient, job: &str, lines: u64) {
        let due = self.at.is_none_or(|t| t.elapsed() >= self.every);
        if !due || self.lines == Some(lines) {
            return;
        }
        self.at = Some(tokio::time::Instant::now());
        self.lines = Some(lines);
        if let Ok(Some(restored)) = checkpoint::load(client, job).await {
            let (w, h) = restored.size();
            if let Err(e) = restored.film(w, h).write(&self.path) {
                eprintln!("sunray: warning: preview: {e}");
            }
        }
    }
}

/// A finished job's statistics as `--stats-json` writes them, if its controller stored them.
pub async fn stats_json(client: &RemClient, job: &str) -> Result<Option<Vec<u8>>, FarmError> {
    Ok(client.get_checkpoint(&super::stats_key(job)).await?)
}

/// The statistics JSON `stats` with `timeline.image_written` set to `at_s` (seconds since
/// the submit); unchanged when it is not a job's statistics.
pub fn with_image_written(stats: &[u8], at_s: f64) -> Vec<u8> {
    let Ok(mut v) = serde_json::from_slice::<serde_json::Value>(stats) else {
        return stats.to_vec();
    };
    match v.get_mut("timeline").and_then(|t| t.as_object_mut()) {
        Some(t) => {
            t.insert("image_written".into(), json!(at_s));
            serde_json::to_vec_pretty(&v).unwrap_or_else(|_| stats.to_vec())
        }
        None => stats.to_vec(),
    }
}

/// Writes job `job`'s finished image to `out` (.png, .ppm, .pfm or .exr, as `sunray render`),
/// and with `samples_map` the heat map of the samples its pixels took (a job rendered to an
/// error).
pub async fn fetch(
    client: &RemClient,
    job: &str,
    out: &Path,
    samples_map: Option<&Path>,
) -> Result<(), FarmError> {
    Format::from_path(out)?;
    if let Some(path) = samples_map {
        Format::from_path(path)?;
    }
    let restored = finished_checkpoint(client, job).await?;
    let (width, height) = restored.size();
    let map = match samples_map {
        Some(path) => match restored.samples_map() {
            Some(map) => Some((path, map)),
            None => {
                return Err(FarmError::Stored {
                    job: job.to_string(),
                    reason: "it was not rendered to an error, so it has no samples map".into(),
                })
            }
        },
        None => None,
    };
    let film = restored.film(width, height);
    film.write(out)?;
    if let Some((path, map)) = map {
        map.write(path)?;
    }
    Ok(())
}

/// How long `fetch` waits for the image of a job whose record says finished: the checkpoint
/// copies on the hosts that answer can trail the record by a write when the host that took
/// the last one is stopped or cut off (seen in the chaos test: 63 of 64 lines).
pub const FETCH_CATCH_UP: Duration = Duration::from_secs(10);

/// Job `job`'s checkpoint with every line in. When fewer are in but its record says
/// finished (read once: finished is final), it is read again every [`POLL`] for up to
/// [`FETCH_CATCH_UP`].
async fn finished_checkpoint(
    client: &RemClient,
    job: &str,
) -> Result<checkpoint::Restored, FarmError> {
    let deadline = tokio::time::Instant::now() + FETCH_CATCH_UP;
    let mut said_finished = None;
    loop {
        let Some(restored) = checkpoint::load(client, job).await? else {
            let ended = job_record::find(client, job)
                .await?
                .filter(|r| is_ended(&r.state));
            let reason = match ended {
                Some(r) => format!(
                    "its record says {}, but no host keeps its image any more (REM removes ended jobs' checkpoints after its retention, or sooner to make room under its checkpoint quota)",
                    r.state
                ),
                None => "no host holds its image or checkpoint".into(),
            };
            return Err(FarmError::Stored {
                job: job.to_string(),
                reason,
            });
        };
        let (_, height) = restored.size();
        let finished = restored.finished_lines();
        if finished >= height {
            return Ok(restored);
        }
        let said = match said_finished {
            Some(said) => said,
            None => {
                let r = job_record::find(client, job).await?;
                *said_finished.insert(r.is_some_and(|r| r.state == "finished"))
            }
        };
        if !said || tokio::time::Instant::now() >= deadline {
            let why = if said {
                format!("its record says finished, but after {} s the hosts that answer hold {finished} of {height} lines (the host with the rest may be down)", FETCH_CATCH_UP.as_secs())
            } else {
                format!("it is not finished: {finished} of {height} lines are in (`sunray watch {job}` waits for it)")
            };
            return Err(FarmError::Stored {
                job: job.to_string(),
                reason: why,
            });
        }
        tokio::time::sleep(POLL).await;
    }
}

/// Cancels job `job`: its record says cancelled (so no controller is started again), then
/// its controller and workers are ended. Returns the record as it was.
pub async fn cancel(client: &RemClient, job: &str) -> Result<JobRecord, FarmError> {
    for _ in 0..3 {
        let r = job_record::find(client, job)
            .await?
            .ok_or_else(|| FarmError::NoRecord(job.to_string()))?;
        if is_ended(&r.state) {
            return Err(FarmError::Stored {
                job: job.to_string(),
                reason: format!("it has already ended ({})", r.state),
            });
        }
        let mut cancelled = r.clone();
        cancelled.state = "cancelled".into();
        cancelled.message = "cancelled by its owner".into();
        match client.put_job(cancelled).await {
            // The controller moved meanwhile: read the record again.
            Err(e) if e.is_fenced() => continue,
            Err(e) => return Err(e.into()),
            Ok(_) => {}
        }
        let prefix = format!("{job}.");
        let procs = client.ps().await?;
        for p in procs
            .iter()
            .filter(|p| p.state == "running" && p.job.starts_with(&prefix))
        {
            if let Some(id) = rem::ProcId::parse(&p.proc_id) {
                let _ = client.kill(&id).await;
            }
        }
        return Ok(r);
    }
    Err(FarmError::Stored {
        job: job.to_string(),
        reason: "its controller keeps moving; try again".into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(state: &str, epoch: u64, done: u64) -> JobRecord {
        JobRecord {
            id: "j".into(),
            state: state.into(),
            epoch,
            controller: format!("h{epoch}/1"),
            controller_host: format!("h{epoch}"),
            progress_done: done,
            progress_total: 64,
            ..JobRecord::default()
        }
    }

    #[test]
    fn watch_reports_moves_states_and_progress_once_each() {
        let first = changes(None, &record("running", 1, 0));
        assert_eq!(first.len(), 3);
        assert!(changes(Some(&record("running", 1, 5)), &record("running", 1, 5)).is_empty());
        let moved = changes(Some(&record("running", 1, 5)), &record("running", 2, 9));
        let kinds: Vec<&str> = moved.iter().map(|e| e["event"].as_str().unwrap()).collect();
        assert_eq!(kinds, ["controller", "progress"]);
        assert_eq!(moved[0]["host"], "h2");
        let ended = changes(Some(&record("running", 2, 9)), &record("finished", 2, 9));
        assert_eq!(ended[0]["state"], "finished");
    }

    #[test]
    fn the_written_image_is_the_last_step_of_the_statistics_submit_writes() {
        let stats = br#"{"job": "j", "timeline": {"finished": 1.5, "image_written": null}}"#;
        let v: serde_json::Value =
            serde_json::from_slice(&with_image_written(stats, 1.75)).unwrap();
        assert_eq!(v["timeline"]["image_written"], 1.75);
        assert_eq!(v["timeline"]["finished"], 1.5);
        assert_eq!(v["job"], "j");
        for not_stats in [&b"not json"[..], br#"{"job": "j"}"#] {
            assert_eq!(with_image_written(not_stats, 1.0), not_stats);
        }
    }
}
