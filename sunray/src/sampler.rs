//! Counter-based random numbers: every value is a hash of (pixel x, y, sample index, and a
//! per-path dimension counter), so a pixel's samples never depend on which thread, process or
//! host renders it, nor in what order. `jitter` places a stratified draw in its cell;
//! [`crate::sobol`] makes a Sobol stream's numbers.

use crate::geometry::Real;
use crate::sobol::Sample4;
use jitter::{permute, stratum};

mod jitter;

/// SplitMix64 step (Steele, Lea and Flood 2014): advances `state` and returns a mixed value.
#[inline]
pub fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    mix64(*state)
}

/// A number in `[0, 1)` from the next output of [`splitmix64`] (its top 53 bits): a seeded
/// stream of uniform numbers for tests and benchmarks.
pub fn unit_f64(state: &mut u64) -> f64 {
    (splitmix64(state) >> 11) as f64 / (1u64 << 53) as f64
}

/// The SplitMix64 finaliser: a bijective avalanche of 64 bits.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random stream of one camera sample: value `n` is `hash(x, y, sample, n)`.
///
/// A stream made by [`SampleStream::stratified`] also knows its sample's index among the
/// pixel's `count` samples: then each 2-D draw ([`SampleStream::next_2d`]) falls in its own
/// cell of an a x b grid (a b = count), the cell chosen by a per-pixel, per-dimension random
/// permutation of the sample indices. Every sample of a pixel lands in a different cell of
/// every 2-D dimension (light disc, gloss cone, lens), each point stays uniform on its own
/// (so the estimate is unbiased), and the error falls faster than with independent numbers.
///
/// A stream made by [`SampleStream::sobol`] draws from an Owen-scrambled Sobol sequence
/// (`sobol_burley`, Burley 2020) instead: sample `index` of the pixel's sequence. Draws go in
/// pairs, each pair a 4-D set of its own scramble (keyed by the pixel and the pair's number,
/// "padded" by 4-D sets as Burley recommends): a pair's first draw takes dimensions 0 and 1
/// (0 for a 1-D draw), its second 2 and 3 (2), so the point in the pixel and the lens point,
/// or a light point and a gloss direction, are stratified together in four dimensions, not
/// only each pair on its own. Any prefix of a pixel's samples is then stratified in every draw
/// (the first 2^k in each of 2^k strata of every 1-D draw), so a pixel may stop after any
/// count: what rendering to an error needs.
#[derive(Clone, Debug)]
pub struct SampleStream {
    key: u64,
    next: u64,
    /// Key of the pixel's permutations (shared by all its samples).
    pixel_key: u64,
    index: u32,
    count: u32,
    /// Draw from the pixel's Sobol sequence (sample `index`) rather than stratified jitter.
    sobol: bool,
    /// False until a stratified stream's first draw: `key` then holds the pixel (x, y) and
    /// `pixel_key` the stream and its base, hashed into the keys at that draw
    /// ([`SampleStream::make_keys`]), so a sample that draws nothing (one sample a pixel of a
    /// scene with nothing stochastic) hashes nothing.
    keyed: bool,
    /// The Sobol sample of the pair of draws under way, made by the pair's first draw.
    pair: Sample4,
}

/// Which numbers a fixed number of samples per pixel draws from (`--sampler`). Rendering to
/// an error always draws from Sobol sequences (a pixel may stop after any count).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Sampler {
    /// Stratified jitter ([`SampleStream::stratified`]): the default, and what every image
    /// rendered before the Sobol sampler was added was rendered with.
    #[default]
    Stratified,
    /// Owen-scrambled Sobol ([`SampleStream::sobol`]).
    Sobol,
}

impl Sampler {
    /// Every sampler, in the order `--sampler` lists them.
    pub const ALL: [Sampler; 2] = [Sampler::Stratified, Sampler::Sobol];

    /// The name on the command line, in settings messages and in checkpoints.
    pub fn name(&self) -> &'static str {
        match self {
            Sampler::Stratified => "stratified",
            Sampler::Sobol => "sobol",
        }
    }

    /// The sampler of a name given by [`Sampler::name`].
    pub fn from_name(name: &str) -> Option<Sampler> {
        Sampler::ALL.into_iter().find(|s| s.name() == name)
    }
}

/// The most samples a pixel's Sobol sequence has (`sobol_burley`'s 2^16).
pub const SOBOL_SAMPLES: u32 = 1 << 16;

impl SampleStream {
    /// An unstratified stream (independent uniform numbers).
    pub fn new(x: u32, y: u32, sample: u32) -> SampleStream {
        SampleStream::stratified(x, y, sample, 0, 1)
    }

    /// The stream of sample `index` of `count` of pixel (x, y), its numbers keyed by
    /// `stream` (the render uses `stream = index`; the accuracy benchmark's reference uses
    /// streams disjoint from the measured ones).
    pub fn stratified(x: u32, y: u32, stream: u32, index: u32, count: u32) -> SampleStream {
        let base = stream.wrapping_sub(index);
        SampleStream {
            key: u64::from(x) | u64::from(y) << 32,
            next: 0,
            pixel_key: u64::from(stream) | u64::from(base) << 32,
            index: index.min(count.saturating_sub(1)),
            count: count.max(1),
            sobol: false,
            keyed: false,
            pair: Sample4::default(),
        }
    }

    /// A stratified stream's keys, from the pixel, stream and base its fields hold until its
    /// first draw ([`SampleStream::stratified`]).
    #[cold]
    #[inline(never)]
    fn make_keys(&mut self) {
        let (x, y) = (self.key & 0xFFFF_FFFF, self.key >> 32);
        let (stream, base) = (self.pixel_key & 0xFFFF_FFFF, self.pixel_key >> 32);
        let pixel = mix64(mix64(x ^ 0x5EED) ^ y);
        self.key = mix64(pixel ^ stream);
        self.pixel_key = mix64(pixel ^ 0xA5A5_0000_0000 ^ base);
        self.keyed = true;
    }

    /// The stream of sample `index` (below [`SOBOL_SAMPLES`]) of pixel (x, y)'s Sobol
    /// sequence, scrambled by `seed` (the render uses 0; the accuracy benchmark's reference
    /// other seeds, for streams disjoint from the measured ones).
    pub fn sobol(x: u32, y: u32, seed: u32, index: u32) -> SampleStream {
        let pixel = mix64(mix64(u64::from(x) ^ 0x50B0_1000) ^ u64::from(y));
        SampleStream {
            // Unused: every draw comes from the Sobol sequence.
            key: 0,
            next: 0,
            pixel_key: mix64(pixel ^ (u64::from(seed) << 32)),
            index: index.min(SOBOL_SAMPLES - 1),
            count: SOBOL_SAMPLES,
            sobol: true,
            keyed: true,
            pair: Sample4::default(),
        }
    }

    /// Whether this stream draws from a Sobol sequence (its first 2-D draw is then the
    /// point in the pixel).
    pub fn is_sobol(&self) -> bool {
        self.sobol
    }

    /// The first Sobol dimension of the draw numbered `self.next` (counted from 1), after
    /// starting a new pair's sample if the draw opens one: 0 for the first draw of a pair, 2
    /// for the second, which uses the first one's sample.
    #[inline]
    fn sobol_draw(&mut self) -> u32 {
        if self.next & 1 == 1 {
            self.pair = Sample4::new(self.index, self.sobol_seed());
            0
        } else {
            2
        }
    }

    /// The Sobol scramble of the pair of draws the draw numbered `self.next` is in (keyed by
    /// the pixel): draws 1 and 2 are pair 1, 3 and 4 pair 2.
    #[inline]
    fn sobol_seed(&self) -> u32 {
        let seed = mix64(self.pixel_key ^ self.next.div_ceil(2));
        (seed ^ (seed >> 32)) as u32
    }

    /// The next uniform number in [0, 1).
    #[inline]
    pub fn next_real(&mut self) -> Real {
        self.next += 1;
        if self.sobol {
            let dim = self.sobol_draw();
            return Real::from(self.pair.dim(dim));
        }
        if !self.keyed {
            self.make_keys();
        }
        let bits = mix64(self.key ^ mix64(self.next));
        (bits >> 11) as Real * (1.0 / (1u64 << 53) as Real)
    }

    /// Two uniform numbers; stratified over the pixel's samples (see the type's docs).
    pub fn next_2d(&mut self) -> (Real, Real) {
        if self.sobol {
            self.next += 1;
            let first = self.sobol_draw();
            let (u, v) = self.pair.dims_2d(first);
            return (Real::from(u), Real::from(v));
        }
        let (u, v) = (self.next_real(), self.next_real());
        if self.count <= 1 {
            return (u, v);
        }
        let h = mix64(self.pixel_key ^ self.next);
        let cell = permute(self.index, self.count, h);
        stratum(cell, self.count, u, v)
    }
}

/// Offsets within a pixel for `n` samples, sample `s`: the centre for one sample; otherwise a
/// jittered point in cell `s` of an a x b grid of the pixel (a b = n, as square as n allows:
/// m x m for n = m^2, m x 2m for n = 2 m^2). A Sobol stream's first 2-D draw, whatever `n`.
pub fn pixel_offset(n: u32, s: u32, rng: &mut SampleStream) -> (Real, Real) {
    if rng.sobol {
        return rng.next_2d();
    }
    if n <= 1 {
        return (0.5, 0.5);
    }
    let (u, v) = (rng.next_real(), rng.next_real());
    let cell = if n.is_power_of_two() {
        s & (n - 1)
    } else {
        s % n
    };
    stratum(cell, n, u, v)
}

/// A uniform point on the unit disc (concentric mapping, Shirley and Chiu).
pub fn sample_disc(u: Real, v: Real) -> (Real, Real) {
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, std::f64::consts::FRAC_PI_4 * (b / a))
    } else {
        (
            b,
            std::f64::consts::FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (a / b),
        )
    };
    (r * phi.cos(), r * phi.sin())
}

#[cfg(test)]
mod tests;
