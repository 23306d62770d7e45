//! Where a stratified draw lands: sample s of a pixel's n takes cell perm(s) of an a x b grid
//! of the unit square (a b = n, as square as n allows), perm a pseudo-random permutation of
//! the samples keyed by the pixel and the draw.

use crate::geometry::Real;

/// `index` mapped by a pseudo-random permutation of `0..n` keyed by `hash` (Kensler,
/// "Correlated Multi-Jittered Sampling", 2013: a hash that is a bijection on the next power of
/// two, cycle-walked into `0..n`).
#[inline]
pub(super) fn permute(index: u32, n: u32, hash: u64) -> u32 {
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
pub(super) fn grid(n: u32) -> (u32, u32) {
    let mut a = (n as f64).sqrt() as u32;
    while a > 1 && !n.is_multiple_of(a) {
        a -= 1;
    }
    let a = a.max(1);
    (a, n / a)
}

/// The point (u, v) placed in cell `cell` of the a x b grid of `n` cells.
#[inline]
pub(super) fn stratum(cell: u32, n: u32, u: Real, v: Real) -> (Real, Real) {
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
