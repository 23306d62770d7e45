//! What a farm job needs of its scene besides the model: the counts its statistics print and
//! the image size, samples and target error the scene asks for. A submitting host that knows these (and the
//! model's chunks) from an earlier submit of the same file starts the job without compiling
//! the scene again (see [`shipped_scenes`](crate::distrib::shipped_scenes)).

use super::Scene;
use serde::{Deserialize, Serialize};

/// A scene's counts and its own render settings.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SceneSummary {
    /// Objects in the model.
    pub objects: usize,
    /// Primitives built from them.
    pub primitives: usize,
    /// Of those, the unbounded ones (planes, unclipped quadrics).
    pub unbounded: usize,
    /// The image size the scene asks for (the world's `resolution`).
    pub resolution: [u32; 2],
    /// The samples per pixel the scene asks for.
    pub samples: u32,
    /// The target error the scene asks for (`target_error(E)`), if any.
    #[serde(default)]
    pub target_error: Option<f64>,
}

impl SceneSummary {
    /// The summary of a loaded scene.
    pub fn of(scene: &Scene) -> SceneSummary {
        SceneSummary {
            objects: scene.objects,
            primitives: scene.prims.len(),
            unbounded: scene.prims.unbounded_count(),
            resolution: scene.world.resolution,
            samples: scene.world.samples,
            target_error: scene.world.target_error,
        }
    }
}
