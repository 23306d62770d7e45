//! What every line of one image shares ([`Frame`]): the camera, and the scene's footprint
//! seen as runs of each line, traced or background ([`Frame::runs`]), the one walk of the
//! footprint that the fixed-count loop ([`super::render_line_into`]) and a render to an
//! error's passes ([`super::pass`]) both take.

use super::footprint::Footprint;
use super::RenderOptions;
use crate::accel::Accel;
use crate::camera::Camera;
use crate::scene::Scene;
use std::ops::Range;

/// What every line of one image shares: the camera and the scene's footprint on the image.
#[derive(Clone, Debug)]
pub struct Frame {
    /// The camera of the image.
    pub(super) camera: Camera,
    footprint: Option<Footprint>,
}

impl Frame {
    /// The frame of `scene` rendered with `opts`.
    pub fn new(scene: &Scene, accel: &Accel, opts: &RenderOptions) -> Frame {
        let camera = Camera::new(&scene.world.camera, opts.width, opts.height);
        let footprint = Footprint::new(&camera, accel);
        Frame { camera, footprint }
    }

    /// Line `y` of a `width`-pixel image as runs of pixels, left to right, each with whether
    /// its eye rays are traced: inside the footprint ([`Footprint::row`]), or outside it,
    /// background (no eye ray through it can meet anything). Without a footprint the line is
    /// one traced run.
    pub(super) fn runs(&self, y: u32, width: u32) -> Vec<(Range<u32>, bool)> {
        let Some(f) = &self.footprint else {
            return vec![(0..width, true)];
        };
        let mut runs = Vec::new();
        let mut from = 0;
        for span in f.row(y, width) {
            if span.start > from {
                runs.push((from..span.start, false));
            }
            from = span.end;
            runs.push((span, true));
        }
        if from < width {
            runs.push((from..width, false));
        }
        runs
    }

    /// What each eye ray of a background run adds to the voxel count (see [`Footprint`]).
    pub(super) fn voxels_on_miss(&self) -> u64 {
        self.footprint.as_ref().map_or(0, |f| f.voxels_on_miss)
    }
}
