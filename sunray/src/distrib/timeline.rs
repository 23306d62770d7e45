//! A job's timeline (DESIGN section 10): when each step of the job happened, in seconds since
//! it was submitted, so that every fixed cost shows. The job's steps are the controller's
//! start, the first and the last line in, the image stored (the finished checkpoint in REM,
//! which `fetch` reads) and the end (the statistics stored); each node's are its spawn, its
//! scene ready (the model fetched and decoded), its accelerator ready (built or read) and its
//! first line in. A step that did not happen (a node that never rendered) is `None`, `null`
//! in the JSON.
//!
//! The origin is the submitting host's wall clock when `sunray submit` started
//! ([`JobClock`]); the controller reads its own wall clock against it (the hosts' clocks are
//! assumed to agree, as NTP keeps them). A node's scene and accelerator steps are the
//! worker's own clock counted back from the arrival of its first Request
//! ([`NodeTimeline::worker_reported`]): no two hosts' clocks are compared for them.

use super::checkpoint::unix_ms;
use serde::{Deserialize, Serialize};

/// The wall-clock origin of a job's timeline.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct JobClock {
    /// When the job was submitted (milliseconds since the Unix epoch); 0 when unknown, in
    /// which case the clock starts when it is made ([`JobClock::at`]).
    pub origin_unix_ms: u64,
}

impl JobClock {
    /// The clock of a job submitted at `origin_unix_ms` (0: now).
    pub fn at(origin_unix_ms: u64) -> JobClock {
        JobClock {
            origin_unix_ms: if origin_unix_ms == 0 {
                unix_ms()
            } else {
                origin_unix_ms
            },
        }
    }

    /// Seconds from the submit to now (0 if this host's clock is behind the submitter's).
    pub fn now(&self) -> f64 {
        unix_ms().saturating_sub(self.origin_unix_ms) as f64 / 1000.0
    }
}

/// The job's steps, in seconds since it was submitted.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timeline {
    /// The submitting host had the job's model: compiled, or recalled from an earlier
    /// submit of the same file (and its remd connected).
    pub model_ready: Option<f64>,
    /// The model was in REM: its chunks put through the submitting host's remd, or found
    /// there.
    pub model_stored: Option<f64>,
    /// The controller started (this run's: a restarted controller's own start).
    pub controller_started: Option<f64>,
    /// The first line of this run came in.
    pub first_line: Option<f64>,
    /// The last line came in.
    pub last_line: Option<f64>,
    /// The finished image (every line) was stored in REM's checkpoint store.
    pub image_stored: Option<f64>,
    /// The job ended: its statistics were made. A farm job ends when its image is stored
    /// (its record says finished, `submit` fetches the image) and its workers wind down
    /// after; a job in the submitting process ends when its workers have stopped.
    pub finished: Option<f64>,
    /// `sunray submit`, following a farm job, had written its image (set by submit in the
    /// statistics it writes; the stored ones end at `finished`).
    pub image_written: Option<f64>,
}

/// A node's steps, in seconds since its job was submitted.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NodeTimeline {
    /// REM started the worker (or this controller took it over).
    pub spawned: Option<f64>,
    /// The worker had the scene's model decoded.
    pub scene_ready: Option<f64>,
    /// The worker had its accelerator built or read.
    pub accel_ready: Option<f64>,
    /// Its first line came in.
    pub first_line: Option<f64>,
}

impl NodeTimeline {
    /// Takes the worker's own clock from a Request that came in at `now` (job time): it was
    /// sent at `stamp_s` on the worker's clock, and the scene and the accelerator were ready
    /// at `scene_s` and `accel_s` on that clock. Counted back from the Request's arrival,
    /// the steps are late by at most the message's trip, never before the spawn nor after
    /// the node's first line (a worker taken over sends the lines it rendered meanwhile
    /// before its Request). Figures that are absent (0), not finite, or after the stamp
    /// are ignored; the first figures known are kept.
    pub fn worker_reported(&mut self, now: f64, stamp_s: f64, scene_s: f64, accel_s: f64) {
        let before = |s: f64| {
            (s.is_finite() && stamp_s.is_finite() && s > 0.0 && s <= stamp_s).then(|| {
                (now - (stamp_s - s))
                    .min(self.first_line.unwrap_or(f64::INFINITY))
                    .max(self.spawned.unwrap_or(0.0))
            })
        };
        let (scene, accel) = (before(scene_s), before(accel_s));
        self.scene_ready = self.scene_ready.or(scene);
        self.accel_ready = self.accel_ready.or(accel);
    }
}

/// Sets `slot` to `t` unless it is set (the first time wins).
pub fn first(slot: &mut Option<f64>, t: f64) {
    slot.get_or_insert(t);
}

impl Timeline {
    /// The steps that happened, in order, with their names.
    pub fn steps(&self) -> Vec<(&'static str, f64)> {
        [
            ("model ready", self.model_ready),
            ("model stored", self.model_stored),
            ("controller", self.controller_started),
            ("first line", self.first_line),
            ("last line", self.last_line),
            ("image stored", self.image_stored),
            ("finished", self.finished),
            ("image written", self.image_written),
        ]
        .into_iter()
        .filter_map(|(name, t)| t.map(|t| (name, t)))
        .collect()
    }

    /// The one line `submit` prints under the per-node table:
    /// `timeline: controller 0.12 s, first line 0.31 s, ...`.
    pub fn line(&self) -> String {
        let steps: Vec<String> = self
            .steps()
            .into_iter()
            .map(|(name, t)| format!("{name} {t:.2} s"))
            .collect();
        format!("timeline (seconds since submit): {}", steps.join(", "))
    }

    /// The timeline of a job whose submitting host had its model at `ready_s` and stored
    /// it in REM at `stored_s` (seconds since the submit; 0: not known).
    pub fn submitted(ready_s: f64, stored_s: f64) -> Timeline {
        let known = |t: f64| (t > 0.0 && t.is_finite()).then_some(t);
        Timeline {
            model_ready: known(ready_s),
            model_stored: known(stored_s),
            ..Timeline::default()
        }
    }

    /// True when the steps that happened are in their order.
    pub fn is_ordered(&self) -> bool {
        self.steps().windows(2).all(|w| w[0].1 <= w[1].1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_lists_the_steps_that_happened_in_order() {
        let t = Timeline {
            model_ready: None,
            model_stored: None,
            controller_started: Some(0.1),
            first_line: Some(0.25),
            last_line: Some(1.5),
            image_stored: None,
            finished: Some(1.75),
            image_written: None,
        };
        assert_eq!(
            t.line(),
            "timeline (seconds since submit): controller 0.10 s, first line 0.25 s, last line 1.50 s, finished 1.75 s"
        );
        assert!(t.is_ordered());
        let wrong = Timeline {
            first_line: Some(2.0),
            ..t
        };
        assert!(!wrong.is_ordered());
    }

    #[test]
    fn a_workers_own_clock_counts_back_from_its_requests_arrival() {
        let mut n = NodeTimeline {
            spawned: Some(0.5),
            ..Default::default()
        };
        // Sent at 2.0 s on its clock, in at 3.0 s job time: scene ready 1.5 s before.
        n.worker_reported(3.0, 2.0, 0.5, 1.0);
        assert_eq!((n.scene_ready, n.accel_ready), (Some(1.5), Some(2.0)));
        // Later Requests do not move what is known.
        n.worker_reported(9.0, 2.5, 0.5, 1.0);
        assert_eq!((n.scene_ready, n.accel_ready), (Some(1.5), Some(2.0)));
        // Never before the spawn; figures absent, not finite or after the stamp are ignored.
        let mut m = NodeTimeline {
            spawned: Some(0.5),
            ..Default::default()
        };
        m.worker_reported(1.0, 5.0, 0.1, f64::NAN);
        assert_eq!((m.scene_ready, m.accel_ready), (Some(0.5), None));
        m.worker_reported(1.0, 5.0, 0.0, 6.0);
        assert_eq!(m.accel_ready, None);
        // A worker taken over: its lines came before its Request.
        let mut adopted = NodeTimeline {
            spawned: Some(0.5),
            first_line: Some(0.75),
            ..Default::default()
        };
        adopted.worker_reported(2.0, 9.0, 8.5, 8.75);
        assert_eq!(adopted.scene_ready, Some(0.75));
    }

    #[test]
    fn the_first_time_wins_and_the_clock_starts_at_its_origin() {
        let mut slot = None;
        first(&mut slot, 1.0);
        first(&mut slot, 2.0);
        assert_eq!(slot, Some(1.0));
        let clock = JobClock::at(unix_ms() - 1500);
        assert!((1.4..10.0).contains(&clock.now()), "{}", clock.now());
        assert!(JobClock::at(0).now() < 1.0);
        assert_eq!(JobClock::at(u64::MAX).now(), 0.0);
    }

    #[test]
    fn the_submit_steps_come_first_and_unknown_ones_are_left_out() {
        let t = Timeline {
            controller_started: Some(2.5),
            ..Timeline::submitted(1.25, 2.0)
        };
        assert_eq!(
            t.line(),
            "timeline (seconds since submit): model ready 1.25 s, model stored 2.00 s, controller 2.50 s"
        );
        assert!(t.is_ordered());
        assert_eq!(Timeline::submitted(0.0, f64::NAN), Timeline::default());
    }

    #[test]
    fn the_json_has_every_step_null_when_it_did_not_happen() {
        let v = serde_json::to_value(Timeline {
            first_line: Some(0.5),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(v["first_line"], 0.5);
        assert!(v["finished"].is_null() && v.get("controller_started").is_some());
    }
}
