//! The converged image a method's error is measured against: two halves from disjoint
//! stratified streams, which also say which pixels carry error and how much the reference
//! itself still errs there.

use super::REFERENCE_STREAMS;
use crate::accel::Accel;
use crate::bench::accuracy::render_with;
use crate::geometry::Vec3;
use crate::render::trace_pixel;
use crate::scene::Scene;

/// The converged image a method's error is measured against.
pub struct Reference {
    /// The mean of the two halves.
    pub image: Vec<Vec3>,
    /// Pixels whose halves differ: those that carry error.
    pub varying: Vec<bool>,
    /// The reference's own RMSE over the varying pixels (half the halves' RMSE there).
    pub own_rmse: f64,
    /// Half the difference of the halves: the reference's own error, pixel by pixel, as
    /// likely as not.
    half_diff: Vec<Vec3>,
}

impl Reference {
    /// Two halves of `samples` from disjoint stratified streams above every measured one.
    pub(super) fn render(scene: &Scene, accel: &Accel, threads: usize, samples: u32) -> Reference {
        let half = (samples / 2).max(1);
        let first = REFERENCE_STREAMS;
        let a = render_with(scene, accel, threads, &|tr, cam, xy| {
            trace_pixel(tr, cam, xy, first, half)
        });
        let b = render_with(scene, accel, threads, &|tr, cam, xy| {
            trace_pixel(tr, cam, xy, first + half, half)
        });
        Reference::of_halves(&a, &b)
    }

    /// The reference made of halves `a` and `b`.
    pub fn of_halves(a: &[Vec3], b: &[Vec3]) -> Reference {
        let image: Vec<Vec3> = a.iter().zip(b).map(|(a, b)| (*a + *b) / 2.0).collect();
        let varying: Vec<bool> = a.iter().zip(b).map(|(a, b)| a != b).collect();
        let own_rmse = masked_rmse(a, b, &varying) / 2.0;
        let half_diff = a.iter().zip(b).map(|(a, b)| (*a - *b) / 2.0).collect();
        Reference {
            image,
            varying,
            own_rmse,
            half_diff,
        }
    }

    /// `image`'s RMSE over the varying pixels, less the reference's own error there.
    pub fn varying_rmse(&self, image: &[Vec3]) -> f64 {
        self.rmse_over(image, &self.varying)
    }

    /// `image`'s RMSE over the pixels `mask` picks, less the reference's own error there.
    pub fn rmse_over(&self, image: &[Vec3], mask: &[bool]) -> f64 {
        let m = masked_rmse(image, &self.image, mask);
        let own = masked_rms(self.half_diff.iter().copied(), mask);
        (m * m - own * own).max(0.0).sqrt()
    }
}

/// RMSE of `a` against `b` over every channel of the pixels `mask` picks (0 if none).
fn masked_rmse(a: &[Vec3], b: &[Vec3], mask: &[bool]) -> f64 {
    masked_rms(a.iter().zip(b).map(|(a, b)| *a - *b), mask)
}

/// The root mean square of every channel of the `values` `mask` picks (0 if none).
fn masked_rms(values: impl Iterator<Item = Vec3>, mask: &[bool]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (v, _) in values.zip(mask).filter(|(_, &m)| m) {
        sum += v.length_squared();
        n += 3;
    }
    if n == 0 {
        0.0
    } else {
        (sum / n as f64).sqrt()
    }
}
