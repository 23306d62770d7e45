//! An image rendered to an error on all cores, its lines in a sliding window: threads take
//! each line's first samples in order, and finish a line (decide its pixels from which
//! pixels of the lines within [`RADIUS`] of it were open, take its raised pixels to their
//! end, write its film row and what each pixel took) as soon as those lines have their first
//! samples, finishing before starting, so only the lines between hold estimates. The steps
//! are the ones the farm's passes take ([`super::pass`]), so the image is the same bytes.
//!
//! Why a window: the estimates of a whole 512 x 512 image are 40 MB (149 bytes a pixel; a
//! 3840 x 2160 image's 1.2 GB), made in one go and read again in a second, and their pages
//! were a sixth of what rendering to an error added to the first samples themselves; the
//! window's lines are a few hundred kilobytes, made again from memory the last ones freed.

use super::adaptive::{self, Adaptive, PixelEstimate};
use super::neighbourhood::{decide_line, RADIUS};
use super::{Frame, PixelSummary, RenderOptions, Rows};
use crate::accel::{Accel, Scratch};
use crate::scene::Scene;
use crate::stats::Counters;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};

/// Where a line is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Stage {
    /// Not begun.
    Waiting,
    /// A thread takes its first samples.
    First,
    /// It has its first samples; not yet finished.
    Sampled,
    /// A thread finishes it.
    Finishing,
    /// Done: its film row written, what each pixel took kept.
    Done,
}

/// What one thread does next.
enum Task<'f> {
    /// Line `y`'s first samples.
    First(usize),
    /// Line `y` finished from its estimates, the open pixels of the lines around it (itself
    /// among them), into its film row.
    Finish {
        y: usize,
        estimates: Vec<PixelEstimate>,
        near: Vec<Arc<[bool]>>,
        film: &'f mut [[f32; 3]],
    },
}

/// The lines' shared state, behind one lock.
struct Lines<'f> {
    stage: Vec<Stage>,
    /// The next line whose first samples no thread has taken.
    next_first: usize,
    /// The lowest line not finished or being finished.
    lowest_open: usize,
    done: usize,
    estimates: Vec<Option<Vec<PixelEstimate>>>,
    /// Which pixels of each line with its first samples were open.
    open: Vec<Option<Arc<[bool]>>>,
    film: Vec<Option<&'f mut [[f32; 3]]>>,
    summaries: Vec<Vec<PixelSummary>>,
    /// A thread panicked: the others stop waiting (its panic is resumed when it is joined).
    aborted: bool,
}

impl<'f> Lines<'f> {
    /// The lowest line that may be finished now: it and the lines within [`RADIUS`] of it
    /// have their first samples.
    fn ready(&self) -> Option<usize> {
        (self.lowest_open..self.next_first).find(|&y| {
            self.stage[y] == Stage::Sampled
                && self.around(y).all(|z| self.stage[z] >= Stage::Sampled)
        })
    }

    /// The lines within [`RADIUS`] of `y` (itself among them), clamped to the image.
    fn around(&self, y: usize) -> std::ops::Range<usize> {
        let r = RADIUS as usize;
        y.saturating_sub(r)..(y + r + 1).min(self.stage.len())
    }

    /// Line `y` has its first samples: `estimates`, whose `open` pixels were open.
    fn sampled(&mut self, y: usize, estimates: Vec<PixelEstimate>, open: Arc<[bool]>) {
        (self.estimates[y], self.open[y]) = (Some(estimates), Some(open));
        self.stage[y] = Stage::Sampled;
    }

    /// Line `y` is done: its pixels took `summaries`.
    fn finished(&mut self, y: usize, summaries: Vec<PixelSummary>) {
        self.summaries[y] = summaries;
        self.stage[y] = Stage::Done;
        self.done += 1;
    }

    /// The next task, or None when every line is done or taken and none is ready: finishing
    /// comes first, so the window stays narrow.
    fn take(&mut self) -> Option<Task<'f>> {
        if let Some(y) = self.ready() {
            self.stage[y] = Stage::Finishing;
            while self.lowest_open < self.stage.len()
                && self.stage[self.lowest_open] >= Stage::Finishing
            {
                self.lowest_open += 1;
            }
            let near = self
                .around(y)
                .filter_map(|z| self.open[z].clone())
                .collect();
            // A line's open pixels are dropped once every line that reads them is taken.
            for z in self.around(y) {
                if self.around(z).all(|k| self.stage[k] >= Stage::Finishing) {
                    self.open[z] = None;
                }
            }
            return Some(Task::Finish {
                y,
                estimates: self.estimates[y].take().unwrap_or_default(),
                near,
                film: self.film[y].take().unwrap_or_default(),
            });
        }
        if self.next_first < self.stage.len() {
            let y = self.next_first;
            self.next_first += 1;
            self.stage[y] = Stage::First;
            return Some(Task::First(y));
        }
        None
    }
}

/// What every line of one image shares: the scene, its accelerator and frame, the options
/// and the error asked.
struct Job<'a> {
    scene: &'a Scene,
    accel: &'a Accel,
    frame: &'a Frame,
    opts: &'a RenderOptions,
    a: &'a Adaptive,
}

impl Job<'_> {
    /// Line `y`'s pixels `est` taken on by whole steps up to `cap` samples.
    fn line(&self, s: &mut Scratch, y: usize, est: &mut [PixelEstimate], cap: u32) -> Counters {
        let (scene, opts, a) = (self.scene, self.opts, self.a);
        let at = (self.accel, self.frame);
        super::pass::advance_line(scene, at, y as u32, opts, a, s, est, (cap, None))
    }

    /// Line `y`'s first samples: the counts, the estimates and which pixels are open.
    fn first(&self, s: &mut Scratch, y: usize) -> (Counters, Vec<PixelEstimate>, Arc<[bool]>) {
        let mut estimates = vec![PixelEstimate::default(); self.opts.width as usize];
        let c = self.line(s, y, &mut estimates, adaptive::pass_cap(self.a, 0));
        let open = estimates.iter().map(PixelEstimate::is_open).collect();
        (c, estimates, open)
    }

    /// Line `y` finished: `estimates` decided from the open pixels of the lines around it
    /// (`near`), taken to their end and written to its `film` row; the counts and what each
    /// pixel took.
    fn finish(
        &self,
        s: &mut Scratch,
        y: usize,
        mut estimates: Vec<PixelEstimate>,
        near: &[Arc<[bool]>],
        film: &mut [[f32; 3]],
    ) -> (Counters, Vec<PixelSummary>) {
        decide_line(&mut estimates, near.iter().map(|o| &o[..]), self.a);
        let c = self.line(s, y, &mut estimates, u32::MAX);
        for (px, e) in film.iter_mut().zip(&estimates) {
            *px = e.pixel();
        }
        (c, estimates.iter().map(PixelEstimate::summary).collect())
    }
}

/// The whole image rendered to the error `a` into `film_rows` (the film's rows, in order),
/// on `rows`' threads: every line's first samples, its decision from the lines within
/// [`RADIUS`] of it, then its raised pixels to their end; the counts of it all and what each
/// pixel took (row-major).
pub fn render_image_to_error<'f>(
    scene: &Scene,
    (accel, frame): (&Accel, &Frame),
    opts: &RenderOptions,
    a: &Adaptive,
    rows: &Rows<'_>,
    film_rows: impl Iterator<Item = &'f mut [[f32; 3]]>,
) -> (Counters, Vec<PixelSummary>) {
    let job = Job {
        scene,
        accel,
        frame,
        opts,
        a,
    };
    let film: Vec<_> = film_rows.map(Some).collect();
    let h = film.len();
    let lines = Mutex::new(Lines {
        stage: vec![Stage::Waiting; h],
        next_first: 0,
        lowest_open: 0,
        done: 0,
        estimates: (0..h).map(|_| None).collect(),
        open: vec![None; h],
        film,
        summaries: vec![Vec::new(); h],
        aborted: false,
    });
    let changed = Condvar::new();
    let lock = || lines.lock().unwrap_or_else(|e| e.into_inner());
    let worker = || {
        let _wakes = WakeOnPanic(&lines, &changed);
        let mut scratch = Scratch::new(rows.prims, rows.mailbox);
        let mut counters = Counters::default();
        loop {
            let task = {
                let mut l: MutexGuard<'_, Lines<'f>> = lock();
                loop {
                    if let Some(t) = l.take() {
                        break t;
                    }
                    if l.done == h || l.aborted {
                        return counters;
                    }
                    l = changed.wait(l).unwrap_or_else(|e| e.into_inner());
                }
            };
            match task {
                Task::First(y) => {
                    let (c, estimates, open) = job.first(&mut scratch, y);
                    counters += c;
                    lock().sampled(y, estimates, open);
                }
                Task::Finish {
                    y,
                    estimates,
                    near,
                    film,
                } => {
                    let (c, summaries) = job.finish(&mut scratch, y, estimates, &near, film);
                    counters += c;
                    lock().finished(y, summaries);
                }
            }
            if let Some(b) = rows.bar {
                b.inc(1);
            }
            changed.notify_all();
        }
    };
    let total = rows.run(worker);
    let summaries = lines
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .summaries;
    (total, summaries.into_iter().flatten().collect())
}

/// Marks the lines aborted and wakes every waiting thread if its thread panics, so that no
/// thread waits for a line the panicking one will never finish.
struct WakeOnPanic<'a, 'f>(&'a Mutex<Lines<'f>>, &'a Condvar);

impl Drop for WakeOnPanic<'_, '_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.lock().unwrap_or_else(|e| e.into_inner()).aborted = true;
            self.1.notify_all();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::neighbourhood::decide_image;
    use crate::render::{render_image_summarized, Progress};

    /// The image the way it is defined: every line's first samples, every pixel decided
    /// from the whole image's open pixels, then every line taken to its end, one line at a
    /// time on one thread.
    fn in_two_goes(scene: &Scene, accel: &Accel, opts: &RenderOptions) -> Vec<PixelEstimate> {
        let a = opts.adaptive.unwrap();
        let frame = Frame::new(scene, accel, opts);
        let mut scratch = Scratch::new(scene.prims.len(), false);
        let w = opts.width as usize;
        let mut est = vec![PixelEstimate::default(); w * opts.height as usize];
        for cap in [adaptive::pass_cap(&a, 0), u32::MAX] {
            if cap == u32::MAX {
                decide_image(&mut est, w, &a);
            }
            for (y, row) in (0..).zip(est.chunks_mut(w)) {
                let f = (accel, &frame);
                super::super::pass::advance_line(
                    scene,
                    f,
                    y,
                    opts,
                    &a,
                    &mut scratch,
                    row,
                    (cap, None),
                );
            }
        }
        est
    }

    /// Any number of threads, on images as short as a line and as narrow as a pixel (fewer
    /// lines than a neighbourhood), gives the image, samples and counts of the definition.
    #[test]
    fn the_window_gives_the_image_in_two_goes_on_any_threads() {
        let (scene, accel) = crate::render::test_scene::shadowed_sphere();
        let a = Adaptive::new(0.01, Some(4), Some(128));
        for size in [[1, 1], [9, 1], [1, 4], [9, 2], [12, 3], [10, 9]] {
            let opts = RenderOptions {
                adaptive: Some(a),
                ..RenderOptions::asked(size, 1)
            };
            let want = in_two_goes(&scene, &accel, &opts);
            let raised = want.iter().filter(|e| e.count() > a.min_samples).count();
            let mut eye = None;
            for threads in 1..=3 {
                let (film, counters, summaries) = render_image_summarized(
                    &scene,
                    &accel,
                    &opts,
                    threads,
                    false,
                    Progress::Hidden,
                );
                for ((px, s), e) in film.pixels.iter().zip(&summaries).zip(&want) {
                    let m = e.mean();
                    assert_eq!(
                        *px,
                        [m.x as f32, m.y as f32, m.z as f32],
                        "{size:?} {threads}"
                    );
                    assert_eq!(*s, e.summary(), "{size:?} {threads}");
                }
                assert_eq!(*eye.get_or_insert(counters.eye), counters.eye);
            }
            if size == [10, 9] {
                assert!(
                    raised > 0,
                    "some pixel of {size:?} goes past its first samples"
                );
            }
        }
    }
}
