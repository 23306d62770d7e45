//! All cores on one image: threads take the film's rows in order from a shared queue,
//! render into them with [`super::render_line_into`] and keep their own counters, summed at
//! the end.

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
    let bar = match progress {
        Progress::Bar => {
            let b = indicatif::ProgressBar::new(u64::from(opts.height));
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
    // Threads take the film's rows in order and render into them.
    let mut film = Film::new(opts.width, opts.height);
    let frame = Frame::new(scene, accel, opts);
    let pixels = if opts.adaptive.is_some() {
        film.pixels.len()
    } else {
        0
    };
    let mut summaries = vec![PixelSummary::default(); pixels];
    let width = opts.width.max(1) as usize;
    let mut summary_rows = summaries.chunks_mut(width);
    let rows = Mutex::new(
        film.pixels
            .chunks_mut(width)
            .zip(0..opts.height)
            .map(move |(row, y)| (row, y, summary_rows.next())),
    );
    let worker = || {
        let mut scratch = Scratch::new(scene.prims.len(), mailbox);
        let mut counters = Counters::default();
        loop {
            let next = rows.lock().unwrap_or_else(|e| e.into_inner()).next();
            let Some((row, y, summaries)) = next else {
                break;
            };
            counters +=
                render_line_into(scene, accel, y, opts, &mut scratch, &frame, row, summaries);
            if let Some(b) = &bar {
                b.inc(1);
            }
        }
        counters
    };
    let results: Vec<Counters> = if threads <= 1 {
        vec![worker()]
    } else {
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..threads).map(|_| s.spawn(worker)).collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                .collect()
        })
    };
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let mut total = Counters::default();
    for counters in results {
        total += counters;
    }
    (film, total, summaries)
}
