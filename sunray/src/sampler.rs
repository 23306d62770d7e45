//! Counter-based random numbers: every value is a hash of (pixel x, y, sample index, and a
//! per-path dimension counter), so a pixel's samples never depend on which thread, process or
//! host renders it, nor in what order.

use crate::geometry::Real;

/// SplitMix64 step (Steele, Lea and Flood 2014): advances `state` and returns a mixed value.
#[inline]
pub fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    mix64(*state)
}

/// The SplitMix64 finaliser: a bijective avalanche of 64 bits.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random stream of one camera sample: value `n` is `hash(x, y, sample, n)`.
#[derive(Clone, Debug)]
pub struct SampleStream {
    key: u64,
    next: u64,
}

impl SampleStream {
    pub fn new(x: u32, y: u32, sample: u32) -> SampleStream {
        let key = mix64(mix64(mix64(u64::from(x) ^ 0x5EED) ^ u64::from(y)) ^ u64::from(sample));
        SampleStream { key, next: 0 }
    }

    /// The next uniform number in [0, 1).
    #[inline]
    pub fn next_real(&mut self) -> Real {
        self.next += 1;
        let bits = mix64(self.key ^ mix64(self.next));
        (bits >> 11) as Real * (1.0 / (1u64 << 53) as Real)
    }

    /// Two uniform numbers.
    pub fn next_2d(&mut self) -> (Real, Real) {
        (self.next_real(), self.next_real())
    }
}

/// Offsets within a pixel for `n` samples, sample `s`: the centre for one sample; jittered
/// strata on a `m x m` grid when `n = m^2`; otherwise uniform jitter over the pixel.
pub fn pixel_offset(n: u32, s: u32, rng: &mut SampleStream) -> (Real, Real) {
    if n <= 1 {
        return (0.5, 0.5);
    }
    let (u, v) = rng.next_2d();
    let m = (n as f64).sqrt().round() as u32;
    if m * m == n {
        let (i, j) = (s % m, s / m);
        ((i as Real + u) / m as Real, (j as Real + v) / m as Real)
    } else {
        (u, v)
    }
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
    fn disc_samples_stay_in_the_disc() {
        let mut s = SampleStream::new(9, 9, 9);
        for _ in 0..1000 {
            let (u, v) = s.next_2d();
            let (x, y) = sample_disc(u, v);
            assert!(x * x + y * y <= 1.0 + 1e-12);
        }
    }
}
