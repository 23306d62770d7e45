//! A worker's render threads: plain OS threads pulling granted lines from a local queue and
//! rendering them with [`crate::render::render_line_into`], so rendering never blocks the async
//! runtime that talks to REM. Results go back over a tokio channel.

use crate::accel::{Accel, Scratch};
use crate::render::adaptive::{Adaptive, PixelEstimate};
use crate::render::columns::Columns;
use crate::render::pass::render_granted_pass;
use crate::render::{render_line_into, Frame, RenderOptions};
use crate::scene::Scene;
use crate::stats::Counters;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// A line to render under a grant.
#[derive(Clone, Debug, PartialEq)]
pub struct LineJob {
    /// The scanline, 0 at the top.
    pub line: u32,
    /// With a target error: the pass to render, and the line's estimates as the previous
    /// pass left them (empty for pass 0).
    pub pass: u32,
    /// See `pass`.
    pub estimates: Vec<PixelEstimate>,
    /// With a later pass, when its grant named them: the pixels `estimates` holds (those the
    /// pass takes), left to right; else `estimates` holds the whole line's.
    pub columns: Option<Columns>,
    /// The grant number it was handed out under, quoted back in the Done message.
    pub grant: u64,
    /// A copy of a line outstanding elsewhere, handed out at the tail of the job.
    pub duplicate: bool,
    /// Which of the job's controllers granted it (the worker counts takeovers): a line
    /// granted by an earlier one is reported with grant 0.
    pub generation: u32,
}

/// A rendered line.
#[derive(Clone, Debug, PartialEq)]
pub struct Rendered {
    /// The line and grant it answers.
    pub job: LineJob,
    /// Linear RGB, one entry per pixel of the line, left to right (empty with a target
    /// error: the pixels are the estimates' means).
    pub pixels: Vec<[f32; 3]>,
    /// With a target error: the line's estimates after the job's pass (those of the job's
    /// `columns` alone when it has them).
    pub estimates: Vec<PixelEstimate>,
    /// The events counted while rendering it.
    pub counters: Counters,
    /// Wall time the thread spent on the line.
    pub line_s: f64,
    /// Wall time the thread took for this line besides waiting for it: since it finished the
    /// previous one, so it also holds the time the host gave to other threads in between
    /// (the line rate of a thread that shares its core).
    pub cycle_s: f64,
    /// Wall time the thread waited for this line with nothing queued (since its previous
    /// one, or its start).
    pub wait_s: f64,
    /// The thread's first line (its wait includes the start-up).
    pub first: bool,
    /// When the thread finished it.
    pub finished: Instant,
}

/// What the threads render.
pub struct PoolScene {
    /// The scene, shared by every thread.
    pub scene: Arc<Scene>,
    /// The accelerator built over the scene's primitives.
    pub accel: Arc<Accel>,
    /// Image size, samples and tracing options: the same for every line.
    pub opts: RenderOptions,
    /// Each thread keeps an octree mailbox (`--mailbox on`); it never changes the pixels.
    pub mailbox: bool,
    /// Extra time per line (a test and benchmark hook that makes a worker slow).
    pub delay: Duration,
}

/// The render threads. Dropping the pool lets them finish their current line and stop.
pub struct RenderPool {
    queue: Arc<Queue>,
    threads: usize,
    opts: RenderOptions,
}

/// The lines not yet started, shared by the worker's I/O thread and the render threads.
#[derive(Debug, Default)]
struct Queue {
    state: Mutex<QueueState>,
    /// Signalled when a line is queued or the pool closes.
    ready: Condvar,
    /// Lines the worker means to keep queued.
    target: AtomicUsize,
}

#[derive(Debug, Default)]
struct QueueState {
    jobs: VecDeque<LineJob>,
    closed: bool,
}

impl Queue {
    /// The next line and how long the thread waited for it: from the moment it found the
    /// queue empty (time spent getting the lock while lines were queued is not waiting for
    /// work). `None` when the pool is closed.
    fn next(&self) -> Option<(LineJob, f64)> {
        let mut state = self.state.lock().ok()?;
        let mut waited = 0.0;
        if state.jobs.is_empty() && !state.closed {
            let empty_at = Instant::now();
            while state.jobs.is_empty() && !state.closed {
                state = self.ready.wait(state).ok()?;
            }
            waited = empty_at.elapsed().as_secs_f64();
        }
        if state.closed {
            return None;
        }
        state.jobs.pop_front().map(|job| (job, waited))
    }

    /// Below half its target the queue is running low: the worker's I/O thread, which
    /// reports lines and queues new ones, must not be kept waiting for a core by the render
    /// threads (on a host with more runnable threads than cores it would otherwise wait for
    /// their time slices, 5 to 30 ms measured). Above it, the render threads keep their
    /// cores: yielding each time would also hand part of their share to other processes.
    fn running_low(&self) -> bool {
        let queued = self.state.lock().map_or(0, |s| s.jobs.len());
        2 * queued < self.target.load(Ordering::Relaxed)
    }

    fn close(&self) {
        if let Ok(mut state) = self.state.lock() {
            state.closed = true;
        }
        self.ready.notify_all();
    }
}

impl RenderPool {
    /// Starts `threads` (at least 1) threads sending results to `results`.
    pub fn start(
        what: PoolScene,
        threads: usize,
        results: tokio::sync::mpsc::UnboundedSender<Rendered>,
    ) -> std::io::Result<RenderPool> {
        let queue = Arc::new(Queue::default());
        let what = Arc::new(what);
        let threads = threads.max(1);
        let pool = RenderPool {
            queue: queue.clone(),
            threads,
            opts: what.opts,
        };
        for i in 0..threads {
            let (queue, what, results) = (queue.clone(), what.clone(), results.clone());
            std::thread::Builder::new()
                .name(format!("render-{i}"))
                .spawn(move || render_loop(&what, &queue, &results))?;
        }
        Ok(pool)
    }

    /// Queues a line; false when the threads are gone.
    pub fn submit(&self, job: LineJob) -> bool {
        let Ok(mut state) = self.queue.state.lock() else {
            return false;
        };
        if state.closed {
            return false;
        }
        state.jobs.push_back(job);
        drop(state);
        self.queue.ready.notify_one();
        true
    }

    /// Lines queued and not yet started.
    pub fn queued(&self) -> usize {
        self.queue.state.lock().map_or(0, |s| s.jobs.len())
    }

    /// Takes back the `n` lines queued last (not started), in queue order.
    pub fn take_back(&self, n: usize) -> Vec<LineJob> {
        let Ok(mut state) = self.queue.state.lock() else {
            return Vec::new();
        };
        let keep = state.jobs.len().saturating_sub(n);
        state.jobs.split_off(keep).into()
    }

    /// How many lines the worker means to keep queued (not yet started); below half of
    /// that, a render thread that has reported a line lets the I/O thread run first.
    pub fn set_queue_target(&self, lines: usize) {
        self.queue.target.store(lines, Ordering::Relaxed);
    }

    /// Render threads in the pool.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// What the threads render with: the image size, samples or target error.
    pub fn options(&self) -> &RenderOptions {
        &self.opts
    }
}

impl Drop for RenderPool {
    fn drop(&mut self) {
        self.queue.close();
    }
}

fn render_loop(
    what: &PoolScene,
    queue: &Queue,
    results: &tokio::sync::mpsc::UnboundedSender<Rendered>,
) {
    let mut scratch = Scratch::new(what.scene.prims.len(), what.mailbox);
    let mut first = true;
    let mut previous: Option<Instant> = None;
    let mut frame: Option<Frame> = None;
    while let Some((mut job, wait_s)) = queue.next() {
        let t = Instant::now();
        // The frame (the camera and the scene's footprint, up to 64 boxes projected) is made
        // once for every line the worker renders, not once a line.
        let frame = frame.get_or_insert_with(|| Frame::new(&what.scene, &what.accel, &what.opts));
        let line = match &what.opts.adaptive {
            Some(a) => render_pass(what, a, &mut job, &mut scratch, frame),
            None => {
                let mut pixels = vec![[0.0; 3]; what.opts.width as usize];
                let (scene, accel, opts) = (&what.scene, &what.accel, &what.opts);
                let y = job.line;
                let counters = render_line_into(
                    scene,
                    accel,
                    y,
                    opts,
                    &mut scratch,
                    frame,
                    &mut pixels,
                    None,
                );
                (pixels, Vec::new(), counters)
            }
        };
        if !what.delay.is_zero() {
            std::thread::sleep(what.delay);
        }
        let finished = Instant::now();
        let line_s = (finished - t).as_secs_f64();
        let cycle_s = previous.map_or(line_s, |p| (finished - p).as_secs_f64() - wait_s);
        let (pixels, estimates, counters) = line;
        let rendered = Rendered {
            job,
            pixels,
            estimates,
            counters,
            line_s,
            cycle_s: cycle_s.max(line_s),
            wait_s,
            first,
            finished,
        };
        first = false;
        previous = Some(finished);
        if results.send(rendered).is_err() {
            return;
        }
        // The send woke the worker's I/O thread.
        if queue.running_low() {
            std::thread::yield_now();
        }
    }
}

/// The job's pass of its line: its pixels (none), estimates after the pass and counts.
fn render_pass(
    what: &PoolScene,
    a: &Adaptive,
    job: &mut LineJob,
    scratch: &mut Scratch,
    frame: &Frame,
) -> (Vec<[f32; 3]>, Vec<PixelEstimate>, Counters) {
    let mut estimates = std::mem::take(&mut job.estimates);
    let counters = render_granted_pass(
        &what.scene,
        &what.accel,
        (job.line, job.pass),
        &what.opts,
        a,
        scratch,
        frame,
        (job.columns.as_ref(), &mut estimates),
    );
    (Vec::new(), estimates, counters)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelOptions;

    pub(crate) fn small_scene() -> (Arc<Scene>, Arc<Accel>, RenderOptions) {
        let table = yari::colour::ColourTable::default();
        let loaded = yari::load::load_str(
            "default.yari",
            crate::scene::load::DEFAULT_SCENE,
            yari::load::InputKind::Yari,
            &table,
        )
        .unwrap();
        let mut scene = Scene::new(loaded.world);
        let accel = Accel::build(&mut scene.prims, &AccelOptions::default());
        let mut opts = RenderOptions::for_scene(&scene);
        (opts.width, opts.height) = (24, 16);
        (Arc::new(scene), Arc::new(accel), opts)
    }

    #[test]
    fn the_queue_runs_low_below_half_its_target() {
        let queue = Queue::default();
        assert!(!queue.running_low(), "no target");
        queue.target.store(8, Ordering::Relaxed);
        let job = LineJob {
            line: 0,
            pass: 0,
            estimates: Vec::new(),
            columns: None,
            grant: 1,
            duplicate: false,
            generation: 0,
        };
        queue.state.lock().unwrap().jobs.extend(vec![job; 4]);
        assert!(!queue.running_low());
        queue.state.lock().unwrap().jobs.pop_front();
        assert!(queue.running_low());
    }

    #[test]
    fn the_last_queued_lines_are_taken_back_in_order() {
        // A pool without threads: nothing takes the lines.
        let pool = RenderPool {
            queue: Arc::new(Queue::default()),
            threads: 1,
            opts: RenderOptions::asked([4, 4], 1),
        };
        for line in 0..5 {
            assert!(pool.submit(LineJob {
                line,
                pass: 0,
                estimates: Vec::new(),
                columns: None,
                grant: u64::from(line) + 1,
                duplicate: false,
                generation: 0,
            }));
        }
        let back: Vec<u32> = pool.take_back(2).iter().map(|j| j.line).collect();
        assert_eq!(back, vec![3, 4]);
        assert_eq!(pool.queued(), 3);
        assert_eq!(pool.take_back(9).len(), 3);
        assert_eq!(pool.queued(), 0);
    }

    #[test]
    fn a_thread_waits_only_while_the_queue_is_empty() {
        let queue = Queue::default();
        let job = LineJob {
            line: 3,
            pass: 0,
            estimates: Vec::new(),
            columns: None,
            grant: 7,
            duplicate: false,
            generation: 0,
        };
        queue.state.lock().unwrap().jobs.push_back(job.clone());
        assert_eq!(queue.next(), Some((job, 0.0)), "queued: no wait");
        queue.close();
        assert_eq!(queue.next(), None, "closed");
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
                pass: 0,
                estimates: Vec::new(),
                columns: None,
                grant: 100 + u64::from(y),
                duplicate: false,
                generation: 0,
            }));
        }
        let mut got = Vec::new();
        for _ in 0..opts.height {
            got.push(rx.blocking_recv().unwrap());
        }
        got.sort_by_key(|r| r.job.line);
        let mut scratch = Scratch::new(scene.prims.len(), true);
        for (y, r) in got.iter().enumerate() {
            let want = crate::render::render_line(&scene, &accel, y as u32, &opts, &mut scratch);
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
