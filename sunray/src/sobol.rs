//! Owen-scrambled Sobol samples of dimensions 0 to 3 (the crate's first 4-D set), bit for
//! bit what `sobol_burley::sample` gives, made faster. The crate computes the Sobol point by walking
//! the set bits of the (scrambled, 16-bit) index, up to 16 dependent steps, for each
//! dimension; that product is linear over GF(2) in the index's bits, so two lookups in
//! tables of 256 entries per dimension (the products of every byte, made once from the
//! crate's own `parts::sobol_rev`) give the same bits. A stream pairs its 2-D draws into
//! 4-D sets (Burley's padding by 4-D sets): dimensions 0 and 1, then 2 and 3, of one
//! shuffled index, so a pixel's point and its lens (or light, or gloss) point are stratified
//! together, not only each on its own. Everything else (the index's shuffle,
//! the per-dimension Owen scramble, the conversion to [0, 1)) is the crate's own `parts`,
//! called in the order its `sample` calls them. A pixel's 2-D draw was a fifth of a
//! depth-of-field render's time with `--sampler sobol`.

use sobol_burley::parts::{hash, owen_scramble_rev, sobol_rev, u32_to_f32_norm};
use std::sync::OnceLock;

/// Per dimension (0 to 3), the Sobol products of the index's top byte and its next byte.
type Tables = [[[u32; 256]; 2]; 4];

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let mut t = [[[0; 256]; 2]; 4];
        for (dim, dt) in t.iter_mut().enumerate() {
            for b in 0..256u32 {
                dt[0][b as usize] = sobol_rev(b << 24, dim as u32);
                dt[1][b as usize] = sobol_rev(b << 16, dim as u32);
            }
        }
        t
    })
}

/// Sample `index` (below 2^16) of the sequence scrambled by `seed`, its index shuffled once
/// for all four dimensions: a stream's pair of draws shares one (the shuffle is half the work
/// of a draw).
#[derive(Clone, Copy, Debug, Default)]
pub struct Sample4 {
    shuffled: u32,
    seed: u32,
}

impl Sample4 {
    /// Sample `index` of the sequence scrambled by `seed`.
    #[inline]
    pub fn new(index: u32, seed: u32) -> Sample4 {
        Sample4 {
            shuffled: shuffled_index(index, seed),
            seed,
        }
    }

    /// Dimension `dim` (0 to 3): `sobol_burley::sample(index, dim, seed)`.
    #[inline]
    pub fn dim(&self, dim: u32) -> f32 {
        debug_assert!(dim < 4, "only dimensions 0 to 3 have tables");
        dimension(tables(), self.shuffled, dim & 3, self.seed)
    }

    /// Dimensions `first` and `first + 1` (0 and 1, or 2 and 3): `sobol_burley::sample` of
    /// each.
    #[inline]
    pub fn dims_2d(&self, first: u32) -> (f32, f32) {
        debug_assert!(
            first == 0 || first == 2,
            "a 2-D draw is dimensions 0-1 or 2-3"
        );
        let t = tables();
        (
            dimension(t, self.shuffled, first & 2, self.seed),
            dimension(t, self.shuffled, (first & 2) | 1, self.seed),
        )
    }
}

/// The index with its bits reversed and shuffled for `seed` (the crate's first step).
#[inline]
fn shuffled_index(index: u32, seed: u32) -> u32 {
    owen_scramble_rev(index.reverse_bits(), hash(seed ^ 0x79c6_8e4a))
}

#[inline]
fn dimension(t: &Tables, shuffled: u32, dim: u32, seed: u32) -> f32 {
    let d = &t[dim as usize & 3];
    let sobol = d[0][(shuffled >> 24) as usize] ^ d[1][((shuffled >> 16) & 0xff) as usize];
    // The crate's scramble constants of dimensions 0 to 3 (dimension set 0).
    const SCRAMBLE: [u32; 4] = [0x912f_69ba, 0x174f_18ab, 0x691e_72ca, 0xb40c_c1b8];
    let scramble = seed.wrapping_mul(0x9c8f_2d3b) ^ SCRAMBLE[dim as usize & 3];
    u32_to_f32_norm(owen_scramble_rev(sobol, hash(scramble)).reverse_bits())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every index of the sequence, for many seeds: the crate's bits.
    #[test]
    fn samples_are_sobol_burley_bit_for_bit() {
        let mut h = 7u64;
        let mut seeds: Vec<u32> = vec![0, 1, u32::MAX];
        seeds.extend((0..40).map(|_| (crate::sampler::splitmix64(&mut h) >> 32) as u32));
        for &seed in &seeds {
            for index in (0..1u32 << 16).step_by(if seed < 2 { 1 } else { 97 }) {
                let sample = Sample4::new(index, seed);
                for first in [0, 2] {
                    let (u, v) = sample.dims_2d(first);
                    let want = (
                        sobol_burley::sample(index, first, seed),
                        sobol_burley::sample(index, first + 1, seed),
                    );
                    assert_eq!(
                        (u.to_bits(), v.to_bits()),
                        (want.0.to_bits(), want.1.to_bits())
                    );
                    assert_eq!(sample.dim(first).to_bits(), want.0.to_bits());
                    assert_eq!(sample.dim(first + 1).to_bits(), want.1.to_bits());
                }
            }
        }
    }
}
