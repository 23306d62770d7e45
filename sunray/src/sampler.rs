//! Counter-based random numbers: every value is a hash of (pixel x, y, sample index, and a
//! per-path dimension counter), so a pixel's samples never depend on which thread, process or
//! host renders it, nor in what order.

use crate::geometry::Real;
use crate::sobol::Sample4;

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
        let pixel = mix64(mix64(u64::from(x) ^ 0x5EED) ^ u64::from(y));
        let key = mix64(pixel ^ u64::from(stream));
        let base = stream.wrapping_sub(index);
        SampleStream {
            key,
            next: 0,
            pixel_key: mix64(pixel ^ 0xA5A5_0000_0000 ^ u64::from(base)),
            index: index.min(count.saturating_sub(1)),
            count: count.max(1),
            sobol: false,
            pair: Sample4::default(),
        }
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

/// `index` mapped by a pseudo-random permutation of `0..n` keyed by `hash` (Kensler,
/// "Correlated Multi-Jittered Sampling", 2013: a hash that is a bijection on the next power of
/// two, cycle-walked into `0..n`).
#[inline]
fn permute(index: u32, n: u32, hash: u64) -> u32 {
    let p = (hash ^ (hash >> 32)) as u32;
    let mut w = n - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    let mut i = index;
    loop {
        i ^= p;
        i = i.wrapping_mul(0xe170_893d);
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i = i.wrapping_mul(0x0929_eb3f);
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | p >> 27);
        i = i.wrapping_mul(0x6935_fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dc_b303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e50_1cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860_a3df);
        i &= w;
        i ^= i >> 5;
        if i < n {
            break;
        }
    }
    if n.is_power_of_two() {
        // The remainder below, without a 64-bit division (a power-of-two count is the common
        // case: 4, 16, 64 samples).
        return i.wrapping_add(p) & (n - 1);
    }
    ((u64::from(i) + u64::from(p)) % u64::from(n)) as u32
}

/// The grid a x b (a b = n, a the largest divisor of n not above sqrt(n)).
#[inline]
fn grid(n: u32) -> (u32, u32) {
    if n.is_power_of_two() {
        let k = n.trailing_zeros();
        return (1 << (k / 2), 1 << (k - k / 2));
    }
    let mut a = (n as f64).sqrt() as u32;
    while a > 1 && !n.is_multiple_of(a) {
        a -= 1;
    }
    let a = a.max(1);
    (a, n / a)
}

/// The point (u, v) placed in cell `cell` of the a x b grid of `n` cells.
#[inline]
fn stratum(cell: u32, n: u32, u: Real, v: Real) -> (Real, Real) {
    if n.is_power_of_two() {
        // Shifts and exact reciprocals for the divisions below: x / 2^k is x * 2^-k to the
        // bit.
        let k = n.trailing_zeros();
        let (ka, kb) = (k / 2, k - k / 2);
        let (i, j) = (cell & ((1 << ka) - 1), cell >> ka);
        return (
            (i as Real + u) * power_of_two(-(ka as i32)),
            (j as Real + v) * power_of_two(-(kb as i32)),
        );
    }
    let (a, b) = grid(n);
    let (i, j) = (cell % a, cell / a);
    ((i as Real + u) / a as Real, (j as Real + v) / b as Real)
}

/// 2^e for e in -1022..=1023, made from its bits.
#[inline]
fn power_of_two(e: i32) -> Real {
    Real::from_bits(((1023 + e) as u64) << 52)
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
mod tests {
    use super::*;

    /// A Sobol stream's draws go in pairs, each pair one scramble of `sobol_burley`'s
    /// sequence: the first draw dimensions 0 and 1, the second 2 and 3, bit for bit (a 1-D
    /// draw the first of those): what every image rendered with `--sampler sobol` or a target
    /// error is made of.
    #[test]
    fn sobol_draws_are_dimensions_0_to_3_of_their_pairs_scramble() {
        for (x, y, seed, index) in [
            (0, 0, 0, 0),
            (3, 9, 0, 1),
            (511, 7, 2, 65_535),
            (40, 2, 1, 12),
        ] {
            let mut s = SampleStream::sobol(x, y, seed, index);
            let scramble = |pair: u64| {
                let key = mix64(s.pixel_key ^ pair);
                (key ^ (key >> 32)) as u32
            };
            // Draws 1-2, 3-4, ...: 2-D and 2-D, then 2-D and 1-D, then 1-D and 2-D.
            let mut want = Vec::new();
            for (pair, shape) in [(1, [2, 2]), (2, [2, 1]), (3, [1, 2]), (4, [2, 2])] {
                let key = scramble(pair);
                for (second, width) in shape.into_iter().enumerate() {
                    let first_dim = 2 * second as u32;
                    for d in 0..width {
                        want.push(f64::from(sobol_burley::sample(index, first_dim + d, key)));
                    }
                }
            }
            let mut got = Vec::new();
            for width in [2, 2, 2, 1, 1, 2, 2, 2] {
                if width == 2 {
                    let (u, v) = s.next_2d();
                    got.extend([u, v]);
                } else {
                    got.push(s.next_real());
                }
            }
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&got),
                bits(&want),
                "pixel ({x}, {y}) seed {seed} sample {index}"
            );
        }
    }

    #[test]
    fn streams_depend_only_on_their_key() {
        let mut a = SampleStream::new(3, 4, 5);
        let mut b = SampleStream::new(3, 4, 5);
        let mut c = SampleStream::new(4, 3, 5);
        let va: Vec<Real> = (0..8).map(|_| a.next_real()).collect();
        let vb: Vec<Real> = (0..8).map(|_| b.next_real()).collect();
        let vc: Vec<Real> = (0..8).map(|_| c.next_real()).collect();
        assert_eq!(va, vb);
        assert_ne!(va, vc);
        assert!(va.iter().all(|v| (0.0..1.0).contains(v)));
    }

    #[test]
    fn uniform_mean_is_about_a_half() {
        let mut s = SampleStream::new(1, 2, 3);
        let mean: Real = (0..10_000).map(|_| s.next_real()).sum::<Real>() / 10_000.0;
        assert!((mean - 0.5).abs() < 0.02, "{mean}");
    }

    #[test]
    fn stratified_offsets_fall_in_their_cells() {
        let mut s = SampleStream::new(0, 0, 0);
        for k in 0..4 {
            let (u, v) = pixel_offset(4, k, &mut s);
            assert_eq!(((u * 2.0) as u32, (v * 2.0) as u32), (k % 2, k / 2));
        }
        assert_eq!(pixel_offset(1, 0, &mut s), (0.5, 0.5));
    }

    #[test]
    fn every_count_is_stratified_in_the_pixel() {
        for n in [2u32, 3, 8, 12, 32] {
            let mut cells = std::collections::HashSet::new();
            let (a, b) = grid(n);
            assert_eq!(a * b, n);
            for k in 0..n {
                let mut s = SampleStream::stratified(5, 6, k, k, n);
                let (u, v) = pixel_offset(n, k, &mut s);
                cells.insert(((u * a as Real) as u32, (v * b as Real) as u32));
            }
            assert_eq!(cells.len(), n as usize, "n = {n}");
        }
    }

    #[test]
    fn secondary_draws_of_a_pixel_take_distinct_cells() {
        for n in [4u32, 16, 12, 7] {
            let (a, b) = grid(n);
            let mut cells = std::collections::HashSet::new();
            for k in 0..n {
                let mut s = SampleStream::stratified(1, 2, k, k, n);
                let _ = pixel_offset(n, k, &mut s);
                let (u, v) = s.next_2d();
                assert!((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v));
                cells.insert(((u * a as Real) as u32, (v * b as Real) as u32));
            }
            assert_eq!(cells.len(), n as usize, "n = {n}");
        }
        // The mean of a stratified dimension over many pixels is still 1/2 (unbiased).
        let mut sum = 0.0;
        for x in 0..500 {
            for k in 0..4 {
                sum += SampleStream::stratified(x, 0, k, k, 4).next_2d().0;
            }
        }
        assert!((sum / 2000.0 - 0.5).abs() < 0.01, "{}", sum / 2000.0);
    }

    /// Every power-of-two prefix of a pixel's Sobol samples is stratified: its n points fall
    /// one in each of the n strata of a 1-D draw, and one in each elementary box (2^a x 2^b,
    /// a + b = log2 n) of a 2-D draw that opens a pair (dimensions 0 and 1); the pixel point
    /// and a later draw alike. (A pair's second draw, dimensions 2 and 3, is stratified with
    /// the first in four dimensions: [`a_pair_of_draws_is_stratified_in_four_dimensions`].)
    /// Another pixel or seed is another scramble.
    #[test]
    fn sobol_prefixes_are_stratified_in_every_draw() {
        for (x, y, seed) in [(0, 0, 0), (17, 3, 0), (17, 3, 9)] {
            for k in 0..=8u32 {
                let n = 1u32 << k;
                let draws: Vec<[(Real, Real); 2]> = (0..n)
                    .map(|i| {
                        let mut s = SampleStream::sobol(x, y, seed, i);
                        let p = pixel_offset(1, 0, &mut s);
                        let _ = s.next_real();
                        let later = s.next_2d();
                        [p, later]
                    })
                    .collect();
                for d in 0..2 {
                    for a in 0..=k {
                        let (cols, rows) = (1u32 << a, 1u32 << (k - a));
                        let boxes: std::collections::HashSet<(u32, u32)> = draws
                            .iter()
                            .map(|p| {
                                let (u, v) = p[d];
                                ((u * cols as Real) as u32, (v * rows as Real) as u32)
                            })
                            .collect();
                        assert_eq!(boxes.len(), n as usize, "n {n}, draw {d}, {cols}x{rows}");
                    }
                }
            }
            let one_d: std::collections::HashSet<u32> = (0..64)
                .map(|i| {
                    let mut s = SampleStream::sobol(x, y, seed, i);
                    let _ = s.next_2d();
                    (s.next_real() * 64.0) as u32
                })
                .collect();
            assert_eq!(one_d.len(), 64);
        }
        let first = |x, seed| SampleStream::sobol(x, 0, seed, 0).next_2d();
        assert_ne!(first(1, 0), first(2, 0));
        assert_ne!(first(1, 0), first(1, 1));
    }

    /// The two draws of a pair are stratified together in four dimensions: the first 2^k
    /// samples' (pixel point, lens point) put 2^3 in every elementary box of volume 2^(3-k)
    /// (every split of k - 3 halvings among the four axes; the first four Sobol dimensions are
    /// a (3, 4)-sequence or better). Draws scrambled each on its own are stratified only
    /// pair by pair and fail this.
    #[test]
    fn a_pair_of_draws_is_stratified_in_four_dimensions() {
        for (x, y, seed) in [(0, 0, 0), (17, 3, 0), (17, 3, 9), (250, 90, 4)] {
            for k in 4..=10u32 {
                let n = 1u32 << k;
                let points: Vec<[Real; 4]> = (0..n)
                    .map(|i| {
                        let mut s = SampleStream::sobol(x, y, seed, i);
                        let (a, b) = s.next_2d();
                        let (c, d) = s.next_2d();
                        [a, b, c, d]
                    })
                    .collect();
                let m = k - 3;
                for a in 0..=m {
                    for b in 0..=m - a {
                        for c in 0..=m - a - b {
                            let splits = [a, b, c, m - a - b - c];
                            let mut boxes = std::collections::HashMap::new();
                            for p in &points {
                                let cell: Vec<u32> = (0..4)
                                    .map(|i| (p[i] * Real::from(1u32 << splits[i])) as u32)
                                    .collect();
                                *boxes.entry(cell).or_insert(0) += 1;
                            }
                            assert!(
                                boxes.len() == 1 << m && boxes.values().all(|&c| c == 8),
                                "pixel ({x}, {y}) seed {seed}, {n} samples, boxes {splits:?}"
                            );
                        }
                    }
                }
            }
        }
    }

    /// The power-of-two paths of the grid, the cell and the permutation are the general
    /// formulas to the bit, so an image rendered with 4, 16 or 64 samples keeps its bytes.
    #[test]
    fn power_of_two_counts_take_the_general_formulas_bit_for_bit() {
        let mut h = 99u64;
        for k in 0..=16u32 {
            let n = 1u32 << k;
            let mut a = (n as f64).sqrt() as u32;
            while a > 1 && !n.is_multiple_of(a) {
                a -= 1;
            }
            let a = a.max(1);
            assert_eq!(grid(n), (a, n / a), "grid of {n}");
            let b = n / a;
            for _ in 0..200 {
                let cell = (splitmix64(&mut h) % u64::from(n)) as u32;
                let (u, v) = (unit_f64(&mut h), unit_f64(&mut h));
                let (i, j) = (cell % a, cell / a);
                let want = ((i as Real + u) / a as Real, (j as Real + v) / b as Real);
                let got = stratum(cell, n, u, v);
                assert_eq!(
                    (got.0.to_bits(), got.1.to_bits()),
                    (want.0.to_bits(), want.1.to_bits())
                );
                let (p, i) = ((h >> 7) as u32, cell);
                assert_eq!(
                    i.wrapping_add(p) & (n - 1),
                    ((u64::from(i) + u64::from(p)) % u64::from(n)) as u32
                );
            }
        }
    }

    #[test]
    fn disc_samples_stay_in_the_disc() {
        let mut s = SampleStream::new(9, 9, 9);
        for _ in 0..1000 {
            let (u, v) = s.next_2d();
            let (x, y) = sample_disc(u, v);
            assert!(x * x + y * y <= 1.0 + 1e-12);
        }
    }
}
