//! All cores on one image: threads take the film's rows in order from a shared queue
//! ([`each_row`]), render into them with [`super::render_line_into`] (or, to an error, take
//! the image in a sliding window of lines, [`super::window`]) and keep their own
//! counters, summed at the end.

use super::{render_line_into, Frame, PixelSummary, RenderOptions, Rows};
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
            super::window::render_image_to_error(scene, (accel, &frame), opts, a, &rows, pixels)
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
    rows.run(worker)
}
