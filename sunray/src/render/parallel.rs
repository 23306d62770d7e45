//! All cores on one image: threads pull scanline numbers from a shared atomic counter,
//! render them with [`super::render_line`] and keep their own counters, summed at the end.

use super::{render_line, Line, RenderOptions};
use crate::accel::{Accel, Scratch};
use crate::film::Film;
use crate::scene::Scene;
use crate::stats::Counters;
use std::sync::atomic::{AtomicU32, Ordering};

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
    let next = AtomicU32::new(0);
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
    let worker = || {
        let mut scratch = Scratch::new(scene.prims.len(), mailbox);
        let mut lines: Vec<Line> = Vec::new();
        let mut counters = Counters::default();
        loop {
            let y = next.fetch_add(1, Ordering::Relaxed);
            if y >= opts.height {
                break;
            }
            let mut line = render_line(scene, accel, y, opts, &mut scratch);
            counters += std::mem::take(&mut line.counters);
            lines.push(line);
            if let Some(b) = &bar {
                b.inc(1);
            }
        }
        (lines, counters)
    };
    let results: Vec<(Vec<Line>, Counters)> = if threads <= 1 {
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
    let mut film = Film::new(opts.width, opts.height);
    let mut total = Counters::default();
    for (lines, counters) in results {
        total += counters;
        for line in lines {
            film.set_line(line.y, &line.pixels);
        }
    }
    (film, total)
}
