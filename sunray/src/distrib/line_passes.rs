//! A job rendered to an error (`--target-error`), as its controller keeps it: the work is a
//! (line, pass) ([`crate::render::pass`]); between two passes of a line the controller holds
//! the line's pixel estimates (exactly, as the worker sent them), hands them out with the
//! line's next pass, and keeps what every pixel took so far for the job's error statistics
//! and samples map. After its first samples (pass 0) a line waits until every line within
//! [`RADIUS`] of it has its own: then the controller decides its pixels
//! ([`neighbourhood::raised_columns`], from which pixels of those lines were open, kept here as
//! they came in) and the line goes on with pass 1 if a pixel was raised, or is finished.

use super::messages::{self, proto, MessageError};
use crate::film::Film;
use crate::render::adaptive::{self, Adaptive, PixelEstimate};
use crate::render::neighbourhood::{self, RADIUS};
use crate::render::{pass, PixelSummary};
use crate::stats::ErrorStats;
use std::collections::HashMap;

/// The lines of a job rendered to an error, between their passes.
#[derive(Clone, Debug)]
pub struct LinePasses {
    a: Adaptive,
    width: u32,
    height: u32,
    /// Lines waiting for their decision or their next pass: their estimates as the last
    /// pass (and the decision) left them.
    between: HashMap<u32, Vec<PixelEstimate>>,
    /// What each pixel took so far, row by row.
    summaries: Vec<PixelSummary>,
    /// Which pixels were open after their first samples, row by row.
    open: Vec<bool>,
}

/// What a pass of a line coming in changed.
#[derive(Clone, Debug, PartialEq)]
pub struct PassIn {
    /// The line's pixels now.
    pub pixels: Vec<[f32; 3]>,
    /// Whether the line needs another pass now (false while it waits for its decision).
    pub more: bool,
    /// Whether it came in waiting for its decision (made at once, in `decided`, when its
    /// neighbourhood was in already).
    pub waiting: bool,
    /// Lines decided now that their neighbourhoods have their first samples (this one among
    /// them, perhaps).
    pub decided: Vec<Decided>,
}

/// A line decided.
#[derive(Clone, Debug, PartialEq)]
pub struct Decided {
    /// The line.
    pub line: u32,
    /// Whether a pixel was raised and needs more: the line goes on with its next pass.
    pub more: bool,
    /// Its estimates after the decision (what its checkpoint record holds).
    pub estimates: Vec<u8>,
}

impl Decided {
    /// Its record in the checkpoint: the decision amends the line's pass `pass` (nothing was
    /// rendered, so no pixels and no counters of its own).
    pub fn record(self, pass: u32) -> proto::FinishedLine {
        proto::FinishedLine {
            line: self.line,
            pixels: Vec::new(),
            counters: None,
            pass,
            estimates: self.estimates,
        }
    }
}

/// Where a line stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineStage {
    /// Nothing of it in, or every pixel done.
    Settled,
    /// It has its first samples and waits for its neighbours' to be decided.
    Waiting,
    /// It needs another pass.
    Pass,
}

impl LinePasses {
    /// Nothing rendered yet of a `width` x `height` image to the error `a`.
    pub fn new(a: Adaptive, width: u32, height: u32) -> LinePasses {
        LinePasses {
            a,
            width,
            height,
            between: HashMap::new(),
            summaries: vec![PixelSummary::default(); width as usize * height as usize],
            open: vec![false; width as usize * height as usize],
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

    /// A pass of `line` is in with `estimates` (checked by [`LinePasses::decode`]): the
    /// line's pixels now, whether it needs another pass, and the lines this decides (its
    /// estimates are kept for its decision or its next pass).
    pub fn pass_in(&mut self, line: u32, estimates: Vec<PixelEstimate>) -> PassIn {
        if line >= self.height {
            return PassIn {
                pixels: pass::line_pixels(&estimates),
                more: false,
                waiting: false,
                decided: Vec::new(),
            };
        }
        let row = line as usize * self.width as usize;
        let width = self.width as usize;
        let was_in = self.has_first_samples(line);
        if let Some(s) = self.summaries.get_mut(row..row + estimates.len()) {
            for (s, e) in s.iter_mut().zip(&estimates) {
                *s = e.summary();
            }
        }
        let first = estimates.iter().all(|e| e.count() >= self.a.min_samples);
        if first && !was_in {
            for (o, e) in self.open[row..row + width].iter_mut().zip(&estimates) {
                *o = e.is_open();
            }
        }
        let pixels = pass::line_pixels(&estimates);
        // A line missing a pixel's first samples (which no worker of ours sends) is given
        // another pass, not held for a decision its first samples would be needed for.
        let waiting = first && estimates.iter().any(|e| e.awaits_decision(&self.a));
        let more = !waiting && !pass::line_done(&estimates, &self.a);
        if waiting || more {
            self.between.insert(line, estimates);
        } else {
            self.between.remove(&line);
        }
        let r = RADIUS;
        let near = line.saturating_sub(r)..=(line + r).min(self.height - 1);
        let decided = near.filter_map(|c| self.decide(c)).collect();
        PassIn {
            pixels,
            more,
            waiting,
            decided,
        }
    }

    /// Decides `line` if it waits and every line within [`RADIUS`] has its first
    /// samples.
    fn decide(&mut self, line: u32) -> Option<Decided> {
        let r = RADIUS;
        let near = line.saturating_sub(r)..=(line + r).min(self.height.saturating_sub(1));
        if !near.clone().all(|y| self.has_first_samples(y)) {
            return None;
        }
        let a = self.a;
        let est = self.between.get_mut(&line)?;
        if !est.iter().any(|e| e.awaits_decision(&a)) {
            return None;
        }
        let width = self.width as usize;
        let open = &self.open;
        let rows = near.map(|y| &open[y as usize * width..(y as usize + 1) * width]);
        neighbourhood::decide_line(est, rows, &a);
        let more = !pass::line_done(est, &a);
        let estimates = messages::estimates_to_bytes(est);
        if !more {
            self.between.remove(&line);
        }
        Some(Decided {
            line,
            more,
            estimates,
        })
    }

    /// Whether every pixel of `line` has its first samples (what each pixel took is kept in
    /// `summaries` from the first pass in on).
    fn has_first_samples(&self, line: u32) -> bool {
        let width = self.width as usize;
        let row = line as usize * width;
        self.summaries
            .get(row..row + width)
            .is_some_and(|s| s.iter().all(|p| p.samples >= self.a.min_samples))
    }

    /// Where `line` stands.
    pub fn stage(&self, line: u32) -> LineStage {
        match self.between.get(&line) {
            None => LineStage::Settled,
            Some(e) if e.iter().any(|e| e.awaits_decision(&self.a)) => LineStage::Waiting,
            Some(_) => LineStage::Pass,
        }
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

    /// Lines come in out of order; each is decided once every line within two of it has
    /// its first samples: those near the one open pixel go on, the rest are finished.
    #[test]
    fn a_line_waits_for_its_neighbourhood_then_goes_on_or_is_finished() {
        let a = Adaptive::new(0.01, Some(4), Some(64));
        let (w, h) = (8u32, 6u32);
        let mut passes = LinePasses::new(a, w, h);
        let flat = adaptive::constant_pixel(DVec3::splat(0.5), &a);
        let mut noisy = PixelEstimate::default();
        for k in 0..4 {
            noisy.add(DVec3::splat(f64::from(k % 2)));
        }
        noisy.first_samples_in(&a);
        assert!(noisy.is_open() && noisy.awaits_decision(&a) && !flat.is_open());
        let first = |y: u32| {
            let mut l = vec![flat; w as usize];
            if y == 0 {
                l[0] = noisy;
            }
            passes_decode(&a, w, &l)
        };
        let mut decided = Vec::new();
        for y in [5, 0, 3, 1] {
            let got = passes.pass_in(y, first(y));
            assert!(
                got.waiting && !got.more && got.decided.is_empty(),
                "line {y}"
            );
            assert_eq!(passes.stage(y), LineStage::Waiting);
        }
        let held = passes.grant_bytes(0, 1);
        assert_eq!(
            held,
            messages::estimates_to_bytes(&first(0)),
            "held exactly"
        );
        for y in [2, 4] {
            decided.extend(passes.pass_in(y, first(y)).decided);
        }
        let order: Vec<(u32, bool)> = decided.iter().map(|d| (d.line, d.more)).collect();
        assert_eq!(
            order,
            [
                (0, true),
                (1, true),
                (2, true),
                (3, false),
                (4, false),
                (5, false)
            ]
        );
        for d in &decided {
            let e = passes.decode(&d.estimates).unwrap();
            for (x, p) in e.iter().enumerate() {
                assert!(!p.awaits_decision(&a), "line {} decided", d.line);
                // Raised: within two columns and two lines of the open pixel (0, 0).
                let raised = d.line <= 2 && x <= 2;
                assert_eq!(p.is_done(&a), !raised, "line {} pixel {x}", d.line);
            }
            let stage = if d.more {
                LineStage::Pass
            } else {
                LineStage::Settled
            };
            assert_eq!(passes.stage(d.line), stage);
        }
        assert_eq!(
            passes.grant_bytes(0, 1),
            decided[0].estimates,
            "handed out decided"
        );
        assert!(
            passes.grant_bytes(3, 1).is_empty(),
            "a finished line is let go"
        );
        // Line 0's next pass: its raised pixels go on until they are done.
        let mut e = passes.decode(&passes.grant_bytes(0, 1)).unwrap();
        for pass in 1.. {
            for p in e.iter_mut() {
                while let Some(want) = p
                    .next_count(&a)
                    .filter(|&n| n <= adaptive::pass_cap(&a, pass))
                {
                    while p.count() < want {
                        p.add(DVec3::splat(0.5));
                    }
                }
            }
            let got = passes.pass_in(0, e.clone());
            assert!(!got.waiting && got.decided.is_empty());
            if !got.more {
                break;
            }
            assert!(pass < adaptive::max_passes(&a), "line 0 never finished");
        }
        assert_eq!(passes.stage(0), LineStage::Settled);
        assert_eq!(
            passes.summaries()[0].samples,
            64,
            "the noisy pixel to the most"
        );
        assert_eq!(
            passes.summaries()[1].samples,
            16,
            "a raised flat one to 4 x 4"
        );
        assert_eq!(passes.summaries()[3].samples, 4, "a pixel not raised");
    }

    /// Estimates as a worker would send them, read back as the controller reads them.
    fn passes_decode(a: &Adaptive, width: u32, e: &[PixelEstimate]) -> Vec<PixelEstimate> {
        messages::estimates_from_bytes(&messages::estimates_to_bytes(e), width, a).unwrap()
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
        // A stage byte this program does not write: unknown bits, or raised undecided.
        for stage in [8u8, 4] {
            let mut bytes = messages::estimates_to_bytes(&[PixelEstimate::default(); 2]);
            bytes[PixelEstimate::BYTES - 1] = stage;
            let e = passes.decode(&bytes).unwrap_err().to_string();
            assert!(e.contains("unknown stage"), "{stage}: {e}");
        }
    }
}
