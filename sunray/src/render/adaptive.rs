//! Rendering to an error instead of a sample count (`--target-error E`): each pixel takes
//! samples from its own Owen-scrambled Sobol sequence ([`crate::sampler::SampleStream::sobol`])
//! until the estimated standard error of its mean, in linear radiance (1.0 = white), is at most
//! E in every channel, with at least `min_samples` (by default [`default_min_samples`]) and at
//! most `max_samples`.
//!
//! First every pixel takes `min_samples` (its first samples). Then one decision looks at
//! the pixel's neighbourhood (the pixels within [`RADIUS`](super::neighbourhood::RADIUS) of
//! it, across and down): when no pixel there is open (its first samples' own estimate
//! above E), the pixel stops;
//! else it is raised to [`raised_samples`] (4 x `min_samples`) and goes on by its own
//! samples alone. Every other decision depends only on the pixel's own samples (their
//! values, in the order taken), and the neighbourhood's only on the first samples of the
//! pixels in it, so the image is the same for any thread, process or host that renders a
//! pixel, and in any order ([`crate::render::pass`]: the farm decides a line once the lines
//! within [`RADIUS`](super::neighbourhood::RADIUS) of it have their first samples).
//!
//! The estimate: a pixel's samples are one Owen-scrambled Sobol sequence (sample i is its
//! point i, the same samples `--sampler sobol` takes, so the union of everything a pixel
//! takes is one net whatever its count), kept as the means of [`BLOCKS`] or fewer
//! consecutive blocks of [`block_len`] samples. A block of 2^k consecutive points of the
//! sequence is itself a scrambled net, an unbiased estimate of the pixel with the same
//! distribution as every other block, so the spread of the blocks' means measures how far
//! their mean is from the truth: the standard error is sqrt(sum (m_j - m)^2 / (K (K - 1)))
//! over the K block means m_j, per channel, the worst channel's. The blocks of one sequence
//! are not independent: they fill one another's gaps, so their means differ by more than
//! their mean errs, and the estimate overstates the error (by about K^((a - 1) / 2)
//! for an error falling as n^(-a/2): 1.5 to 1.7x on an edge's a = 1.5), which is honest. Four
//! independently scrambled replicates (the estimate before) measured the error exactly but
//! paid that same factor in the error itself, each replicate a net of a quarter of the
//! samples: with the blocks a pixel reaches the same RMSE with 1.4 to 1.6 times fewer
//! samples (docs/renderer.md). The sample variance over n (what independent samples need)
//! overstates a Sobol mean's error by a factor that grows with n (about n^(1/4) on an edge),
//! and rendered pixels to 0.08 to 0.55 E where E was asked.
//!
//! One floor: the estimate never credits the samples with converging faster than an edge
//! does under stratification (error n^-3/4, against independent samples' n^-1/2), so it is
//! at least sqrt(s^2 / n^1.5), s^2 the samples' own variance. Blocks of few samples can
//! agree by chance (an edge that each block's one or two points split alike) while the
//! samples themselves differ; without the floor such a pixel stops with its error left (on
//! a 1-D edge, 3.3 E at E = 0.01, measured in this module's tests before the floor).
//!
//! The schedule: `min_samples` first; then the neighbourhood's decision; a raised pixel
//! takes [`raised_samples`], then, while the estimate is above E, the count the
//! estimate asks for (n s^2 / E^2 for an estimate s after n samples), at least `min_samples`
//! more and at most twice as many as taken (the error is estimated again on the way), rounded
//! up to whole blocks ([`whole_blocks`]: 5 to 8 of them, so a step is rounded up by less
//! than a quarter), never above `max_samples`.
//!
//! [`report`] makes what a render to an error reports: its error statistics and samples map;
//! [`bytes`] writes a pixel's estimate exactly, for the farm's passes and checkpoints.

use super::packets::trace_sobol_samples;
use crate::accel::bvh::packet::PACKET;
use crate::camera::Camera;
use crate::sampler::SOBOL_SAMPLES;
use crate::shading::Tracer;
use glam::DVec3;

pub mod bytes;
pub mod report;
pub use report::{error_stats, samples_map};

/// The first samples a pixel takes with a target error E when `--min-samples` is not given:
/// 0.08 / E rounded up to a power of two, at least 4 (4 at E >= 0.02, 8 at 0.01, 16 at
/// 0.005; a raised pixel then takes at least 4 times as many). A thin feature (an edge across
/// one corner, a checker seen through a lens) missed by every first sample of a whole
/// neighbourhood stops its pixels with a wrong mean, and such a feature covers about 1/n of a
/// pixel after n stratified samples: so the first samples grow as E falls. (A pixel deciding
/// alone needed 16 at every E: with 4, on the built-in scene at 64x64 against a 4,096-sample
/// reference, the RMSE reached 4.9 E at E = 0.002; docs/renderer.md, "Rendering to an error".)
pub fn default_min_samples(target_error: f64) -> u32 {
    let n = (0.08 / target_error).ceil();
    // NaN (a target refused later) counts as 1; infinity (a tiny target) as the most.
    let n = if n >= 1.0 {
        n.min(f64::from(MAX_ADAPTIVE_SAMPLES)) as u32
    } else {
        1
    };
    n.next_power_of_two()
        .clamp(MIN_FIRST_SAMPLES, MAX_ADAPTIVE_SAMPLES)
}

/// The fewest first samples [`default_min_samples`] gives.
pub const MIN_FIRST_SAMPLES: u32 = 4;

/// The fewest samples a raised pixel takes: 4 x `min_samples` rounded up to whole blocks, at
/// most `max_samples` (16 with the default first samples at E >= 0.02, 32 at E = 0.01).
pub fn raised_samples(a: &Adaptive) -> u32 {
    whole_blocks(a.min_samples.saturating_mul(4)).min(a.max_samples)
}

/// The default most samples a pixel takes with a target error.
pub const DEFAULT_MAX_SAMPLES: u32 = 1024;
/// The most samples a pixel may take with a target error: the length of its Sobol sequence.
pub const MAX_ADAPTIVE_SAMPLES: u32 = SOBOL_SAMPLES;

/// How many consecutive blocks a pixel's samples are kept in: the estimate of its error
/// has 4 to 7 degrees of freedom per channel at every count the schedule stops at.
pub const BLOCKS: u32 = 8;
const _: () = assert!(
    BLOCKS.is_power_of_two(),
    "PixelEstimate::add pairs blocks at powers of two"
);

/// The length of each block a pixel of `n` samples keeps: the least power of two that puts
/// them in at most [`BLOCKS`] blocks (1 up to 8 samples, 2 up to 16, 4 up to 32, ...).
pub fn block_len(n: u32) -> u32 {
    n.div_ceil(BLOCKS).max(1).next_power_of_two()
}

/// The least count from `n` on at which every block is whole: 5 to 8 whole blocks (or 1 to
/// 8 single samples), so the schedule's steps are at most a quarter of the count.
pub fn whole_blocks(n: u32) -> u32 {
    let b = block_len(n);
    n.div_ceil(b).saturating_mul(b)
}

/// What rendering to an error asks of every pixel.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Adaptive {
    /// The standard error of a pixel's mean to reach, in linear radiance: finite, > 0.
    pub target_error: f64,
    /// The first samples every pixel takes (the fewest): 2 (a variance needs two) to
    /// `max_samples`.
    pub min_samples: u32,
    /// The most samples a pixel takes: up to [`MAX_ADAPTIVE_SAMPLES`].
    pub max_samples: u32,
}

/// Why an [`Adaptive`] cannot be used: one line naming the flag.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum AdaptiveError {
    /// The target is not a finite number above 0.
    #[error("--target-error must be a number above 0 (linear radiance, 1 = white), not {0}")]
    Target(f64),
    /// The fewest samples below 2 or above the most.
    #[error("--min-samples must be from 2 to --max-samples ({max}), not {min}")]
    Min {
        /// The fewest asked.
        min: u32,
        /// The most asked.
        max: u32,
    },
    /// The most samples above the Sobol sequence's length.
    #[error("--max-samples must be from 2 to {MAX_ADAPTIVE_SAMPLES}, not {0}")]
    Max(u32),
}

impl Adaptive {
    /// `target_error` with the default sample bounds ([`default_min_samples`], at most the
    /// most, and [`DEFAULT_MAX_SAMPLES`]), or the ones given.
    pub fn new(target_error: f64, min_samples: Option<u32>, max_samples: Option<u32>) -> Adaptive {
        let max_samples = max_samples.unwrap_or(DEFAULT_MAX_SAMPLES);
        let min_samples =
            min_samples.unwrap_or_else(|| default_min_samples(target_error).min(max_samples));
        Adaptive {
            target_error,
            min_samples,
            max_samples,
        }
    }

    /// Checks the bounds (a `Scene` message, a checkpoint or a user's flags).
    pub fn check(&self) -> Result<(), AdaptiveError> {
        let e = self.target_error;
        if !(e.is_finite() && e > 0.0) {
            return Err(AdaptiveError::Target(e));
        }
        if !(2..=MAX_ADAPTIVE_SAMPLES).contains(&self.max_samples) {
            return Err(AdaptiveError::Max(self.max_samples));
        }
        if !(2..=self.max_samples).contains(&self.min_samples) {
            return Err(AdaptiveError::Min {
                min: self.min_samples,
                max: self.max_samples,
            });
        }
        Ok(())
    }
}

/// A pixel's samples so far: their count, their mean and sum of squared deviations per
/// channel (Welford) and the mean of each of its blocks of [`block_len`] consecutive
/// samples (running means, added in the order taken: a constant's mean is the constant
/// exactly). A block's mean is kept in f32 (it only measures the spread, and an error target
/// is far above f32's rounding), and its stage (open after its first samples, decided,
/// raised) in a byte, so a pixel travels and is checkpointed in 149 bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelEstimate {
    n: u32,
    mean: DVec3,
    m2: DVec3,
    blocks: [Rgb32; BLOCKS as usize],
    stage: u8,
}

/// [`PixelEstimate::stage`]: its first samples' own estimate was above the target.
const OPEN: u8 = 1;
/// [`PixelEstimate::stage`]: its neighbourhood was looked at.
const DECIDED: u8 = 2;
/// [`PixelEstimate::stage`]: decided to go on (a pixel near it, or itself, was open).
const RAISED: u8 = 4;

/// A block's running mean, one f32 per channel.
type Rgb32 = [f32; 3];

fn widen(v: Rgb32) -> DVec3 {
    DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]))
}

fn narrow(v: DVec3) -> Rgb32 {
    [v.x as f32, v.y as f32, v.z as f32]
}

impl PixelEstimate {
    /// Adds one sample: the next one, which joins the last block (after the blocks pair
    /// up, when all [`BLOCKS`] are whole and the sample would start a ninth).
    #[inline]
    pub fn add(&mut self, c: DVec3) {
        let i = self.n;
        // The blocks pair up when the sample would start a ninth block: at i = 8 b, b the
        // blocks' length, a power of two (so block_len(i + 1) > block_len(i) exactly then).
        if i >= BLOCKS && i.is_power_of_two() {
            for j in 0..BLOCKS as usize / 2 {
                let pair = widen(self.blocks[2 * j]) + widen(self.blocks[2 * j + 1]);
                self.blocks[j] = narrow(pair * 0.5);
            }
            self.blocks[BLOCKS as usize / 2..].fill([0.0; 3]);
        }
        self.n += 1;
        let delta = c - self.mean;
        self.mean += delta / f64::from(self.n);
        self.m2 += delta * (c - self.mean);
        // block_len is a power of two: the block and the place in it by shift and mask.
        let shift = block_len(i + 1).trailing_zeros();
        let m = &mut self.blocks[(i >> shift) as usize];
        let w = widen(*m);
        *m = narrow(w + (c - w) / f64::from((i & ((1 << shift) - 1)) + 1));
    }

    /// How many samples were added.
    pub fn count(&self) -> u32 {
        self.n
    }

    /// Whether its first samples' own estimate was above the target (known once it has
    /// them: [`PixelEstimate::first_samples_in`]).
    pub fn is_open(&self) -> bool {
        self.stage & OPEN != 0
    }

    /// Whether it has its first samples and waits for its neighbourhood's decision
    /// ([`PixelEstimate::decide`]).
    pub fn awaits_decision(&self, a: &Adaptive) -> bool {
        self.n >= a.min_samples && self.stage & DECIDED == 0
    }

    /// Notes whether the pixel is open, when it has exactly its first samples (again and
    /// again the same answer: it depends on those samples alone).
    pub fn first_samples_in(&mut self, a: &Adaptive) {
        if self.n == a.min_samples && self.stage & DECIDED == 0 {
            let open = self.squared_error().sqrt() > a.target_error;
            self.stage = if open { OPEN } else { 0 };
        }
    }

    /// The neighbourhood's decision: `raise` when a pixel within
    /// [`RADIUS`](super::neighbourhood::RADIUS) of this one (itself included) is open. Made
    /// once; a later call changes nothing.
    pub fn decide(&mut self, raise: bool) {
        if self.stage & DECIDED == 0 {
            self.stage |= DECIDED | if raise { RAISED } else { 0 };
        }
    }

    /// Whether the stage byte is one this program writes (what came over the network may
    /// not be).
    pub fn stage_is_valid(&self) -> bool {
        self.stage & !(OPEN | DECIDED | RAISED) == 0
            && (self.stage & RAISED == 0 || self.stage & DECIDED != 0)
    }

    /// The mean of the samples (black with none).
    pub fn mean(&self) -> DVec3 {
        self.mean
    }

    /// The pixel's value on the film: its mean in `f32`.
    pub fn pixel(&self) -> [f32; 3] {
        narrow(self.mean)
    }

    /// The estimated squared standard error of the mean, the worst channel's: the spread of
    /// the blocks' means, each weighted by its share of the samples, over K (K - 1) for the
    /// K blocks that hold samples (0 with fewer than two), and never below the samples' own
    /// variance over n^1.5 (see the module's text).
    fn squared_error(&self) -> f64 {
        let b = block_len(self.n);
        let held = self.n.div_ceil(b);
        if held < 2 {
            return 0.0;
        }
        let n = f64::from(self.n);
        // Each block's share of the samples: every block's but the last is b / n.
        let (whole, last) = (f64::from(b) / n, f64::from(self.n - (held - 1) * b) / n);
        let weight = |j: u32| if j + 1 < held { whole } else { last };
        let first = widen(self.blocks[0]);
        // Their weighted mean, as an offset from the first (0 exactly when all agree).
        let mean = (0..held).fold(first, |m, j| {
            m + (widen(self.blocks[j as usize]) - first) * weight(j)
        });
        let mut sum = DVec3::ZERO;
        for j in 0..held {
            let d = (widen(self.blocks[j as usize]) - mean) * weight(j);
            sum += d * d;
        }
        let k = f64::from(held);
        let spread = sum * (k / (k - 1.0));
        // The floor: s^2 / n^1.5 per channel, s^2 the samples' own variance.
        let floor = self.m2 / ((n - 1.0) * n * n.sqrt());
        spread.max(floor).max_element().max(0.0)
    }

    /// The estimated standard error of the mean, the worst channel's (infinite with no
    /// samples).
    pub fn standard_error(&self) -> f64 {
        if self.n == 0 {
            return f64::INFINITY;
        }
        self.squared_error().sqrt()
    }

    /// True when the pixel is finished: it needs no more samples
    /// ([`PixelEstimate::next_count`] is `None`) and no decision (it has one, or it is at
    /// `max_samples`).
    pub fn is_done(&self, a: &Adaptive) -> bool {
        self.next_count(a).is_none() && (self.stage & DECIDED != 0 || self.n >= a.max_samples)
    }

    /// What the pixel took: its samples and estimated error.
    pub fn summary(&self) -> super::PixelSummary {
        super::PixelSummary {
            samples: self.n,
            error: self.standard_error() as f32,
        }
    }

    /// The count the pixel should reach next, or `None` when it takes none now: at the
    /// target, at `max_samples`, stopped by its neighbourhood or waiting for its decision
    /// after its first samples.
    pub fn next_count(&self, a: &Adaptive) -> Option<u32> {
        let n = self.n;
        if n >= a.max_samples {
            return None;
        }
        if n < a.min_samples {
            return Some(a.min_samples);
        }
        if self.stage & RAISED == 0 {
            return None;
        }
        let raised = raised_samples(a);
        if n < raised {
            return Some(raised);
        }
        let se2 = self.squared_error();
        if se2.sqrt() <= a.target_error {
            return None;
        }
        let e2 = a.target_error * a.target_error;
        let asked = (f64::from(n) * se2 / e2).ceil();
        let asked = if asked.is_finite() {
            asked.min(f64::from(u32::MAX)) as u32
        } else {
            u32::MAX
        };
        let next = asked
            .min(n.saturating_mul(2))
            .max(n.saturating_add(a.min_samples));
        // Whole blocks, so each holds as many samples as the others.
        let next = whole_blocks(next);
        Some(next.min(a.max_samples))
    }
}

/// Pixel (x, y) rendered to the error `a` asks as a pixel alone (its neighbourhood itself):
/// its samples from its Sobol sequence scrambled by `seed` (the render's is 0), taken as
/// [`PixelEstimate::next_count`] says.
pub fn trace_pixel_to_error(
    tracer: &mut Tracer,
    camera: &Camera,
    (x, y): (u32, u32),
    seed: u32,
    a: &Adaptive,
) -> PixelEstimate {
    let mut est = PixelEstimate::default();
    advance_pixel(tracer, camera, (x, y), seed, a, &mut est, u32::MAX);
    est.decide(est.is_open());
    advance_pixel(tracer, camera, (x, y), seed, a, &mut est, u32::MAX);
    est
}

/// Pixel (x, y) taken on from `est` as [`trace_pixel_to_error`] takes it, step by step of
/// [`PixelEstimate::next_count`], stopping before a step that would pass `cap` samples;
/// returns whether the pixel is done. The steps are the same whether a pixel is taken in one
/// go or over several calls (the farm's passes), so its samples and estimate are too. A pixel
/// that reaches its first samples here stops for its neighbourhood's decision, whether it is
/// open noted.
pub fn advance_pixel(
    tracer: &mut Tracer,
    camera: &Camera,
    (x, y): (u32, u32),
    seed: u32,
    a: &Adaptive,
    est: &mut PixelEstimate,
    cap: u32,
) -> bool {
    while let Some(want) = est.next_count(a) {
        if want > cap {
            return false;
        }
        // The step's samples traced a packet at a time, added in order.
        while est.count() < want {
            let n = (want - est.count()).min(PACKET as u32) as usize;
            let colours = trace_sobol_samples(tracer, camera, (x, y), seed, est.count(), n);
            for c in &colours[..n] {
                est.add(*c);
            }
        }
        est.first_samples_in(a);
    }
    true
}

/// The most samples a pixel has after pass `pass` of a render to the error `a` in passes:
/// `min_samples` after pass 0 (the first samples; then the neighbourhoods decide), then
/// [`raised_samples`] after pass 1, and twice as many after each later one. A raised pixel's
/// first step is to [`raised_samples`], each later one at most to twice its samples rounded
/// up to whole blocks ([`PixelEstimate::next_count`]), and rounding up to whole blocks keeps
/// order and leaves a count of whole blocks and its doublings as they are, so every raised
/// pixel not done takes at least one step in each pass, whatever `min_samples` is, and the
/// last pass, whose cap reaches `max_samples`, finishes every pixel.
pub fn pass_cap(a: &Adaptive, pass: u32) -> u32 {
    if pass == 0 {
        return a.min_samples;
    }
    let second = u64::from(raised_samples(a));
    let cap = second << (pass - 1).min(32);
    cap.min(u64::from(u32::MAX)) as u32
}

/// How many passes a render to the error `a` takes at most: every pixel is done after the
/// first pass whose cap reaches `max_samples` (at most 16).
pub fn max_passes(a: &Adaptive) -> u32 {
    (0..=32)
        .find(|&p| pass_cap(a, p) >= a.max_samples)
        .unwrap_or(32)
        + 1
}

/// A constant pixel (the background outside the scene's footprint) at its first samples:
/// `min_samples` of `c`, no error (not open), added one by one as a traced pixel's are (so
/// the state is exactly the traced one's, its blocks' f32 means included).
pub fn constant_pixel(c: DVec3, a: &Adaptive) -> PixelEstimate {
    let mut est = PixelEstimate::default();
    for _ in 0..a.min_samples {
        est.add(c);
    }
    est.first_samples_in(a);
    est
}

#[cfg(test)]
mod tests;
