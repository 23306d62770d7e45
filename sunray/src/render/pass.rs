//! Rendering to an error a pass at a time (and, with no cap, `sunray render`'s lines:
//! [`advance_line`] is both): the farm's unit of work with `--target-error` is
//! a (line, pass). Pass 0 takes every pixel of the line to its first samples; then, once
//! the lines within [`RADIUS`](super::neighbourhood::RADIUS) of it have theirs, its pixels
//! are decided ([`super::neighbourhood`]); pass `k` takes each raised pixel not done on by
//! whole steps of its schedule while it stays within [`pass_cap`]`(k)` samples. A pixel's
//! steps are those [`render_image_to_error`](super::window::render_image_to_error) takes
//! (all first samples, every decision, the rest in one go), so after its last pass a line
//! is bit for bit what `sunray render` gives,
//! wherever and in however many goes each pass ran: a pass starts from the line's
//! [`PixelEstimate`]s as the previous one and the decision left them (exactly: they travel
//! as bytes).

use super::adaptive::{self, pass_cap, Adaptive, PixelEstimate};
use super::columns::Columns;
use super::{Frame, RenderOptions};
use crate::accel::{Accel, Scratch};
use crate::scene::Scene;
use crate::shading::Tracer;
use crate::stats::Counters;

/// Pass `pass` of line `y` with the target `a`, as a farm's grant carries it, returning the
/// pass's counts. `carried`: with `columns`, the estimates of the pixels it names alone
/// (left to right) as the previous pass and the decision left them (a later pass carries
/// only those: [`Columns::taking`]; the pass changes no other pixel), else the whole line's
/// (none for pass 0); the same pixels' estimates after the pass on return. A pixel's
/// samples are those of the whole line's pass: they depend on the pixel alone.
#[allow(clippy::too_many_arguments)] // the line's parts, each borrowed as the caller holds it
pub fn render_granted_pass(
    scene: &Scene,
    accel: &Accel,
    (y, pass): (u32, u32),
    opts: &RenderOptions,
    a: &Adaptive,
    scratch: &mut Scratch,
    frame: &Frame,
    (columns, carried): (Option<&Columns>, &mut Vec<PixelEstimate>),
) -> Counters {
    let (width, cap) = (opts.width as usize, pass_cap(a, pass));
    let at = (accel, frame);
    let Some(c) = columns else {
        // The whole line: taken on where it lies.
        carried.resize(width, PixelEstimate::default());
        return advance_line(scene, at, y, opts, a, scratch, carried, (cap, None));
    };
    let mut line = vec![PixelEstimate::default(); width];
    c.put(&mut line, carried);
    let counters = advance_line(scene, at, y, opts, a, scratch, &mut line, (cap, columns));
    *carried = c.pick(&line);
    counters
}

/// Line `y` taken on from `estimates` by whole schedule steps while each pixel stays within
/// `cap` samples ([`adaptive::advance_pixel`]): a farm pass, or with no cap the whole line
/// as `sunray render` takes it; with `only`, the pixels it names alone (the others are left
/// as they are). A pixel with no samples outside the scene's footprint is the background at
/// its first samples, counted as the eye rays they would be.
#[allow(clippy::too_many_arguments)] // the line's parts, each borrowed as the caller holds it
pub(super) fn advance_line(
    scene: &Scene,
    (accel, frame): (&Accel, &Frame),
    y: u32,
    opts: &RenderOptions,
    a: &Adaptive,
    scratch: &mut Scratch,
    estimates: &mut [PixelEstimate],
    (cap, only): (u32, Option<&Columns>),
) -> Counters {
    let mut counters = Counters::default();
    // A line's counts must not depend on the lines its thread rendered before.
    scratch.occluders.clear();
    let mut tracer = Tracer {
        scene,
        accel,
        opts: opts.trace,
        scratch,
        counters: &mut counters,
    };
    let background = adaptive::constant_pixel(scene.world.background, a);
    for (run, traced) in frame.runs(y, opts.width) {
        for x in run {
            let Some(est) = estimates.get_mut(x as usize) else {
                break;
            };
            if only.is_some_and(|c| !c.contains(x)) {
                continue;
            }
            if !traced && est.count() == 0 {
                tracer.counters.eye += u64::from(a.min_samples);
                tracer.counters.voxels += frame.voxels_on_miss() * u64::from(a.min_samples);
                *est = background;
            } else {
                adaptive::advance_pixel(&mut tracer, &frame.camera, (x, y), 0, a, est, cap);
            }
        }
    }
    counters
}

/// Line `y` rendered to the error `a` with each pixel its own neighbourhood (raised only
/// when it is open itself): what [`render_line`](super::render_line) gives for one line
/// alone. An image's lines decide over their neighbourhoods
/// ([`render_image_to_error`](super::window::render_image_to_error)).
pub(super) fn line_alone(
    scene: &Scene,
    (accel, frame): (&Accel, &Frame),
    y: u32,
    opts: &RenderOptions,
    a: &Adaptive,
    scratch: &mut Scratch,
    estimates: &mut [PixelEstimate],
) -> Counters {
    let mut counters = advance_line(
        scene,
        (accel, frame),
        y,
        opts,
        a,
        scratch,
        estimates,
        (a.min_samples, None),
    );
    for e in estimates.iter_mut() {
        e.decide(e.is_open());
    }
    counters += advance_line(
        scene,
        (accel, frame),
        y,
        opts,
        a,
        scratch,
        estimates,
        (u32::MAX, None),
    );
    counters
}

/// True when every pixel of a line is done (it needs no further pass and no decision).
pub fn line_done(estimates: &[PixelEstimate], a: &Adaptive) -> bool {
    estimates.iter().all(|e| e.is_done(a))
}

/// A line's pixels: the means of its estimates.
pub fn line_pixels(estimates: &[PixelEstimate]) -> Vec<[f32; 3]> {
    estimates.iter().map(PixelEstimate::pixel).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::neighbourhood::decide_image;
    use crate::render::{adaptive::max_passes, render_image_summarized, Progress};

    /// The farm's way (every line's first samples, the decisions, then pass after pass of
    /// each line) gives `sunray render`'s image bit for bit, with the same samples; the
    /// neighbourhood raises pixels that are not open themselves. A later pass of the pixels
    /// it takes alone ([`render_granted_pass`]) gives what the whole line's pass gives.
    #[test]
    fn an_image_in_passes_is_the_image_in_one_go() {
        let (scene, accel) = crate::render::test_scene::shadowed_sphere();
        let a = Adaptive::new(0.01, Some(4), Some(256));
        let opts = RenderOptions {
            adaptive: Some(a),
            ..RenderOptions::asked([24, 16], 1)
        };
        let (film, counters, summaries) =
            render_image_summarized(&scene, &accel, &opts, 2, false, Progress::Hidden);
        let frame = Frame::new(&scene, &accel, &opts);
        let mut scratch = Scratch::new(scene.prims.len(), false);
        let w = opts.width as usize;
        let mut est = vec![PixelEstimate::default(); w * opts.height as usize];
        let mut eye = 0;
        // A pass as a grant carries it: the whole line, or with columns their pixels alone.
        let mut pass_of =
            |y: u32, pass: u32, row: &mut [PixelEstimate], columns: Option<&Columns>| {
                let mut carried = match columns {
                    Some(c) => c.pick(row),
                    None => row.to_vec(),
                };
                let c = render_granted_pass(
                    &scene,
                    &accel,
                    (y, pass),
                    &opts,
                    &a,
                    &mut scratch,
                    &frame,
                    (columns, &mut carried),
                );
                match columns {
                    Some(c) => c.put(row, &carried),
                    None => row.copy_from_slice(&carried),
                }
                c.eye
            };
        for (y, row) in (0..).zip(est.chunks_mut(w)) {
            eye += pass_of(y, 0, row, None);
        }
        assert!(est.iter().all(|e| e.awaits_decision(&a) && e.count() == 4));
        decide_image(&mut est, w, &a);
        let open = est.iter().filter(|e| e.is_open()).count();
        let near_open = est
            .iter()
            .filter(|e| !e.is_open() && !e.is_done(&a))
            .count();
        let stopped = est.iter().filter(|e| e.is_done(&a)).count();
        assert!(
            open > 0 && near_open > 0 && stopped > 0,
            "{open} {near_open} {stopped}"
        );
        let mut most_passes = 0;
        for (y, row) in (0..).zip(est.chunks_mut(w)) {
            let mut pass = 1;
            while !line_done(row, &a) {
                assert!(pass < max_passes(&a), "line {y} still not done");
                // The farm's later passes carry the pixels they take alone: the same.
                let columns = Columns::taking(row, &a, pass);
                let mut by_columns = row.to_vec();
                let c = pass_of(y, pass, &mut by_columns, Some(&columns));
                let eye_of_pass = pass_of(y, pass, row, None);
                assert_eq!(c, eye_of_pass, "line {y} pass {pass}");
                assert_eq!(by_columns, row, "line {y} pass {pass}");
                eye += eye_of_pass;
                for e in row.iter() {
                    assert!(e.is_done(&a) || e.count() <= pass_cap(&a, pass));
                }
                pass += 1;
            }
            most_passes = most_passes.max(pass);
        }
        assert_eq!(line_pixels(&est), film.pixels);
        assert_eq!(eye, counters.eye, "the same samples, counted once");
        let took: Vec<_> = est.iter().map(PixelEstimate::summary).collect();
        assert_eq!(took, summaries);
        for e in &est {
            assert_eq!(PixelEstimate::from_le_bytes(&e.to_le_bytes()), *e);
        }
        assert!(
            most_passes >= 4,
            "{most_passes} passes: the scene must need several"
        );
    }

    /// A pixel that never reaches its target: each pass must take it at least one step on,
    /// whatever its first samples.
    #[test]
    fn every_pixel_not_done_takes_a_step_in_every_pass() {
        for min in 1..=40 {
            let a = Adaptive::new(1e-6, Some(min), Some(4096));
            let mut est = PixelEstimate::default();
            for pass in 0..max_passes(&a) {
                // Raised by its neighbourhood after its first samples.
                if est.awaits_decision(&a) {
                    est.decide(true);
                }
                if est.next_count(&a).is_none() {
                    // One sample alone has no spread to estimate (min 1).
                    assert!(est.count() < 2, "min {min}: done at {}", est.count());
                    break;
                }
                let before = est.count();
                while let Some(want) = est.next_count(&a).filter(|&w| w <= pass_cap(&a, pass)) {
                    while est.count() < want {
                        // 0, 1, 0, 1...: blocks of one sample differ, and the floor (the
                        // samples' variance) keeps longer blocks' equal means from agreeing.
                        est.add(glam::DVec3::splat(f64::from(est.count() % 2)));
                    }
                }
                assert!(est.count() > before, "min {min}: pass {pass} took no step");
            }
            assert_eq!(
                est.next_count(&a),
                None,
                "min {min}: done after the last pass"
            );
            assert!(
                est.count() == 4096 || est.count() < 2,
                "min {min}: {}",
                est.count()
            );
        }
    }

    #[test]
    fn passes_are_bounded() {
        for (min, max, passes) in [(16, 1024, 6), (2, 65_536, 15), (4, 4, 1), (3, 10, 2)] {
            let a = Adaptive::new(0.01, Some(min), Some(max));
            assert_eq!(max_passes(&a), passes, "{min}..{max}");
            assert!(pass_cap(&a, passes - 1) >= max);
        }
    }
}
