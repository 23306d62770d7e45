//! Perlin's gradient noise (the "improved noise" of 2002) with our own fixed permutation table,
//! and turbulence (sum of octaves of |noise|).

use crate::geometry::{Real, Vec3};
use crate::sampler::splitmix64;
use std::sync::OnceLock;

/// The fixed permutation of 0..=255, doubled to avoid index wrapping. Made by a Fisher-Yates
/// shuffle driven by SplitMix64 from a fixed seed, so it is the same in every build.
fn permutation() -> &'static [u8; 512] {
    static TABLE: OnceLock<[u8; 512]> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut p: [u8; 256] = std::array::from_fn(|i| i as u8);
        let mut state = 0x5E_ED0F_5A1A_u64;
        for i in (1..256).rev() {
            let j = (splitmix64(&mut state) % (i as u64 + 1)) as usize;
            p.swap(i, j);
        }
        std::array::from_fn(|i| p[i & 255])
    })
}

#[inline]
fn fade(t: Real) -> Real {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

#[inline]
fn lerp(t: Real, a: Real, b: Real) -> Real {
    a + t * (b - a)
}

/// Dot product of the point offset with one of the 12 cube-edge gradients.
#[inline]
fn grad(hash: u8, x: Real, y: Real, z: Real) -> Real {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

/// Gradient noise in about [-1, 1], zero at integer lattice points.
pub fn noise(p: Vec3) -> Real {
    if !p.is_finite() {
        return 0.0;
    }
    let perm = permutation();
    let fl = p.floor();
    let xi = (fl.x as i64 & 255) as usize;
    let yi = (fl.y as i64 & 255) as usize;
    let zi = (fl.z as i64 & 255) as usize;
    let (x, y, z) = (p.x - fl.x, p.y - fl.y, p.z - fl.z);
    let (u, v, w) = (fade(x), fade(y), fade(z));
    let a = perm[xi] as usize + yi;
    let aa = perm[a] as usize + zi;
    let ab = perm[a + 1] as usize + zi;
    let b = perm[xi + 1] as usize + yi;
    let ba = perm[b] as usize + zi;
    let bb = perm[b + 1] as usize + zi;
    lerp(
        w,
        lerp(
            v,
            lerp(u, grad(perm[aa], x, y, z), grad(perm[ba], x - 1.0, y, z)),
            lerp(
                u,
                grad(perm[ab], x, y - 1.0, z),
                grad(perm[bb], x - 1.0, y - 1.0, z),
            ),
        ),
        lerp(
            v,
            lerp(
                u,
                grad(perm[aa + 1], x, y, z - 1.0),
                grad(perm[ba + 1], x - 1.0, y, z - 1.0),
            ),
            lerp(
                u,
                grad(perm[ab + 1], x, y - 1.0, z - 1.0),
                grad(perm[bb + 1], x - 1.0, y - 1.0, z - 1.0),
            ),
        ),
    )
}

/// Turbulence: sum over `octaves` of |noise(2^i p)| / 2^i, in about [0, 1].
pub fn turbulence(p: Vec3, octaves: u32) -> Real {
    let mut sum = 0.0;
    let mut f = 1.0;
    for _ in 0..octaves {
        sum += noise(p * f).abs() / f;
        f *= 2.0;
    }
    sum
}

/// The gradient of the noise by central differences.
pub fn noise_gradient(p: Vec3) -> Vec3 {
    let h = 1e-3;
    Vec3::new(
        noise(p + Vec3::X * h) - noise(p - Vec3::X * h),
        noise(p + Vec3::Y * h) - noise(p - Vec3::Y * h),
        noise(p + Vec3::Z * h) - noise(p - Vec3::Z * h),
    ) / (2.0 * h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_on_the_lattice_and_bounded() {
        assert_eq!(noise(Vec3::new(3.0, -7.0, 12.0)), 0.0);
        let mut state = 7u64;
        let mut spread = (Real::INFINITY, Real::NEG_INFINITY);
        for _ in 0..10_000 {
            let mut r = || (splitmix64(&mut state) >> 11) as Real / (1u64 << 53) as Real * 50.0;
            let v = noise(Vec3::new(r(), r(), r()));
            assert!(v.abs() <= 1.1, "{v}");
            spread = (spread.0.min(v), spread.1.max(v));
        }
        assert!(spread.0 < -0.4 && spread.1 > 0.4, "{spread:?}");
    }

    #[test]
    fn noise_is_continuous() {
        let p = Vec3::new(1.3, 2.7, -0.4);
        assert!((noise(p) - noise(p + Vec3::splat(1e-7))).abs() < 1e-5);
    }

    #[test]
    fn gradient_matches_a_difference() {
        let p = Vec3::new(0.3, 0.6, 0.2);
        let g = noise_gradient(p);
        let d = Vec3::new(1e-4, 0.0, 0.0);
        let fd = (noise(p + d) - noise(p)) / 1e-4;
        assert!((g.x - fd).abs() < 1e-2, "{} vs {fd}", g.x);
    }
}
