//! A job rendered to an error (`--target-error`), as its controller keeps it: the work is a
//! (line, pass) ([`crate::render::pass`]); between two passes of a line the controller holds
//! the line's pixel estimates (exactly, as the worker sent them), hands them out with the
//! line's next pass, and keeps what every pixel took so far for the job's error statistics
//! and samples map. After its first samples (pass 0) a line waits until every line within
//! [`RADIUS`] of it has its own: then the controller decides its pixels
//! ([`neighbourhood::raised_columns`], from which pixels of those lines were open, kept here as
//! they came in) and the line goes on with pass 1 if a pixel was raised, or is finished.
//! A finished line's checkpoint record is settled ([`settled`]): its pixels and what each
//! took, not its estimates.

use super::messages::{self, proto, MessageError};
use super::settled::{self, SettledPixel};
use crate::film::Film;
use crate::render::adaptive::{self, Adaptive, PixelEstimate};
use crate::render::columns::Columns;
use crate::render::neighbourhood::{self, RADIUS};
use crate::render::{pass, PixelSummary};
use crate::stats::ErrorStats;
use std::collections::HashMap;

/// The most bytes of estimates the lines between their passes hold before their next passes
/// go ahead of the lines still on their first ([`LinePasses::next_passes_first`]): with every
/// first pass first, a 3840 x 2160 image held all its estimates at once, 1.2 GB, in the
/// controller and in its checkpoint (past REM's quota of 1 GiB a host).
pub const HELD_BYTES: usize = 64 << 20;

/// The lines of a job rendered to an error, between their passes.
#[derive(Clone, Debug)]
pub struct LinePasses {
    a: Adaptive,
    width: u32,
    height: u32,
    /// Lines waiting for their decision or their next pass: their estimates as the last
    /// pass (and the decision) left them.
    between: HashMap<u32, Vec<PixelEstimate>>,
    /// The pixels a line's pass takes, as its grants carried them: made once for the pass's
    /// grants (copies too) and the check of its answer (each pixel's next step is its
    /// estimated error: made for each, 15% of the submit process's time in a profile).
    handed: HashMap<u32, (u32, Columns)>,
    /// What each pixel took so far, row by row.
    summaries: Vec<PixelSummary>,
    /// Which pixels were open after their first samples, row by row.
    open: Vec<bool>,
    /// [`HELD_BYTES`] (less in tests).
    held_bytes: usize,
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
    /// When every pixel of the line is done: what its checkpoint record keeps of them
    /// ([`settled`]; empty otherwise).
    pub settled: Vec<u8>,
}

/// A line decided.
#[derive(Clone, Debug, PartialEq)]
pub struct Decided {
    /// The line.
    pub line: u32,
    /// Whether a pixel was raised and needs more: the line goes on with its next pass.
    pub more: bool,
    /// Its estimates after the decision, when it goes on (what its checkpoint record holds).
    pub estimates: Vec<u8>,
    /// When it is finished, its pixels (as bytes) and what each took ([`settled`]): what its
    /// checkpoint record holds.
    pub settled: Option<(Vec<u8>, Vec<u8>)>,
}

impl Decided {
    /// Its record in the checkpoint: the decision amends the line's pass `pass` (nothing was
    /// rendered, so no counters of its own).
    pub fn record(self, pass: u32) -> proto::FinishedLine {
        let (pixels, settled) = self.settled.unwrap_or_default();
        proto::FinishedLine {
            line: self.line,
            pixels,
            counters: None,
            pass,
            estimates: self.estimates,
            settled,
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
            handed: HashMap::new(),
            summaries: vec![PixelSummary::default(); width as usize * height as usize],
            open: vec![false; width as usize * height as usize],
            held_bytes: HELD_BYTES,
        }
    }

    /// The same, its next passes first past `held_bytes` of estimates between passes (tests).
    pub fn with_held_bytes(self, held_bytes: usize) -> LinePasses {
        LinePasses { held_bytes, ..self }
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
                settled: Vec::new(),
            };
        }
        let row = line as usize * self.width as usize;
        let width = self.width as usize;
        self.handed.remove(&line);
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
        let mut settled = Vec::new();
        if waiting || more {
            self.between.insert(line, estimates);
        } else {
            self.between.remove(&line);
            settled = self.settled_bytes(line);
        }
        PassIn {
            pixels,
            more,
            waiting,
            decided: self.decide_near(line),
            settled,
        }
    }

    /// A settled line of a checkpoint is in ([`settled::from_bytes`] checked it): what its
    /// pixels took and which were open are noted, and the lines this decides returned.
    pub fn settled_in(&mut self, line: u32, pixels: &[SettledPixel]) -> Vec<Decided> {
        let width = self.width as usize;
        let row = line as usize * width;
        if line >= self.height || pixels.len() != width {
            return Vec::new();
        }
        for (x, p) in pixels.iter().enumerate() {
            self.summaries[row + x] = p.summary;
            self.open[row + x] = p.open;
        }
        self.between.remove(&line);
        self.handed.remove(&line);
        self.decide_near(line)
    }

    /// What a settled line's record keeps of `line`'s pixels: what each took and whether it
    /// was open, as noted when its passes came in (not computed from its estimates again).
    fn settled_bytes(&self, line: u32) -> Vec<u8> {
        let width = self.width as usize;
        let row = line as usize * width..(line as usize + 1) * width;
        let (took, open) = (&self.summaries[row.clone()], &self.open[row]);
        settled::to_bytes(
            took.iter()
                .zip(open)
                .map(|(&summary, &open)| SettledPixel { summary, open }),
        )
    }

    /// The lines within [`RADIUS`] of `line` decided now.
    fn decide_near(&mut self, line: u32) -> Vec<Decided> {
        let r = RADIUS;
        let near = line.saturating_sub(r)..=(line + r).min(self.height - 1);
        near.filter_map(|c| self.decide(c)).collect()
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
        self.handed.remove(&line);
        let open = &self.open;
        let rows = near.map(|y| &open[y as usize * width..(y as usize + 1) * width]);
        neighbourhood::decide_line(est, rows, &a);
        let more = !pass::line_done(est, &a);
        if more {
            let estimates = messages::estimates_to_bytes(est);
            return Some(Decided {
                line,
                more,
                estimates,
                settled: None,
            });
        }
        let est = self.between.remove(&line)?;
        let pixels = messages::pixels_to_bytes(&pass::line_pixels(&est));
        Some(Decided {
            line,
            more,
            estimates: Vec::new(),
            settled: Some((pixels, self.settled_bytes(line))),
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

    /// Whether lines going on should be handed out before the lines still on their first
    /// pass: when the lines between passes hold more than [`HELD_BYTES`] of estimates (so a
    /// large image is finished band by band; a smaller one is refined pass by pass).
    pub fn next_passes_first(&self) -> bool {
        self.between.len() * self.width as usize * PixelEstimate::BYTES > self.held_bytes
    }

    /// Where `line` stands.
    pub fn stage(&self, line: u32) -> LineStage {
        match self.between.get(&line) {
            None => LineStage::Settled,
            Some(e) if e.iter().any(|e| e.awaits_decision(&self.a)) => LineStage::Waiting,
            Some(_) => LineStage::Pass,
        }
    }

    /// The estimates that go with a grant of `line`'s pass `pass`, with their bitmap: those
    /// of the pixels the pass takes samples for ([`Columns::taking`]; none for pass 0), or
    /// unless `sparse` the whole line's and no bitmap (a worker of an earlier build).
    pub fn grant_bytes(&mut self, line: u32, pass: u32, sparse: bool) -> (Vec<u8>, Vec<u8>) {
        let Some(e) = self.between.get(&line).filter(|_| pass > 0) else {
            return Default::default();
        };
        if !sparse {
            return (messages::estimates_to_bytes(e), Vec::new());
        }
        let columns = match self.handed.get(&line) {
            Some((p, c)) if *p == pass => c,
            _ => {
                let c = Columns::taking(e, &self.a, pass);
                &self.handed.entry(line).insert_entry((pass, c)).into_mut().1
            }
        };
        (
            messages::estimates_to_bytes(&columns.pick(e)),
            columns.to_bytes(),
        )
    }

    /// The pixels pass `pass` of `line` takes (as handed out with it, when it was).
    fn taking(&self, line: u32, pass: u32, held: &[PixelEstimate]) -> Columns {
        match self.handed.get(&line) {
            Some((p, c)) if *p == pass => c.clone(),
            _ => Columns::taking(held, &self.a, pass),
        }
    }

    /// Pass `pass` of `line` as a worker sent it, the estimates of the pixels its bitmap
    /// `columns` names: the line's estimates after the pass (its other pixels' as held
    /// here), checked: the bitmap must name the pixels the pass takes, and only those.
    pub fn decode_picked(
        &self,
        line: u32,
        pass: u32,
        columns: &[u8],
        bytes: &[u8],
    ) -> Result<Vec<PixelEstimate>, MessageError> {
        let width = self.width;
        let bad = |why: &str| MessageError::Estimates {
            width,
            why: why.to_string(),
        };
        let held = match self.between.get(&line) {
            Some(held) if pass > 0 => held,
            _ => return Err(bad("no pass of the line waits for them")),
        };
        let got = Columns::from_bytes(columns, width).map_err(|why| bad(&why))?;
        if got != self.taking(line, pass, held) {
            return Err(bad("its bitmap is not the pixels the pass takes"));
        }
        let picked = messages::picked_estimates_from_bytes(bytes, &got, width, &self.a)?;
        let mut after = held.clone();
        got.put(&mut after, &picked);
        Ok(after)
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
mod tests;
