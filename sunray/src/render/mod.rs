//! The render loop. A scanline is rendered by a pure function of (scene, accelerator, line,
//! options) -> pixels + counters ([`render_line`]); [`render_image`] runs it on all cores,
//! each taking the film's next row, the same request-render-complete loop a SunRay III
//! worker runs against its controller. [`settings`] holds what decides the
//! pixels besides the scene; [`footprint`], which pixels no eye ray of can meet anything,
//! and [`frame`], what every line of an image shares (the camera, the footprint as runs);
//! [`adaptive`], rendering each pixel to a target error instead of a sample count,
//! [`neighbourhood`], the one decision a pixel then takes from the pixels around it, and
//! [`pass`], doing so a pass at a time (the farm's unit of work then), each later pass
//! taking only the pixels of a line that [`columns`] names.
//! [`parallel`] runs the lines of one image on all cores, and [`window`] those of an image
//! rendered to an error, in a sliding window. [`image_version`] names the pixels this build
//! renders, so a farm never makes one image of two builds' lines.

pub mod adaptive;
pub mod columns;
pub mod footprint;
mod frame;
pub mod image_version;
pub mod neighbourhood;
mod packets;
pub mod parallel;
pub mod pass;
pub mod settings;
#[cfg(test)]
mod test_scene;
pub mod window;

use crate::accel::bvh::packet::PACKET;
use crate::accel::{Accel, Scratch};
use crate::camera::Camera;
use crate::geometry::Real;
use crate::sampler::{pixel_offset, SampleStream, Sampler};
use crate::scene::Scene;
use crate::shading::hall::RayKind;
use crate::shading::{TraceOptions, Tracer};
use crate::stats::Counters;

pub use frame::Frame;
pub use parallel::{render_image, render_image_summarized, Progress};
pub use settings::{Overrides, Settings};

/// How an image's rows are shared out: the threads (at least 1), the scratch each needs (a
/// scene of `prims` primitives, the mailbox on or off) and the progress bar to advance.
pub struct Rows<'a> {
    /// Threads to run.
    pub threads: usize,
    /// Primitives in the scene (for each thread's scratch).
    pub prims: usize,
    /// Whether the mailbox is on.
    pub mailbox: bool,
    /// The bar advanced by each row done.
    pub bar: Option<&'a indicatif::ProgressBar>,
}

impl Rows<'_> {
    /// `worker` run on [`Rows::threads`] threads (on this one when 1), their counts summed;
    /// a worker's panic is resumed here.
    pub fn run(&self, worker: impl Fn() -> Counters + Sync) -> Counters {
        let results: Vec<Counters> = if self.threads <= 1 {
            vec![worker()]
        } else {
            std::thread::scope(|s| {
                let handles: Vec<_> = (0..self.threads).map(|_| s.spawn(&worker)).collect();
                handles
                    .into_iter()
                    .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                    .collect()
            })
        };
        let mut total = Counters::default();
        for c in results {
            total += c;
        }
        total
    }
}

/// Everything besides the scene that decides the pixels.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RenderOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels (scanlines).
    pub height: u32,
    /// Samples per pixel (1 = one ray through each pixel centre).
    pub samples: u32,
    /// Ray-tree depth and weight limits.
    pub trace: TraceOptions,
    /// Render each pixel to a target error instead of `samples` ([`adaptive`]).
    #[serde(default)]
    pub adaptive: Option<adaptive::Adaptive>,
    /// Which numbers a fixed `samples` per pixel draws from (not used with `adaptive`).
    #[serde(default)]
    pub sampler: Sampler,
}

impl RenderOptions {
    /// The scene's own resolution and samples, default ray-tree limits.
    pub fn for_scene(scene: &Scene) -> RenderOptions {
        RenderOptions::asked(scene.world.resolution, scene.world.samples)
    }

    /// The defaults for a scene that asks for `resolution` and `samples` (0 counts as 1).
    pub fn asked(resolution: [u32; 2], samples: u32) -> RenderOptions {
        RenderOptions {
            width: resolution[0].max(1),
            height: resolution[1].max(1),
            samples: samples.max(1),
            trace: TraceOptions::default(),
            adaptive: None,
            sampler: Sampler::Stratified,
        }
    }
}

impl RenderOptions {
    /// Haines's SPD invariant setup: (W+1)x(H+1) eye rays, one through each pixel corner of
    /// the WxH image (the NFF angle then spans the centres of the first and last rows of the
    /// corner grid), one sample each, no weight threshold, and every ray his procedure
    /// spawns ([`TraceOptions::spawn_all`]).
    pub fn spd_corners(self) -> RenderOptions {
        RenderOptions {
            width: self.width + 1,
            height: self.height + 1,
            samples: 1,
            trace: TraceOptions {
                min_weight: 0.0,
                spawn_all: true,
                ..self.trace
            },
            adaptive: None,
            // Through the corners themselves.
            sampler: Sampler::Stratified,
        }
    }
}

/// One rendered scanline.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Line {
    /// The scanline, 0 at the top.
    pub y: u32,
    /// Linear RGB, left to right, `width` entries.
    pub pixels: Vec<[f32; 3]>,
    /// The events counted while rendering it.
    pub counters: Counters,
}

/// Renders scanline `y` (0 = top). `scratch` only saves allocations and mailbox work; the
/// result does not depend on it or on anything rendered before.
pub fn render_line(
    scene: &Scene,
    accel: &Accel,
    y: u32,
    opts: &RenderOptions,
    scratch: &mut Scratch,
) -> Line {
    let mut pixels = vec![[0.0; 3]; opts.width as usize];
    let frame = Frame::new(scene, accel, opts);
    let counters = render_line_into(scene, accel, y, opts, scratch, &frame, &mut pixels, None);
    Line {
        y,
        pixels,
        counters,
    }
}

/// What a pixel rendered to an error took: its samples and its estimated error.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSummary {
    /// Samples taken.
    pub samples: u32,
    /// The estimated standard error of its mean (the worst channel's).
    pub error: f32,
}

/// [`render_line`] into `pixels` (the row of a film, `opts.width` long) in `frame` (made
/// for the same scene and options), returning the line's counts: a whole image is rendered
/// in place, with no line allocated and copied and the frame made once. With a target error
/// the line is taken to it alone, each pixel deciding by its own first samples (an image's
/// pixels decide over their neighbourhoods: [`window::render_image_to_error`]), and what each
/// pixel took goes to `summaries` when given (as long as `pixels`).
#[allow(clippy::too_many_arguments)] // the row's parts, each borrowed as the caller holds it
pub fn render_line_into(
    scene: &Scene,
    accel: &Accel,
    y: u32,
    opts: &RenderOptions,
    scratch: &mut Scratch,
    frame: &Frame,
    pixels: &mut [[f32; 3]],
    mut summaries: Option<&mut [PixelSummary]>,
) -> Counters {
    if let Some(a) = &opts.adaptive {
        // To an error: the line alone, each pixel its own neighbourhood (an image decides
        // over neighbourhoods: `window::render_image_to_error`).
        let mut estimates = vec![adaptive::PixelEstimate::default(); opts.width as usize];
        let counters = pass::line_alone(scene, (accel, frame), y, opts, a, scratch, &mut estimates);
        for (x, (pixel, est)) in pixels.iter_mut().zip(&estimates).enumerate() {
            *pixel = est.pixel();
            if let Some(s) = summaries.as_deref_mut().and_then(|s| s.get_mut(x)) {
                *s = est.summary();
            }
        }
        return counters;
    }
    let camera = &frame.camera;
    let mut counters = Counters::default();
    let n = opts.samples.max(1);
    // A line's counts must not depend on the lines its thread rendered before.
    scratch.occluders.clear();
    let mut tracer = Tracer {
        scene,
        accel,
        opts: opts.trace,
        scratch,
        counters: &mut counters,
    };
    // Pixels outside the scene's footprint are background, counted as the eye rays the
    // tracer would have sent (each one node: `Footprint`), a run at a time; the rest traced.
    let background = mean_of(n, |_| scene.world.background);
    let background = [
        background.x as f32,
        background.y as f32,
        background.z as f32,
    ];
    for (run, traced) in frame.runs(y, opts.width) {
        if !traced {
            if let Some(px) = pixels.get_mut(run.start as usize..run.end as usize) {
                px.fill(background);
            }
            let rays = u64::from(run.end - run.start) * u64::from(n);
            tracer.counters.eye += rays;
            tracer.counters.voxels += frame.voxels_on_miss() * rays;
            continue;
        }
        // Neighbours' eye rays walk the accelerator together, a packet at a time.
        let mut x = run.start;
        while x < run.end {
            let xs = x..run.end.min(x + PACKET as u32);
            let colours =
                packets::trace_pixels(&mut tracer, camera, xs.clone(), y, n, opts.sampler);
            for (x, c) in xs.clone().zip(colours) {
                if let Some(pixel) = pixels.get_mut(x as usize) {
                    *pixel = [c.x as f32, c.y as f32, c.z as f32];
                }
            }
            x = xs.end;
        }
    }
    counters
}

/// The mean colour of samples `0..count` of pixel `(x, y)`, their random numbers keyed by
/// streams `first_stream..` ([`trace_sample`]; the render uses `first_stream = 0`).
pub fn trace_pixel(
    tracer: &mut Tracer,
    camera: &Camera,
    (x, y): (u32, u32),
    first_stream: u32,
    count: u32,
) -> glam::DVec3 {
    mean_of(count, |k| {
        trace_sample(tracer, camera, (x, y), first_stream + k, k, count)
    })
}

/// The mean of samples `0..count` of pixel `(x, y)`'s Owen-scrambled Sobol sequence scrambled
/// by `seed` (`--sampler sobol`; the render uses seed 0).
pub fn trace_pixel_sobol(
    tracer: &mut Tracer,
    camera: &Camera,
    (x, y): (u32, u32),
    seed: u32,
    count: u32,
) -> glam::DVec3 {
    mean_of(count, |k| {
        trace_sobol_sample(tracer, camera, (x, y), seed, k)
    })
}

/// The colour seen by sample `index` of pixel `(x, y)`'s Owen-scrambled Sobol sequence
/// scrambled by `seed`: the one sample both `--sampler sobol` and rendering to an error
/// ([`adaptive::advance_pixel`]) take, its first 2-D draw placing the point in the pixel.
pub(crate) fn trace_sobol_sample(
    tracer: &mut Tracer,
    camera: &Camera,
    (x, y): (u32, u32),
    seed: u32,
    index: u32,
) -> glam::DVec3 {
    let mut rng = SampleStream::sobol(x, y, seed, index);
    trace_with(tracer, camera, (x, y), 1, 0, &mut rng)
}

/// The mean of `sample(k)` for `k` in `0..count`, summed in that order. One sample needs no
/// division (x / 1 is x; skipping it saves a dependent divide per pixel).
fn mean_of(count: u32, mut sample: impl FnMut(u32) -> glam::DVec3) -> glam::DVec3 {
    let mut sum = glam::DVec3::ZERO;
    for k in 0..count {
        sum += sample(k);
    }
    if count == 1 {
        sum
    } else {
        sum / count as Real
    }
}

/// The colour seen by sample `index` of `count` of pixel `(x, y)`, its random numbers keyed
/// by `stream` ([`SampleStream::stratified`]; the render uses `stream = index`): the eye ray
/// through the sample's point of the pixel, at its shutter time if the scene moves, from its
/// point of the lens if the camera has one, traced.
pub fn trace_sample(
    tracer: &mut Tracer,
    camera: &Camera,
    (x, y): (u32, u32),
    stream: u32,
    index: u32,
    count: u32,
) -> glam::DVec3 {
    let mut rng = SampleStream::stratified(x, y, stream, index, count);
    trace_with(tracer, camera, (x, y), count, index, &mut rng)
}

/// The colour seen by sample `index` of `count` of pixel `(x, y)` drawing its numbers from
/// `rng` (stratified jitter, or a Sobol stream whose first draw places the point).
pub(crate) fn trace_with(
    tracer: &mut Tracer,
    camera: &Camera,
    (x, y): (u32, u32),
    count: u32,
    index: u32,
    rng: &mut SampleStream,
) -> glam::DVec3 {
    let ray = eye_ray(tracer.scene, camera, (x, y), count, index, rng);
    let air = crate::shading::Media::AIR;
    tracer.trace(ray, RayKind::Eye, 1, 1.0, air, rng)
}

/// The eye ray of sample `index` of `count` of pixel `(x, y)`, drawing its point in the
/// pixel, its shutter time if the scene moves and its lens point if the camera has one from
/// `rng`, which shading goes on drawing from.
pub(crate) fn eye_ray(
    scene: &Scene,
    camera: &Camera,
    (x, y): (u32, u32),
    count: u32,
    index: u32,
    rng: &mut SampleStream,
) -> crate::geometry::Ray {
    let (dx, dy) = pixel_offset(count, index, rng);
    let time = if scene.world.features.motion_blur {
        rng.next_real()
    } else {
        0.0
    };
    camera.ray(x as Real + dx, y as Real + dy, time, Some(&mut *rng))
}

#[cfg(test)]
mod tests;
