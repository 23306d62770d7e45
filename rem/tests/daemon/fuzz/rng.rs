//! SplitMix64: the generator that picks every part of an input, seeded per input.

/// SplitMix64: tiny, fast, and good enough to pick fuzz inputs.
pub(super) struct Rng(u64);

impl Rng {
    /// The generator of input `index` (each input can be replayed alone).
    pub(super) fn for_input(seed: u64, index: usize) -> Rng {
        let mut r = Rng(seed ^ (index as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93));
        r.next();
        r
    }

    pub(super) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (`n > 0`).
    pub(super) fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// True with probability `1 / n`.
    pub(super) fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }

    pub(super) fn pick<T: Clone>(&mut self, items: &[T]) -> T {
        items[self.below(items.len())].clone()
    }

    pub(super) fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.next() as u8).collect()
    }

    pub(super) fn alnum(&mut self, n: usize) -> String {
        const A: &[u8] = b"abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789._-";
        (0..n).map(|_| A[self.below(A.len())] as char).collect()
    }

    /// A length: mostly short, sometimes large.
    pub(super) fn len(&mut self) -> usize {
        match self.below(16) {
            0 => 0,
            1..=10 => self.below(32),
            11..=13 => self.below(1024),
            14 => self.below(64 << 10),
            _ => self.pick(&[129, 4096, 65_537, 300_000]),
        }
    }
}
