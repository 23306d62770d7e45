//! What a render to an error reports: its pixels' error statistics (the stats JSON's
//! `error`) and the heat map of the samples each took (`--samples-map`).

use super::Adaptive;
use crate::film::Film;
use crate::render::PixelSummary;
use crate::stats::{ErrorStats, SamplesBucket};

/// What the pixels of a render to the error `a` reached and took (their `summaries`).
pub fn error_stats(summaries: &[PixelSummary], a: &Adaptive) -> ErrorStats {
    // Bucket k holds the pixels of 2^k to 2^(k+1) - 1 samples.
    let mut buckets = [0u64; 32];
    let (mut sq, mut max, mut samples, mut at_max) = (0.0, 0.0_f64, 0u64, 0u64);
    for p in summaries {
        let e = f64::from(p.error);
        sq += e * e;
        max = max.max(e);
        samples += u64::from(p.samples);
        at_max += u64::from(p.samples >= a.max_samples && e > a.target_error);
        buckets[31 - p.samples.max(1).leading_zeros() as usize] += 1;
    }
    let histogram = (0..32u32)
        .zip(buckets)
        .filter(|&(_, pixels)| pixels > 0)
        .map(|(k, pixels)| SamplesBucket {
            from: 1 << k,
            to: ((1u64 << (k + 1)) - 1).min(u64::from(u32::MAX)) as u32,
            pixels,
        })
        .collect();
    let n = summaries.len().max(1) as f64;
    ErrorStats {
        target: a.target_error,
        rms: (sq / n).sqrt(),
        max,
        at_max_samples: at_max,
        mean_samples: samples as f64 / n,
        histogram,
    }
}

/// A heat map of the samples each pixel took (`--samples-map`): black for `min_samples`
/// through blue, red and yellow to white for `max_samples`, on a log scale.
pub fn samples_map(summaries: &[PixelSummary], a: &Adaptive, width: u32, height: u32) -> Film {
    let (lo, hi) = (f64::from(a.min_samples).ln(), f64::from(a.max_samples).ln());
    let ramp = [
        [0.0, 0.0, 0.0],
        [0.1, 0.1, 0.8],
        [0.9, 0.1, 0.1],
        [1.0, 0.9, 0.1],
        [1.0, 1.0, 1.0],
    ];
    let mut film = Film::new(width, height);
    for (px, s) in film.pixels.iter_mut().zip(summaries) {
        let t = if hi > lo {
            ((f64::from(s.samples).ln() - lo) / (hi - lo)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let f = t * (ramp.len() - 1) as f64;
        let k = (f as usize).min(ramp.len() - 2);
        let w = (f - k as f64) as f32;
        for c in 0..3 {
            px[c] = ramp[k][c] * (1.0 - w) + ramp[k + 1][c] * w;
        }
    }
    film
}
