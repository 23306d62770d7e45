//! What decides a pixel besides the scene: [`Settings`] (the image size, samples, ray-tree
//! limits and the accelerator), and [`Overrides`], what a user asks for on top of a scene's
//! own resolution and samples. `sunray render`, `sunray submit` and the SunRay III workers all
//! go through [`Overrides::settings`], so a distributed render decides its pixels exactly as a
//! local one.

use super::RenderOptions;
use crate::accel::{AccelKind, AccelOptions};
use crate::scene::Scene;
use crate::stats::RenderStats;

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
        }
    }
}

impl Overrides {
    /// The settings for `scene`: its own resolution and samples, overridden as asked.
    pub fn settings(&self, scene: &Scene) -> Settings {
        let mut render = RenderOptions::for_scene(scene);
        if let Some((w, h)) = self.resolution {
            (render.width, render.height) = (w, h);
        }
        if let Some(s) = self.samples {
            render.samples = s.max(1);
        }
        render.trace.max_depth = self.depth;
        render.trace.min_weight = self.min_weight;
        if self.spd_corners {
            render = render.spd_corners();
        }
        Settings {
            render,
            accel: AccelOptions {
                max_per_voxel: self.accel.max_per_voxel.max(1),
                ..self.accel
            },
            mailbox: self.mailbox,
        }
    }
}

impl Settings {
    /// The statistics header of a render of `scene` (named `name`) with these settings: image,
    /// accelerator (as [`crate::accel::Accel::build`] resolves it), objects and primitives.
    /// Counters, times, threads and accelerator cells are the caller's to fill in.
    pub fn stats_header(&self, name: &str, scene: &Scene) -> RenderStats {
        let bounded = scene.prims.iter().filter(|p| p.bounds().is_some()).count();
        let kind = self.accel.kind.resolve(bounded);
        RenderStats {
            scene: name.to_string(),
            width: self.render.width,
            height: self.render.height,
            samples: self.render.samples,
            accel: kind.name().to_string(),
            mailbox: self.mailbox && kind == AccelKind::Octree,
            objects: scene.world.objects.len(),
            primitives: scene.prims.len(),
            unbounded: scene.prims.len() - bounded,
            ..RenderStats::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load::{load, SceneSource};

    #[test]
    fn overrides_replace_the_scenes_own_size_and_samples() {
        let scene = load(&SceneSource::Builtin, None).unwrap().scene;
        let own = Overrides::default().settings(&scene);
        assert_eq!(own.render, RenderOptions::for_scene(&scene));
        let s = Overrides {
            resolution: Some((64, 32)),
            samples: Some(0),
            ..Overrides::default()
        }
        .settings(&scene);
        assert_eq!(
            (s.render.width, s.render.height, s.render.samples),
            (64, 32, 1)
        );
        let c = Overrides {
            resolution: Some((64, 32)),
            spd_corners: true,
            ..Overrides::default()
        }
        .settings(&scene);
        assert_eq!((c.render.width, c.render.height), (65, 33));
        assert_eq!(c.render.trace.min_weight, 0.0);
    }
}
