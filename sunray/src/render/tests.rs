//! The render loop's tests: the footprint's pixels against tracing every pixel.

use super::*;
use footprint::Footprint;

/// Nine small spheres in the middle of the picture, one reflecting: most pixels are
/// outside the footprint.
const SPHERES: &str = "background(color = 0.2,0.05,0.2);
camera(position = 0,0,-8; at = 0,0,0; up = 0,1,0; angle = 20);
light(position = -10,3,-20; color = 1,1,1);
begin
  attribute(color = 1,0.5,0.5; kdr = 0.6; ka = 0.2; phong = 20);
  sphere(center = 0,0,0; radius = 0.4);
  sphere(center = 0.9,0.2,0.3; radius = 0.2);
  sphere(center = -0.9,-0.3,0.2; radius = 0.25);
  sphere(center = 0.2,0.9,-0.2; radius = 0.2);
  sphere(center = -0.3,-0.9,0.4; radius = 0.2);
  sphere(center = 0.6,-0.6,0; radius = 0.15);
  sphere(center = -0.6,0.6,0; radius = 0.15);
  sphere(center = 1.5,1.1,1; radius = 0.3);
  sphere(center = -1.2,1.2,-1; radius = 0.1);
end
";

fn scene(motion: bool) -> (Scene, Accel) {
    let text = if motion {
        SPHERES.replace(
            "  sphere(center = 0.6",
            "  motion(0.2,0,0);\n  sphere(center = 0.6",
        )
    } else {
        SPHERES.to_string()
    };
    test_scene::compiled(&text)
}

/// The render loop before the footprint: every sample of every pixel traced. A pixel
/// `left_out` of the footprint must test no primitive, and counts one node an eye ray,
/// as the footprint counts it (tracing counted the inner nodes it entered above the cut).
fn trace_every_pixel(
    scene: &Scene,
    accel: &Accel,
    y: u32,
    opts: &RenderOptions,
    left_out: &dyn Fn(u32) -> bool,
) -> Line {
    let camera = Camera::new(&scene.world.camera, opts.width, opts.height);
    let mut counters = Counters::default();
    let mut scratch = Scratch::new(scene.prims.len(), false);
    let mut tracer = Tracer {
        scene,
        accel,
        opts: opts.trace,
        scratch: &mut scratch,
        counters: &mut counters,
    };
    let pixels = (0..opts.width)
        .map(|x| {
            let before = *tracer.counters;
            let c = match &opts.adaptive {
                Some(a) => {
                    adaptive::trace_pixel_to_error(&mut tracer, &camera, (x, y), 0, a).mean()
                }
                None if opts.sampler == Sampler::Sobol => {
                    trace_pixel_sobol(&mut tracer, &camera, (x, y), 0, opts.samples)
                }
                None => trace_pixel(&mut tracer, &camera, (x, y), 0, opts.samples),
            };
            if left_out(x) {
                let counts = &mut *tracer.counters;
                assert_eq!(
                    counts.intersection_tests, before.intersection_tests,
                    "{x},{y}"
                );
                counts.voxels = before.voxels + (counts.eye - before.eye);
            }
            [c.x as f32, c.y as f32, c.z as f32]
        })
        .collect();
    Line {
        y,
        pixels,
        counters,
    }
}

#[test]
fn pixels_outside_the_footprint_are_what_tracing_them_gives() {
    let to_error = Some(adaptive::Adaptive::new(0.02, None, None));
    let (stratified, sobol) = (Sampler::Stratified, Sampler::Sobol);
    let mut sobol_differs = false;
    for (samples, motion, adaptive, sampler) in [
        (1, false, None, stratified),
        (4, false, None, stratified),
        (3, true, None, stratified),
        (1, true, to_error, stratified),
        (4, false, None, sobol),
        (3, true, None, sobol),
    ] {
        let (scene, accel) = scene(motion);
        assert_eq!(scene.world.features.motion_blur, motion);
        let opts = RenderOptions {
            width: 40,
            height: 30,
            samples,
            trace: TraceOptions::default(),
            adaptive,
            sampler,
        };
        let camera = Camera::new(&scene.world.camera, opts.width, opts.height);
        let footprint = Footprint::new(&camera, &accel).unwrap();
        let mut scratch = Scratch::new(scene.prims.len(), false);
        let mut left_out = 0;
        for y in 0..opts.height {
            let covered: u32 = footprint
                .row(y, opts.width)
                .iter()
                .map(|r| r.len() as u32)
                .sum();
            left_out += opts.width - covered;
            let got = render_line(&scene, &accel, y, &opts, &mut scratch);
            let row = footprint.row(y, opts.width);
            let left_out_x = |x: u32| !row.iter().any(|r| r.contains(&x));
            let want = trace_every_pixel(&scene, &accel, y, &opts, &left_out_x);
            // The rays are the same; the tests and nodes counted are not, as neighbours'
            // eye rays walk the tree in packets (`packets`) and a pixel alone does not.
            let rays = |l: &Line| {
                let c = &l.counters;
                [
                    c.eye,
                    c.eye_hits,
                    c.shadow,
                    c.shadow_behind,
                    c.reflected,
                    c.refracted,
                ]
            };
            assert_eq!(
                got.pixels, want.pixels,
                "line {y}, {samples} samples, {sampler:?}"
            );
            assert_eq!(
                rays(&got),
                rays(&want),
                "line {y}, {samples} samples, {sampler:?}"
            );
            if sampler == sobol {
                let other = RenderOptions {
                    sampler: stratified,
                    ..opts
                };
                sobol_differs |= render_line(&scene, &accel, y, &other, &mut scratch) != got;
            }
        }
        assert!(
            left_out > opts.width * opts.height / 3,
            "{left_out} pixels left out"
        );
    }
    assert!(sobol_differs, "--sampler sobol draws other samples");
}
