//! `sunray bench shares`: the figures of a farm many people share, from the timeline that
//! `deploy/bench/run.sh shares` records on the compose cluster (the farm's queue read every
//! half second while three users' staggered jobs run): each job's wait (submit to its first
//! slot), run time (first slot to its end) and slots over time (a plotters plot), and each
//! user's slot-seconds against the fair share the queue gave them over the same time.

use plotters::prelude::*;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use super::plot::PlotError;

/// A job as the driver submitted it.
#[derive(Clone, Debug, Deserialize)]
pub struct PlannedJob {
    /// Its id.
    pub id: String,
    /// Whose it is.
    pub user: String,
    /// Seconds after the start when its submit returned (`None`: never submitted).
    pub at_s: Option<f64>,
    /// Its `--hosts`.
    pub hosts: u32,
    /// Its `--priority`.
    pub priority: u32,
}

/// One job in one reading of the queue (`rem queue --json`).
#[derive(Clone, Debug, Deserialize)]
pub struct QueuedJob {
    /// Its id.
    pub id: String,
    /// Whose it is.
    pub user: String,
    /// Slots its workers held (its record's).
    pub slots: u32,
    /// Slots the queue's rule gave it.
    pub share: u32,
    /// Its place while it waited (`None`: the rule let it run).
    pub queue_position: Option<u32>,
}

/// One reading of the queue.
#[derive(Clone, Debug, Deserialize)]
pub struct Reading {
    /// Seconds after the start.
    pub t: f64,
    /// Slots the live hosts lent.
    pub slots: u32,
    /// The active jobs.
    pub jobs: Vec<QueuedJob>,
}

/// The driver's record of a run (`deploy/bench/results/shares.json`).
#[derive(Clone, Debug, Deserialize)]
pub struct Timeline {
    /// The image size.
    pub resolution: String,
    /// The jobs, in the order they were submitted.
    pub jobs: Vec<PlannedJob>,
    /// The queue, read every half second.
    pub samples: Vec<Reading>,
    /// Jobs whose image differed from `sunray render`.
    #[serde(default)]
    pub differ: Vec<String>,
}

/// What became of one job.
#[derive(Clone, Debug, PartialEq)]
pub struct JobFigures {
    /// Its id and user.
    pub id: String,
    /// Whose it is.
    pub user: String,
    /// Its priority.
    pub priority: u32,
    /// Submit to the first reading with a slot held (seconds).
    pub wait_s: Option<f64>,
    /// First slot to the first reading without it (seconds).
    pub run_s: Option<f64>,
    /// Most slots it held at once.
    pub peak: u32,
}

/// Each user's slot-seconds held, and those the queue's shares gave them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UserFigures {
    /// Slot-seconds held.
    pub got: f64,
    /// Slot-seconds of the shares.
    pub fair: f64,
}

/// The figures of a timeline.
pub fn figures(t: &Timeline) -> (Vec<JobFigures>, BTreeMap<String, UserFigures>) {
    let jobs = t
        .jobs
        .iter()
        .map(|j| {
            let seen = |r: &Reading| {
                r.jobs
                    .iter()
                    .find(|q| q.id == j.id && q.user == j.user)
                    .cloned()
            };
            let first = t
                .samples
                .iter()
                .find(|r| seen(r).is_some_and(|q| q.slots > 0));
            let last_seen = t.samples.iter().rposition(|r| seen(r).is_some());
            let end = last_seen.and_then(|i| t.samples.get(i + 1)).map(|r| r.t);
            let peak = t
                .samples
                .iter()
                .filter_map(seen)
                .map(|q| q.slots)
                .max()
                .unwrap_or(0);
            JobFigures {
                id: j.id.clone(),
                user: j.user.clone(),
                priority: j.priority,
                wait_s: first.zip(j.at_s).map(|(f, at)| (f.t - at).max(0.0)),
                run_s: first.zip(end).map(|(f, e)| e - f.t),
                peak,
            }
        })
        .collect();
    let mut users: BTreeMap<String, UserFigures> = BTreeMap::new();
    for w in t.samples.windows(2) {
        let dt = w[1].t - w[0].t;
        for q in &w[0].jobs {
            let u = users.entry(q.user.clone()).or_default();
            u.got += f64::from(q.slots) * dt;
            u.fair += f64::from(q.share) * dt;
        }
    }
    (jobs, users)
}

/// The report: the jobs' and users' tables, in Markdown.
pub fn report(t: &Timeline) -> String {
    let (jobs, users) = figures(t);
    let lent = t.samples.iter().map(|r| r.slots).max().unwrap_or(0);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Six workstations lending {lent} slots, mount6 at {}; the queue read every half second \
         (`deploy/bench/run.sh shares`).\n",
        t.resolution
    );
    s.push_str("| job | user | priority | hosts | wait s | run s | most slots |\n");
    s.push_str("|---|---|---|---|---|---|---|\n");
    let secs = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{v:.1}"));
    for (j, plan) in jobs.iter().zip(&t.jobs) {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            j.id,
            j.user,
            j.priority,
            plan.hosts,
            secs(j.wait_s),
            secs(j.run_s),
            j.peak
        );
    }
    s.push_str("\n| user | slot-seconds held | fair share (the queue's) | held / fair |\n");
    s.push_str("|---|---|---|---|\n");
    for (user, u) in &users {
        let ratio = if u.fair > 0.0 { u.got / u.fair } else { 0.0 };
        let _ = writeln!(s, "| {user} | {:.1} | {:.1} | {ratio:.2} |", u.got, u.fair);
    }
    if !t.differ.is_empty() {
        let _ = writeln!(
            s,
            "\nImages that differ from `sunray render`: {}",
            t.differ.join(", ")
        );
    }
    s
}

const W: u32 = 900;
const H: u32 = 500;
const COLOURS: [[u8; 3]; 6] = [
    [31, 119, 180],
    [214, 39, 40],
    [44, 160, 44],
    [148, 103, 189],
    [255, 127, 14],
    [23, 190, 207],
];

/// Slots each job held over time, one stepped line per job, into a PNG at `path`.
pub fn plot(t: &Timeline, path: &Path) -> Result<(), PlotError> {
    super::plot::register_font()?;
    let end = t.samples.last().map_or(1.0, |r| r.t).max(1.0);
    let top = t.samples.iter().map(|r| r.slots).max().unwrap_or(1).max(1);
    let mut buf = vec![255u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(super::plot::draw_err)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Slots each job held (three users, six slots)",
                (super::plot::FONT, 22),
            )
            .margin(16)
            .x_label_area_size(45)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..end, 0.0..f64::from(top) + 0.5)
            .map_err(super::plot::draw_err)?;
        chart
            .configure_mesh()
            .x_desc("seconds since the first submit")
            .y_desc("slots")
            .label_style((super::plot::FONT, 14))
            .axis_desc_style((super::plot::FONT, 16))
            .light_line_style(RGBColor(242, 242, 242))
            .draw()
            .map_err(super::plot::draw_err)?;
        for (k, j) in t.jobs.iter().enumerate() {
            let c = COLOURS[k % COLOURS.len()];
            let c = RGBColor(c[0], c[1], c[2]);
            let mut points = Vec::new();
            for w in t.samples.windows(2) {
                let held = w[0]
                    .jobs
                    .iter()
                    .find(|q| q.id == j.id && q.user == j.user)
                    .map_or(0.0, |q| f64::from(q.slots));
                // Offset a little per job, so that equal counts do not hide each other.
                let y = held + 0.04 * k as f64;
                points.push((w[0].t, y));
                points.push((w[1].t, y));
            }
            let name = format!("{} ({}, priority {})", j.id, j.user, j.priority);
            chart
                .draw_series(LineSeries::new(points, c.stroke_width(2)))
                .map_err(super::plot::draw_err)?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .label_font((super::plot::FONT, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(180, 180, 180))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(super::plot::draw_err)?;
        root.present().map_err(super::plot::draw_err)?;
    }
    super::plot::save_png(buf, (W, H), path)
}

/// Reads the timeline at `input`, writes `shares.md` and `shares.png` into `out_dir` and
/// returns the report.
pub fn run(input: &Path, out_dir: &Path) -> Result<String, SharesError> {
    let text = std::fs::read_to_string(input)
        .map_err(|e| SharesError::Read(input.display().to_string(), e.to_string()))?;
    let t: Timeline = serde_json::from_str(&text)
        .map_err(|e| SharesError::Read(input.display().to_string(), e.to_string()))?;
    let report = report(&t);
    std::fs::create_dir_all(out_dir).map_err(|e| SharesError::Write(e.to_string()))?;
    let md = format!("# A farm three users share\n\n{report}\n![slots over time](shares.png)\n");
    crate::film::write_atomically(&out_dir.join("shares.md"), md.as_bytes())
        .map_err(|e| SharesError::Write(e.to_string()))?;
    plot(&t, &out_dir.join("shares.png"))?;
    Ok(report)
}

/// Why the figures could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SharesError {
    /// The timeline could not be read or parsed.
    #[error("{0}: {1}")]
    Read(String, String),
    /// The report could not be written.
    #[error("writing the report: {0}")]
    Write(String),
    /// The plot failed.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reading(t: f64, jobs: &[(&str, &str, u32, u32)]) -> Reading {
        Reading {
            t,
            slots: 2,
            jobs: jobs
                .iter()
                .map(|&(id, user, slots, share)| QueuedJob {
                    id: id.into(),
                    user: user.into(),
                    slots,
                    share,
                    queue_position: (share == 0).then_some(1),
                })
                .collect(),
        }
    }

    fn timeline() -> Timeline {
        let job = |id: &str, user: &str, at| PlannedJob {
            id: id.into(),
            user: user.into(),
            at_s: Some(at),
            hosts: 2,
            priority: 50,
        };
        Timeline {
            resolution: "8x8".into(),
            jobs: vec![job("a", "alice", 0.0), job("b", "bob", 1.0)],
            samples: vec![
                reading(0.5, &[("a", "alice", 2, 2)]),
                reading(1.5, &[("a", "alice", 2, 1), ("b", "bob", 0, 1)]),
                reading(2.5, &[("a", "alice", 1, 1), ("b", "bob", 1, 1)]),
                reading(3.5, &[("b", "bob", 2, 2)]),
                reading(4.5, &[]),
            ],
            differ: Vec::new(),
        }
    }

    #[test]
    fn waits_runs_and_slot_seconds_come_from_the_readings() {
        let (jobs, users) = figures(&timeline());
        assert_eq!(jobs[0].wait_s, Some(0.5));
        assert_eq!(jobs[0].run_s, Some(3.0), "first slot at 0.5, gone at 3.5");
        assert_eq!(
            jobs[1].wait_s,
            Some(1.5),
            "submitted at 1, first slot read at 2.5"
        );
        assert_eq!((jobs[1].run_s, jobs[1].peak), (Some(2.0), 2));
        // alice: 2 + 2 + 1 slot-seconds held, 2 + 1 + 1 given; bob: 0 + 1 + 2 held, 1 + 1 + 2.
        assert_eq!(
            users["alice"],
            UserFigures {
                got: 5.0,
                fair: 4.0
            }
        );
        assert_eq!(
            users["bob"],
            UserFigures {
                got: 3.0,
                fair: 4.0
            }
        );
        let text = report(&timeline());
        assert!(text.contains("| alice | 5.0 | 4.0 | 1.25 |"), "{text}");
    }

    #[test]
    fn the_plot_and_report_are_written() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("shares.json");
        let json = r#"{"resolution": "8x8", "jobs": [{"id": "a", "user": "alice", "at_s": 0.0,
            "hosts": 1, "priority": 50}], "samples": [{"t": 0.0, "slots": 1, "jobs": [{"id": "a",
            "user": "alice", "state": "running", "slots": 1, "share": 1, "queue_position": null}]},
            {"t": 1.0, "slots": 1, "jobs": []}]}"#;
        std::fs::write(&input, json).unwrap();
        let text = run(&input, dir.path()).unwrap();
        assert!(
            text.contains("| a | alice | 50 | 1 | 0.0 | 1.0 | 1 |"),
            "{text}"
        );
        assert!(image::open(dir.path().join("shares.png")).is_ok());
        let bad = dir.path().join("bad.json");
        std::fs::write(&bad, "{").unwrap();
        assert!(matches!(run(&bad, dir.path()), Err(SharesError::Read(..))));
    }
}
