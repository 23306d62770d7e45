//! What decides a pixel besides the scene: [`Settings`] (the image size, samples, ray-tree
//! limits and the accelerator), and [`Overrides`], what a user asks for on top of a scene's
//! own resolution and samples. `sunray render`, `sunray submit` and the SunRay III workers all
//! go through [`Overrides::settings`], so a distributed render decides its pixels exactly as a
//! local one.
//!
//! Every field has explicit bounds ([`MAX_SIDE`], [`MAX_PIXELS`], [`MAX_SAMPLES`],
//! [`MAX_DEPTH`], [`MIN_WEIGHT`], [`MAX_PER_VOXEL`], [`MAX_OCTREE_DEPTH`], [`ACCEL_NAMES`]),
//! checked by [`Settings::check`] wherever settings come from outside: a user's flags and
//! scene ([`Overrides::settings`]), a controller's `Scene` message and a checkpoint
//! (`Settings::from_proto` in `distrib::messages`). A value out of bounds is a
//! [`SettingsError`] naming the field, the value and the bound, found before anything is
//! allocated for the render.

use super::RenderOptions;
use crate::accel::{AccelKind, AccelOptions};
use crate::sampler::Sampler;
use crate::scene::summary::SceneSummary;
use crate::scene::Scene;
use crate::shading::TraceOptions;
use crate::stats::RenderStats;
use std::fmt;
use std::ops::RangeInclusive;

/// The widest and tallest image: 16384 pixels a side (16K). A worker allocates one line of
/// `width` pixels per render thread, so this bounds what a `Scene` message can make it
/// allocate; the thesis's scenes are 256 to 512 pixels wide. In `--spd-corners` mode the
/// corner grid is one larger than the image, so the image itself is at most 16383 a side.
pub const MAX_SIDE: u32 = 16_384;

/// The most pixels in an image, width x height: 2^27 = 134,217,728 (16K UHD, 15360 x 8640,
/// fits). The controller (and `sunray render`) holds the whole film, 12 bytes a pixel: 1.5 GiB
/// at this bound.
pub const MAX_PIXELS: u64 = 1 << 27;

/// The most samples per pixel: 65536. The accuracy benchmark's converged reference uses
/// 16384; the stochastic scenes use 4 to 64.
pub const MAX_SAMPLES: u32 = 65_536;

/// The deepest ray tree: 64 levels (eye ray = 1). A Whitted/Hall ray tree rarely needs more
/// than 10 (the SPD rule is 5); every level is a stack frame of the recursive tracer, so this
/// also bounds its stack. The tracer never goes deeper, whatever it is given
/// ([`TraceOptions::MAX_DEPTH`]).
pub const MAX_DEPTH: u32 = TraceOptions::MAX_DEPTH;

/// The weight threshold below which no secondary ray is spawned: a finite number in [0, 1].
/// 0 spawns every ray the depth allows (the SPD corner mode), 1 none.
pub const MIN_WEIGHT: RangeInclusive<f64> = 0.0..=1.0;

/// The octree's split threshold: a voxel holding more than this many primitives is split;
/// 1 to 2^20 (1,048,576; the thesis uses 10). Above a few thousand the octree is one voxel.
pub const MAX_PER_VOXEL: u32 = 1 << 20;

/// The octree's deepest subdivision: 0 (one voxel) to 12, 4096 cells a side (the default
/// and the thesis's tables use 8). The octree's memory grows up to four times a level where
/// primitives share surfaces and `max_per_voxel` is small: with 1 primitive a voxel, the SPD
/// mount (size 4) builds 150 MB at depth 12 but 2.4 GB at 16, the built-in scene 3.2 GB at
/// the octree's own cap of 20 ([`crate::accel::octree::MAX_DEPTH`], which stays the cap for
/// options built in code). So a `Scene` message cannot make a worker build a multi-gigabyte
/// octree.
pub const MAX_OCTREE_DEPTH: u32 = 12;

/// The accelerator names a `Scene` message or a checkpoint may carry ([`AccelKind::name`]).
pub const ACCEL_NAMES: [&str; 4] = ["auto", "octree", "bvh", "exhaustive"];

/// A bounded integer field of [`Settings`], named as in `proto::RenderSettings`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// Image width (`--resolution W`x).
    Width,
    /// Image height (`--resolution x`H).
    Height,
    /// Samples per pixel (`--samples`).
    Samples,
    /// Ray-tree depth (`--depth`).
    MaxDepth,
    /// The octree's split threshold (`--max-per-voxel`).
    MaxPerVoxel,
    /// The octree's subdivision depth (`--max-depth`).
    OctreeMaxDepth,
}

impl Field {
    /// The field's name in `proto::RenderSettings`, with the flag that sets it.
    pub fn name(self) -> &'static str {
        match self {
            Field::Width => "width (--resolution WxH)",
            Field::Height => "height (--resolution WxH)",
            Field::Samples => "samples (--samples)",
            Field::MaxDepth => "max_depth (ray-tree depth, --depth)",
            Field::MaxPerVoxel => "max_per_voxel (--max-per-voxel)",
            Field::OctreeMaxDepth => "octree_max_depth (--max-depth)",
        }
    }
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A render setting out of its bounds: which, its value and the bound, on one line.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SettingsError {
    /// An integer field outside `min..=max`.
    #[error("render setting {field} = {value} is out of range {min}..={max}")]
    OutOfRange {
        /// The field.
        field: Field,
        /// Its value.
        value: u64,
        /// The smallest value allowed.
        min: u64,
        /// The largest value allowed.
        max: u64,
    },
    /// Both sides within [`MAX_SIDE`], but more than [`MAX_PIXELS`] pixels.
    #[error("render setting width x height = {width} x {height} = {} pixels is more than {MAX_PIXELS}", u64::from(*.width) * u64::from(*.height))]
    TooManyPixels {
        /// The width.
        width: u32,
        /// The height.
        height: u32,
    },
    /// The weight threshold is not a finite number in [`MIN_WEIGHT`].
    #[error("render setting min_weight (--min-weight) = {value} is not a number in [0, 1]")]
    MinWeight {
        /// Its value (NaN and infinities included).
        value: f64,
    },
    /// An accelerator name that is not one of [`ACCEL_NAMES`].
    #[error("render setting accel = {name:?} is not one of auto, octree, bvh, exhaustive")]
    Accel {
        /// The name given.
        name: String,
    },
    /// A sampler name that is not one of [`Sampler::ALL`]'s.
    #[error("render setting sampler = {name:?} is not one of stratified, sobol")]
    Sampler {
        /// The name given.
        name: String,
    },
    /// A target error or its sample bounds out of range.
    #[error(transparent)]
    Adaptive(#[from] super::adaptive::AdaptiveError),
}

/// Checks that `value` of `field` is within `range`.
fn check_range(field: Field, value: u64, range: RangeInclusive<u64>) -> Result<(), SettingsError> {
    if range.contains(&value) {
        Ok(())
    } else {
        Err(SettingsError::OutOfRange {
            field,
            value,
            min: *range.start(),
            max: *range.end(),
        })
    }
}

/// The accelerator of a name in [`ACCEL_NAMES`] (as a `Scene` message or checkpoint spells it).
pub fn accel_kind(name: &str) -> Result<AccelKind, SettingsError> {
    [
        AccelKind::Auto,
        AccelKind::Octree,
        AccelKind::Bvh,
        AccelKind::Exhaustive,
    ]
    .into_iter()
    .find(|k| k.name() == name)
    .ok_or_else(|| SettingsError::Accel {
        name: name.to_string(),
    })
}

/// The sampler named `name` (a `Scene` message's or a checkpoint's; empty is stratified, as
/// sent before there was a choice).
pub fn sampler(name: &str) -> Result<Sampler, SettingsError> {
    if name.is_empty() {
        return Ok(Sampler::Stratified);
    }
    Sampler::from_name(name).ok_or_else(|| SettingsError::Sampler {
        name: name.to_string(),
    })
}

/// Everything besides the scene that decides the pixels of a render, and how they are found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Image size, samples per pixel and ray-tree limits.
    pub render: RenderOptions,
    /// The accelerator to build (it changes speed, never pixels).
    pub accel: AccelOptions,
    /// Whether the octree uses its intersection buffer (Glassner's mailbox).
    pub mailbox: bool,
}

/// What the user asks for on top of the scene's own settings (the flags of `sunray render`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Overrides {
    /// Width and height instead of the scene's `resolution`.
    pub resolution: Option<(u32, u32)>,
    /// Samples per pixel instead of the scene's `samples` (at least 1).
    pub samples: Option<u32>,
    /// Maximum depth of the ray tree (eye ray = 1).
    pub depth: u32,
    /// Rays whose weight falls to this or below are not spawned.
    pub min_weight: f64,
    /// Haines's SPD invariant mode: (W+1)x(H+1) eye rays through the pixel corners, one
    /// sample each, no weight threshold ([`RenderOptions::spd_corners`]).
    pub spd_corners: bool,
    /// The accelerator and its build parameters.
    pub accel: AccelOptions,
    /// The octree's intersection buffer.
    pub mailbox: bool,
    /// Render each pixel to a target error instead of a sample count.
    pub adaptive: Option<super::adaptive::Adaptive>,
    /// Which numbers a fixed number of samples draws from.
    pub sampler: Sampler,
}

impl Default for Overrides {
    /// The defaults of `sunray render`: the scene's own size and samples, depth 5, weight
    /// threshold 0.001, the automatic accelerator, the mailbox on.
    fn default() -> Overrides {
        Overrides {
            resolution: None,
            samples: None,
            depth: 5,
            min_weight: 0.001,
            spd_corners: false,
            accel: AccelOptions::default(),
            mailbox: true,
            adaptive: None,
            sampler: Sampler::Stratified,
        }
    }
}

impl Overrides {
    /// The settings for `scene`: its own resolution and samples, overridden as asked (a
    /// sample count of 0 and a split threshold of 0 count as 1); refused if out of bounds
    /// ([`Settings::check`]), whether the scene or the flags asked for it.
    pub fn settings(&self, scene: &Scene) -> Result<Settings, SettingsError> {
        self.settings_for(&SceneSummary::of(scene))
    }

    /// [`Overrides::settings`] from the scene's summary alone (a farm job whose scene is not
    /// compiled again on the submitting host).
    pub fn settings_for(&self, scene: &SceneSummary) -> Result<Settings, SettingsError> {
        let mut render = RenderOptions::asked(scene.resolution, scene.samples);
        if let Some((w, h)) = self.resolution {
            (render.width, render.height) = (w, h);
        }
        if let Some(s) = self.samples {
            render.samples = s.max(1);
        }
        render.trace.max_depth = self.depth;
        render.trace.min_weight = self.min_weight;
        render.sampler = self.sampler;
        // The flags' target error, else the scene's unless the flags ask for a sample count.
        render.adaptive = self.adaptive.or_else(|| {
            let scene_asks = scene.target_error.filter(|_| self.samples.is_none());
            scene_asks.map(|e| super::adaptive::Adaptive::new(e, None, None))
        });
        let mut settings = Settings {
            render,
            accel: AccelOptions {
                max_per_voxel: self.accel.max_per_voxel.max(1),
                ..self.accel
            },
            mailbox: self.mailbox,
        };
        // Checked before the corner grid adds a line and a column, so that cannot overflow.
        settings.check()?;
        if self.spd_corners {
            settings.render = settings.render.spd_corners();
            settings.check()?;
        }
        Ok(settings)
    }
}

impl Settings {
    /// Checks every field against its bound: width and height in 1..=[`MAX_SIDE`], at most
    /// [`MAX_PIXELS`] pixels, samples in 1..=[`MAX_SAMPLES`], ray-tree depth in
    /// 1..=[`MAX_DEPTH`], min_weight finite in [`MIN_WEIGHT`], max_per_voxel in
    /// 1..=[`MAX_PER_VOXEL`], the octree's depth in 0..=[`MAX_OCTREE_DEPTH`]. The first field
    /// out of bounds is the error.
    pub fn check(&self) -> Result<(), SettingsError> {
        let r = &self.render;
        let side = 1..=u64::from(MAX_SIDE);
        check_range(Field::Width, r.width.into(), side.clone())?;
        check_range(Field::Height, r.height.into(), side)?;
        if u64::from(r.width) * u64::from(r.height) > MAX_PIXELS {
            return Err(SettingsError::TooManyPixels {
                width: r.width,
                height: r.height,
            });
        }
        check_range(Field::Samples, r.samples.into(), 1..=MAX_SAMPLES.into())?;
        check_range(
            Field::MaxDepth,
            r.trace.max_depth.into(),
            1..=MAX_DEPTH.into(),
        )?;
        let w = r.trace.min_weight;
        if !w.is_finite() || !MIN_WEIGHT.contains(&w) {
            return Err(SettingsError::MinWeight { value: w });
        }
        if let Some(a) = &r.adaptive {
            a.check()?;
        }
        let per_voxel = u64::try_from(self.accel.max_per_voxel).unwrap_or(u64::MAX);
        check_range(Field::MaxPerVoxel, per_voxel, 1..=MAX_PER_VOXEL.into())?;
        check_range(
            Field::OctreeMaxDepth,
            self.accel.max_depth.into(),
            0..=MAX_OCTREE_DEPTH.into(),
        )
    }

    /// The statistics header of a render of `scene` (named `name`) with these settings: image,
    /// accelerator (as [`crate::accel::Accel::build`] resolves it), objects and primitives.
    /// Counters, times, threads and accelerator cells are the caller's to fill in.
    pub fn stats_header(&self, name: &str, scene: &Scene) -> RenderStats {
        self.stats_header_of(
            name,
            scene.objects,
            scene.prims.len(),
            scene.prims.unbounded_count(),
        )
    }

    /// [`Settings::stats_header`] from the scene's counts alone (a job whose model is not
    /// decoded here).
    pub fn stats_header_of(
        &self,
        name: &str,
        objects: usize,
        primitives: usize,
        unbounded: usize,
    ) -> RenderStats {
        let unbounded = unbounded.min(primitives);
        let kind = self.accel.kind.resolve(primitives - unbounded);
        RenderStats {
            scene: name.to_string(),
            width: self.render.width,
            height: self.render.height,
            samples: self.render.samples,
            sampler: match self.render.adaptive {
                Some(_) => Sampler::Sobol.name().to_string(),
                None => self.render.sampler.name().to_string(),
            },
            accel: kind.name().to_string(),
            mailbox: self.mailbox && kind == AccelKind::Octree,
            objects,
            primitives,
            unbounded,
            ..RenderStats::default()
        }
    }
}

#[cfg(test)]
mod tests;
