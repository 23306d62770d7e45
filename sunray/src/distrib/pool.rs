//! A worker's render threads: plain OS threads pulling granted lines from a local queue and
//! rendering them with [`crate::render::render_line`], so rendering never blocks the async
//! runtime that talks to REM. Results go back over a tokio channel.

use crate::accel::{Accel, Scratch};
use crate::render::{render_line, RenderOptions};
use crate::scene::Scene;
use crate::stats::Counters;
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A line to render under a grant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineJob {
    pub line: u32,
    pub grant: u64,
}

/// A rendered line.
#[derive(Clone, Debug, PartialEq)]
pub struct Rendered {
    pub job: LineJob,
    pub pixels: Vec<[f32; 3]>,
    pub counters: Counters,
    /// Wall time the thread spent on the line.
    pub line_s: f64,
    /// Wall time the thread waited for this line (since its previous one, or its start).
    pub wait_s: f64,
    /// The thread's first line (its wait includes the start-up).
    pub first: bool,
}

/// What the threads render.
pub struct PoolScene {
    pub scene: Arc<Scene>,
    pub accel: Arc<Accel>,
    pub opts: RenderOptions,
    pub mailbox: bool,
    /// Extra time per line (a test and benchmark hook that makes a worker slow).
    pub delay: Duration,
}

/// The render threads. Dropping the pool lets them finish their current line and stop.
pub struct RenderPool {
    jobs: mpsc::Sender<LineJob>,
    threads: usize,
}

impl RenderPool {
    /// Starts `threads` (at least 1) threads sending results to `results`.
    pub fn start(
        what: PoolScene,
        threads: usize,
        results: tokio::sync::mpsc::UnboundedSender<Rendered>,
    ) -> std::io::Result<RenderPool> {
        let (tx, rx) = mpsc::channel::<LineJob>();
        let rx = Arc::new(Mutex::new(rx));
        let what = Arc::new(what);
        let threads = threads.max(1);
        for i in 0..threads {
            let (rx, what, results) = (rx.clone(), what.clone(), results.clone());
            std::thread::Builder::new()
                .name(format!("render-{i}"))
                .spawn(move || render_loop(&what, &rx, &results))?;
        }
        Ok(RenderPool { jobs: tx, threads })
    }

    /// Queues a line; false when the threads are gone.
    pub fn submit(&self, job: LineJob) -> bool {
        self.jobs.send(job).is_ok()
    }

    pub fn threads(&self) -> usize {
        self.threads
    }
}

fn render_loop(
    what: &PoolScene,
    jobs: &Mutex<mpsc::Receiver<LineJob>>,
    results: &tokio::sync::mpsc::UnboundedSender<Rendered>,
) {
    let mut scratch = Scratch::new(what.scene.prims.len(), what.mailbox);
    let mut first = true;
    loop {
        // The lock is held only while waiting for the next job.
        let waiting = Instant::now();
        let job = match jobs.lock() {
            Ok(rx) => rx.recv(),
            Err(_) => return,
        };
        let Ok(job) = job else { return };
        let t = Instant::now();
        let wait_s = (t - waiting).as_secs_f64();
        let line = render_line(&what.scene, &what.accel, job.line, &what.opts, &mut scratch);
        if !what.delay.is_zero() {
            std::thread::sleep(what.delay);
        }
        let rendered = Rendered {
            job,
            pixels: line.pixels,
            counters: line.counters,
            line_s: t.elapsed().as_secs_f64(),
            wait_s,
            first,
        };
        first = false;
        if results.send(rendered).is_err() {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelOptions;

    pub(crate) fn small_scene() -> (Arc<Scene>, Arc<Accel>, RenderOptions) {
        let table = yari::colour::ColourTable::default();
        let loaded = yari::load::load_str(
            "default.yari",
            super::super::DEFAULT_SCENE,
            yari::load::InputKind::Yari,
            &table,
        )
        .unwrap();
        let scene = Scene::new(loaded.world);
        let accel = Accel::build(&scene.prims, &AccelOptions::default());
        let mut opts = RenderOptions::for_scene(&scene);
        (opts.width, opts.height) = (24, 16);
        (Arc::new(scene), Arc::new(accel), opts)
    }

    #[test]
    fn threads_render_exactly_what_render_line_does() {
        let (scene, accel, opts) = small_scene();
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
        let pool = RenderPool::start(
            PoolScene {
                scene: scene.clone(),
                accel: accel.clone(),
                opts,
                mailbox: true,
                delay: Duration::ZERO,
            },
            3,
            tx,
        )
        .unwrap();
        for y in 0..opts.height {
            assert!(pool.submit(LineJob {
                line: y,
                grant: 100 + u64::from(y)
            }));
        }
        let mut got = Vec::new();
        for _ in 0..opts.height {
            got.push(rx.blocking_recv().unwrap());
        }
        got.sort_by_key(|r| r.job.line);
        let mut scratch = Scratch::new(scene.prims.len(), true);
        for (y, r) in got.iter().enumerate() {
            let want = render_line(&scene, &accel, y as u32, &opts, &mut scratch);
            assert_eq!(r.job.grant, 100 + y as u64);
            assert_eq!(r.pixels, want.pixels);
            assert_eq!(r.counters, want.counters);
        }
        drop(pool);
        assert!(
            rx.blocking_recv().is_none(),
            "threads stop when the pool is dropped"
        );
    }
}
