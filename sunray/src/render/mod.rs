//! The render loop. A scanline is rendered by a pure function of (scene, accelerator, line,
//! options) -> pixels + counters ([`render_line`]); [`render_image`] runs it on all cores by
//! pulling line numbers from a shared atomic counter, the same request-render-complete loop a
//! SunRay III worker runs against its controller. [`settings`] holds what decides the
//! pixels besides the scene.

pub mod parallel;
pub mod settings;

use crate::accel::{Accel, Scratch};
use crate::camera::Camera;
use crate::geometry::Real;
use crate::sampler::{pixel_offset, SampleStream};
use crate::scene::Scene;
use crate::shading::hall::RayKind;
use crate::shading::{TraceOptions, Tracer};
use crate::stats::Counters;

pub use parallel::{render_image, Progress};
pub use settings::{Overrides, Settings};

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
}

impl RenderOptions {
    /// The scene's own resolution and samples, default ray-tree limits.
    pub fn for_scene(scene: &Scene) -> RenderOptions {
        RenderOptions {
            width: scene.world.resolution[0].max(1),
            height: scene.world.resolution[1].max(1),
            samples: scene.world.samples.max(1),
            trace: TraceOptions::default(),
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
    let camera = Camera::new(&scene.world.camera, opts.width, opts.height);
    let mut counters = Counters::default();
    let n = opts.samples.max(1);
    let motion = scene.world.features.motion_blur;
    let mut pixels = Vec::with_capacity(opts.width as usize);
    let mut tracer = Tracer {
        scene,
        accel,
        opts: opts.trace,
        scratch,
        counters: &mut counters,
    };
    for x in 0..opts.width {
        let mut sum = glam::DVec3::ZERO;
        for s in 0..n {
            let mut rng = SampleStream::stratified(x, y, s, s, n);
            let (dx, dy) = pixel_offset(n, s, &mut rng);
            let time = if motion { rng.next_real() } else { 0.0 };
            let ray = camera.ray(x as Real + dx, y as Real + dy, time, Some(&mut rng));
            sum += tracer.trace(
                ray,
                RayKind::Eye,
                1,
                1.0,
                crate::shading::Media::AIR,
                &mut rng,
            );
        }
        // One sample needs no division (x / 1 is x; skipping it saves a dependent divide
        // per pixel).
        let c = if n == 1 { sum } else { sum / n as Real };
        pixels.push([c.x as f32, c.y as f32, c.z as f32]);
    }
    Line {
        y,
        pixels,
        counters,
    }
}
