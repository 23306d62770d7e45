//! Eye rays traced together: sample `k` of up to [`PACKET`] pixels side by side
//! ([`trace_pixels`], a fixed count), or up to [`PACKET`] consecutive samples of one pixel
//! ([`trace_sobol_samples`], a render to an error's step), makes one packet of eye rays,
//! whose closest hits the accelerator finds in one walk ([`crate::accel::bvh::packet`]);
//! each hit is then shaded alone, in order. A pixel's colour is the one
//! [`super::trace_pixel`] (or [`super::trace_pixel_sobol`]) gives it, and a sample's the one
//! [`super::trace_sobol_sample`] gives: the same streams, the same rays, the same hits.

use super::eye_ray;
use crate::accel::bvh::packet::PACKET;
use crate::camera::Camera;
use crate::geometry::{RayPre, Real, Vec3};
use crate::sampler::{SampleStream, Sampler};
use crate::shading::Tracer;
use arrayvec::ArrayVec;
use std::ops::Range;

/// The mean colours of pixels `xs` (at most [`PACKET`] of them) of line `y`, `count`
/// samples each from `sampler`'s streams (stream `k` for sample `k`; Sobol seed 0), as the
/// render takes them; entries past `xs`'s length are zero.
pub(crate) fn trace_pixels(
    tracer: &mut Tracer,
    camera: &Camera,
    xs: Range<u32>,
    y: u32,
    count: u32,
    sampler: Sampler,
) -> [glam::DVec3; PACKET] {
    let mut sums = [glam::DVec3::ZERO; PACKET];
    for k in 0..count {
        let eyes = xs.clone().take(PACKET).map(|x| {
            // As trace_sample and trace_sobol_sample make a sample's stream.
            match sampler {
                Sampler::Stratified => (
                    (x, y),
                    SampleStream::stratified(x, y, k, k, count),
                    count,
                    k,
                ),
                Sampler::Sobol => ((x, y), SampleStream::sobol(x, y, 0, k), 1, 0),
            }
        });
        let (colours, traced) = trace_packet(tracer, camera, eyes);
        for (sum, c) in sums.iter_mut().zip(&colours[..traced]) {
            *sum += *c;
        }
    }
    if count == 1 {
        sums
    } else {
        sums.map(|s| s / count as Real)
    }
}

/// The colours of samples `first..first + n` (`n` at most [`PACKET`]) of pixel `(x, y)`'s
/// Sobol sequence scrambled by `seed`, each the one [`super::trace_sobol_sample`] gives it;
/// entries past `n` are zero. One pixel's samples are the most coherent packet there is: a
/// pinhole's rays leave from one point into one pixel.
pub(crate) fn trace_sobol_samples(
    tracer: &mut Tracer,
    camera: &Camera,
    (x, y): (u32, u32),
    seed: u32,
    first: u32,
    n: usize,
) -> [Vec3; PACKET] {
    let eyes = (first..)
        .take(n.min(PACKET))
        // As trace_sobol_sample makes the sample's stream.
        .map(|index| ((x, y), SampleStream::sobol(x, y, seed, index), 1, 0));
    trace_packet(tracer, camera, eyes).0
}

/// The colours of up to [`PACKET`] eye rays traced as one packet, each given as its pixel,
/// its stream and the `(count, index)` that place it in the pixel ([`eye_ray`]), and how many
/// there were; entries past that are zero.
fn trace_packet(
    tracer: &mut Tracer,
    camera: &Camera,
    eyes: impl Iterator<Item = ((u32, u32), SampleStream, u32, u32)>,
) -> ([Vec3; PACKET], usize) {
    let mut rngs = ArrayVec::<SampleStream, PACKET>::new();
    let mut rays = ArrayVec::<RayPre, PACKET>::new();
    for (pixel, mut rng, count, index) in eyes.take(PACKET) {
        let ray = eye_ray(tracer.scene, camera, pixel, count, index, &mut rng);
        rays.push(RayPre::new(ray));
        rngs.push(rng);
    }
    let mut colours = [Vec3::ZERO; PACKET];
    tracer.trace_eye_packet(&rays, &mut rngs, &mut colours);
    (colours, rays.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::{trace_pixel, trace_pixel_sobol, trace_sobol_sample, Frame, RenderOptions};
    use crate::stats::Counters;

    /// Glass, gloss, an area light and a lens; then the same without the glass: every pixel of a packet, at one and at several samples, from either sampler, is the
    /// colour the pixel gets alone, to the bit.
    #[test]
    fn packets_give_each_pixel_its_own_colour() {
        const GLASS: &str = "kdr = 0.1 ; kdt = 0.1 ; refract = 1.5 ;";
        let src = "background(color = 0.1,0.2,0.3); ambient(color = 0.2,0.2,0.2);
camera(position = 0,1,-6 ; at = 0,0,0 ; up = 0,1,0 ; angle = 40 ; aperture = 0.05 ; focus = 6);
light(position = -4,6,-5 ; color = 1,1,1 ; radius = 0.5);
light(position = 5,3,-2 ; color = 0.5,0.5,0.5);
begin
  begin attribute(color = 0.9,0.9,0.9 ; GLASS phong = 40);
    sphere(center = 0,0,0 ; radius = 1); end
  begin attribute(color = 1,0.4,0.2 ; kdr = 0.5 ; gloss = 6 ; phong = 10);
    sphere(center = 1.6,0.2,1.5 ; radius = 0.8); end
  begin attribute(color = 0.9,0.9,0.9 ; texture = 5 0.2,0.2,0.2 0.5,0.5,0.5);
    polygon(vertices = 4; -4,-1,-4 4,-1,-4 4,-1,6 -4,-1,6); end
end";
        for glass in [GLASS, "kdr = 0.6 ;"] {
            let (scene, accel) = crate::render::test_scene::compiled(&src.replace("GLASS", glass));
            assert_eq!(scene.world.features.transparency, glass == GLASS);
            same_colours(&scene, &accel);
        }
    }

    fn same_colours(scene: &crate::scene::Scene, accel: &crate::accel::Accel) {
        let (w, h) = (23, 9);
        let opts = RenderOptions::asked([w, h], 1);
        let frame = Frame::new(scene, accel, &opts);
        let mut scratch = crate::accel::Scratch::new(scene.prims.len(), false);
        let mut counters = Counters::default();
        let mut tracer = Tracer {
            scene,
            accel,
            opts: opts.trace,
            scratch: &mut scratch,
            counters: &mut counters,
        };
        let mut hits = 0;
        for sampler in [Sampler::Stratified, Sampler::Sobol] {
            for count in [1, 3] {
                for y in 0..h {
                    let mut x = 0;
                    while x < w {
                        let xs = x..w.min(x + 1 + (x + y) % PACKET as u32);
                        let got =
                            trace_pixels(&mut tracer, &frame.camera, xs.clone(), y, count, sampler);
                        for (j, x) in xs.clone().enumerate() {
                            let want = match sampler {
                                Sampler::Stratified => {
                                    trace_pixel(&mut tracer, &frame.camera, (x, y), 0, count)
                                }
                                Sampler::Sobol => {
                                    trace_pixel_sobol(&mut tracer, &frame.camera, (x, y), 0, count)
                                }
                            };
                            assert_eq!(
                                got[j].to_array().map(f64::to_bits),
                                want.to_array().map(f64::to_bits),
                                "{sampler:?} {count} ({x}, {y})"
                            );
                            hits += usize::from(want != scene.world.background);
                        }
                        x = xs.end;
                    }
                }
            }
        }
        // One pixel's consecutive Sobol samples as a packet: each the sample alone.
        for y in 0..h {
            for x in 0..w {
                let (first, n) = ((x * 7 + y) % 13, 1 + (x + y) as usize % PACKET);
                let got = trace_sobol_samples(&mut tracer, &frame.camera, (x, y), 0, first, n);
                for (k, c) in (first..).zip(&got[..n]) {
                    let want = trace_sobol_sample(&mut tracer, &frame.camera, (x, y), 0, k);
                    assert_eq!(
                        c.to_array().map(f64::to_bits),
                        want.to_array().map(f64::to_bits),
                        "sample {k} of ({x}, {y})"
                    );
                }
                assert!(got[n..].iter().all(|c| *c == Vec3::ZERO));
            }
        }
        assert!(hits > 100, "{hits}");
    }
}
