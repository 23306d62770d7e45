//! All cores on one image: threads take the film's rows in order from a shared queue
//! ([`each_row`]), render into them with [`super::render_line_into`] (or, to an error, take
//! the image's estimates through [`render_image_to_error`]) and keep their own
//! counters, summed at the end.

use super::adaptive::{self, Adaptive, PixelEstimate};
use super::neighbourhood;
use super::{render_line_into, Frame, PixelSummary, RenderOptions};
use crate::accel::{Accel, Scratch};
use crate::film::Film;
use crate::scene::Scene;
use crate::stats::Counters;
use std::sync::Mutex;

/// Whether to draw a progress bar (only sensible when stderr is a terminal).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// No bar (tests, pipes, `--quiet`).
    Hidden,
    /// An indicatif bar of lines done on stderr.
    Bar,
}

/// Renders the whole image with `threads` threads (at least 1). The image is byte-identical
/// for every thread count.
pub fn render_image(
    scene: &Scene,
    accel: &Accel,
    opts: &RenderOptions,
    threads: usize,
    mailbox: bool,
    progress: Progress,
) -> (Film, Counters) {
    let (film, counters, _) =
        render_image_summarized(scene, accel, opts, threads, mailbox, progress);
    (film, counters)
}

/// [`render_image`], with what each pixel took when it is rendered to an error (row-major as
/// the film; empty without a target error).
pub fn render_image_summarized(
    scene: &Scene,
    accel: &Accel,
    opts: &RenderOptions,
    threads: usize,
    mailbox: bool,
    progress: Progress,
) -> (Film, Counters, Vec<PixelSummary>) {
    // A render to an error goes over the lines twice: their first samples, then the rest.
    let goes = if opts.adaptive.is_some() { 2 } else { 1 };
    let bar = match progress {
        Progress::Bar => {
            let b = indicatif::ProgressBar::new(u64::from(opts.height) * goes);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{bar:40} {pos}/{len} lines  {per_sec}  eta {eta}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            Some(b)
        }
        Progress::Hidden => None,
    };
    let rows = Rows {
        threads,
        prims: scene.prims.len(),
        mailbox,
        bar: bar.as_ref(),
    };
    let mut film = Film::new(opts.width, opts.height);
    let frame = Frame::new(scene, accel, opts);
    let width = opts.width.max(1) as usize;
    let (counters, summaries) = match &opts.adaptive {
        Some(a) => {
            let pixels = film.pixels.chunks_mut(width);
            render_image_to_error(scene, (accel, &frame), opts, a, &rows, pixels)
        }
        None => {
            let counters = each_row(&rows, &mut film.pixels, width, |scratch, y, row| {
                render_line_into(scene, accel, y, opts, scratch, &frame, row, None)
            });
            (counters, Vec::new())
        }
    };
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    (film, counters, summaries)
}

/// The whole image rendered to the error `a` into `film_rows` (the film's rows, in order):
/// every line's first samples, then each line decided ([`neighbourhood::decide_among`], from
/// which pixels of the lines around it are open) and its raised pixels taken to their end,
/// each go on `rows`' threads; the counts of it all and what each pixel took (row-major).
/// A line's estimates are made, decided, written to its film row and dropped by the threads
/// that render it: none of it waits on one thread (a 512 x 512 image's 40 MB of estimates
/// made and read on one thread was a fifth of the wall time of 2 threads at 4 samples a
/// pixel).
pub fn render_image_to_error<'f>(
    scene: &Scene,
    (accel, frame): (&Accel, &Frame),
    opts: &RenderOptions,
    a: &Adaptive,
    rows: &Rows<'_>,
    film_rows: impl Iterator<Item = &'f mut [[f32; 3]]>,
) -> (Counters, Vec<PixelSummary>) {
    let width = opts.width as usize;
    let mut lines: Vec<ErrorLine<'f>> = film_rows
        .map(|pixels| ErrorLine {
            pixels,
            estimates: Vec::new(),
            open: Vec::new(),
            summaries: Vec::new(),
        })
        .collect();
    let mut counters = each_row(rows, &mut lines, 1, |scratch, y, line| {
        let line = &mut line[0];
        line.estimates = vec![PixelEstimate::default(); width];
        let c = super::pass::advance_line(
            scene,
            (accel, frame),
            y,
            opts,
            a,
            scratch,
            &mut line.estimates,
            adaptive::pass_cap(a, 0),
        );
        line.open = line.estimates.iter().map(PixelEstimate::is_open).collect();
        c
    });
    let open: Vec<Vec<bool>> = lines
        .iter_mut()
        .map(|l| std::mem::take(&mut l.open))
        .collect();
    counters += each_row(rows, &mut lines, 1, |scratch, y, line| {
        let line = &mut line[0];
        let mut estimates = std::mem::take(&mut line.estimates);
        neighbourhood::decide_among(&open, y as usize, &mut estimates, a);
        let c = super::pass::advance_line(
            scene,
            (accel, frame),
            y,
            opts,
            a,
            scratch,
            &mut estimates,
            u32::MAX,
        );
        for (px, e) in line.pixels.iter_mut().zip(&estimates) {
            let m = e.mean();
            *px = [m.x as f32, m.y as f32, m.z as f32];
        }
        line.summaries = estimates.iter().map(PixelEstimate::summary).collect();
        c
    });
    let summaries = lines.into_iter().flat_map(|l| l.summaries).collect();
    (counters, summaries)
}

/// One line of [`render_image_to_error`]: its film row, its pixels' estimates while it is
/// rendered, which of them were open after their first samples, and what each took.
struct ErrorLine<'f> {
    pixels: &'f mut [[f32; 3]],
    estimates: Vec<PixelEstimate>,
    open: Vec<bool>,
    summaries: Vec<PixelSummary>,
}

/// How an image's rows are shared out: the threads (at least 1), the scratch each needs (a
/// scene of `prims` primitives, the mailbox on or off) and the progress bar to advance.
pub struct Rows<'a> {
    /// Threads to run.
    pub threads: usize,
    /// Primitives in the scene (for each thread's scratch).
    pub prims: usize,
    /// Whether the mailbox is on.
    pub mailbox: bool,
    /// The bar advanced by each row done.
    pub bar: Option<&'a indicatif::ProgressBar>,
}

/// `f(scratch, y, row)` on every `width`-long row of `items`, threads taking the rows in
/// order from a shared queue, each with its own scratch; their counters summed.
pub fn each_row<T: Send>(
    rows: &Rows<'_>,
    items: &mut [T],
    width: usize,
    f: impl Fn(&mut Scratch, u32, &mut [T]) -> Counters + Sync,
) -> Counters {
    let queue = Mutex::new(items.chunks_mut(width.max(1)).zip(0u32..));
    let worker = || {
        let mut scratch = Scratch::new(rows.prims, rows.mailbox);
        let mut counters = Counters::default();
        loop {
            let next = queue.lock().unwrap_or_else(|e| e.into_inner()).next();
            let Some((row, y)) = next else {
                break;
            };
            counters += f(&mut scratch, y, row);
            if let Some(b) = rows.bar {
                b.inc(1);
            }
        }
        counters
    };
    let results: Vec<Counters> = if rows.threads <= 1 {
        vec![worker()]
    } else {
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..rows.threads).map(|_| s.spawn(worker)).collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                .collect()
        })
    };
    let mut total = Counters::default();
    for counters in results {
        total += counters;
    }
    total
}
