//! A job rendered to an error (`--target-error`), as its controller keeps it: the work is a
//! (line, pass) ([`crate::render::pass`]); between two passes of a line the controller holds
//! the line's pixel estimates (exactly, as the worker sent them), hands them out with the
//! line's next pass, and keeps what every pixel took so far for the job's error statistics
//! and samples map.

use super::messages::{self, MessageError};
use crate::film::Film;
use crate::render::adaptive::{self, Adaptive, PixelEstimate};
use crate::render::{pass, PixelSummary};
use crate::stats::ErrorStats;
use std::collections::HashMap;

/// The lines of a job rendered to an error, between their passes.
#[derive(Clone, Debug)]
pub struct LinePasses {
    a: Adaptive,
    width: u32,
    /// Lines waiting for their next pass: their estimates as the last pass left them.
    between: HashMap<u32, Vec<PixelEstimate>>,
    /// What each pixel took so far, row by row.
    summaries: Vec<PixelSummary>,
}

impl LinePasses {
    /// Nothing rendered yet of a `width` x `height` image to the error `a`.
    pub fn new(a: Adaptive, width: u32, height: u32) -> LinePasses {
        LinePasses {
            a,
            width,
            between: HashMap::new(),
            summaries: vec![PixelSummary::default(); width as usize * height as usize],
        }
    }

    /// What the job asks of every pixel.
    pub fn adaptive(&self) -> &Adaptive {
        &self.a
    }

    /// A line's estimates as a worker (or a checkpoint) sent them, checked.
    pub fn decode(&self, bytes: &[u8]) -> Result<Vec<PixelEstimate>, MessageError> {
        messages::estimates_from_bytes(bytes, self.width, &self.a)
    }

    /// A pass of `line` is in with `estimates`: the line's pixels now, and whether it needs
    /// another pass (its estimates are kept for it).
    pub fn pass_in(&mut self, line: u32, estimates: Vec<PixelEstimate>) -> (Vec<[f32; 3]>, bool) {
        let row = line as usize * self.width as usize;
        if let Some(s) = self.summaries.get_mut(row..row + estimates.len()) {
            for (s, e) in s.iter_mut().zip(&estimates) {
                *s = e.summary();
            }
        }
        let pixels = pass::line_pixels(&estimates);
        let more = !pass::line_done(&estimates, &self.a);
        if more {
            self.between.insert(line, estimates);
        } else {
            self.between.remove(&line);
        }
        (pixels, more)
    }

    /// The estimates that go with a grant of `line`'s pass `pass` (none for pass 0).
    pub fn grant_bytes(&self, line: u32, pass: u32) -> Vec<u8> {
        match self.between.get(&line) {
            Some(e) if pass > 0 => messages::estimates_to_bytes(e),
            _ => Vec::new(),
        }
    }

    /// What every pixel took so far, row by row.
    pub fn summaries(&self) -> &[PixelSummary] {
        &self.summaries
    }

    /// The heat map of the samples each pixel took so far (`--samples-map`).
    pub fn samples_map(&self) -> Film {
        self.samples_map_every(1)
    }

    /// [`LinePasses::samples_map`] of every `step`-th pixel of every `step`-th line (the web
    /// view's live picture of a large image, made without a film of its full size).
    pub fn samples_map_every(&self, step: u32) -> Film {
        let step = step.max(1) as usize;
        let width = self.width.max(1) as usize;
        let height = self.summaries.len() / width;
        let picked: Vec<PixelSummary> = (0..height)
            .step_by(step)
            .flat_map(|y| (0..width).step_by(step).map(move |x| y * width + x))
            .map(|i| self.summaries[i])
            .collect();
        let (w, h) = (width.div_ceil(step) as u32, height.div_ceil(step) as u32);
        adaptive::samples_map(&picked, &self.a, w, h)
    }

    /// The error statistics of the pixels so far.
    pub fn error_stats(&self) -> ErrorStats {
        adaptive::error_stats(&self.summaries, &self.a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// The web view's live samples map of a large image picks every step-th pixel of the
    /// whole map, without making it.
    #[test]
    fn the_samples_map_every_step_picks_the_whole_maps_pixels() {
        let a = Adaptive::new(0.01, Some(4), Some(64));
        let mut passes = LinePasses::new(a, 5, 3);
        for (i, s) in passes.summaries.iter_mut().enumerate() {
            s.samples = 4 << (i % 5);
        }
        let whole = passes.samples_map();
        let every = passes.samples_map_every(2);
        assert_eq!((every.width, every.height), (3, 2));
        for y in 0..2 {
            for x in 0..3 {
                assert_eq!(
                    every.pixels[(y * 3 + x) as usize],
                    whole.pixels[(2 * y * 5 + 2 * x) as usize]
                );
            }
        }
        assert_ne!(whole.pixels[0], whole.pixels[4], "the map shows the counts");
    }

    #[test]
    fn a_line_is_held_between_its_passes_and_let_go_when_done() {
        let a = Adaptive::new(0.01, Some(4), Some(64));
        let mut passes = LinePasses::new(a, 2, 3);
        let mut noisy = PixelEstimate::default();
        for k in 0..4 {
            noisy.add(DVec3::splat(f64::from(k % 2)));
        }
        let flat = adaptive::constant_pixel(DVec3::splat(0.5), &a);
        let bytes = messages::estimates_to_bytes(&[noisy, flat]);
        let got = passes.decode(&bytes).unwrap();
        let (pixels, more) = passes.pass_in(1, got);
        assert!(more, "the noisy pixel needs more");
        assert_eq!(pixels, vec![[0.5; 3], [0.5; 3]]);
        assert_eq!(passes.grant_bytes(1, 1), bytes, "handed out exactly");
        assert!(passes.grant_bytes(1, 0).is_empty() && passes.grant_bytes(0, 1).is_empty());
        assert_eq!(passes.summaries()[2].samples, 4);
        let (_, more) = passes.pass_in(1, vec![flat, flat]);
        assert!(!more);
        assert!(passes.grant_bytes(1, 2).is_empty(), "a done line is let go");
        assert_eq!(passes.error_stats().mean_samples, 4.0 * 2.0 / 6.0);
    }

    #[test]
    fn estimates_that_are_not_the_lines_are_refused() {
        let a = Adaptive::new(0.01, Some(4), Some(64));
        let passes = LinePasses::new(a, 2, 3);
        let one = messages::estimates_to_bytes(&[PixelEstimate::default()]);
        assert!(passes.decode(&one).is_err(), "one pixel of two");
        let mut many = PixelEstimate::default();
        for _ in 0..65 {
            many.add(DVec3::ONE);
        }
        let e = passes
            .decode(&messages::estimates_to_bytes(&[many, many]))
            .unwrap_err()
            .to_string();
        assert!(e.contains("65 samples") && e.contains("64"), "{e}");
    }
}
