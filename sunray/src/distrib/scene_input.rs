//! The scene of a job: a file (compiled once, on the controller) or the built-in example
//! scene, and the render settings taken from the same flags, with the same meaning, as
//! `sunray render`.

use super::messages::Settings;
use crate::accel::AccelKind;
use crate::cli::render::{load_world, OnOff, RenderArgs};
use crate::scene::Scene;
use crate::stats::{Counters, RenderStats};
use std::path::{Path, PathBuf};

/// The SCENE argument that names the built-in example scene (the default of `submit`).
pub const BUILTIN: &str = "@example";

/// The built-in example scene: glass, mirror, marble and wood on a checkered floor.
pub const DEFAULT_SCENE: &str = include_str!("default_scene.yari");

/// A loaded scene.
pub struct SceneInput {
    /// `None` for the built-in scene.
    pub path: Option<PathBuf>,
    pub scene: Scene,
}

/// The scene path given on the command line, `None` for the built-in one.
pub fn given_path(args: &RenderArgs) -> Option<PathBuf> {
    let p = &args.scene;
    (!p.as_os_str().is_empty() && p.as_os_str() != BUILTIN).then(|| p.clone())
}

/// Loads the scene named by the render flags (warnings printed, errors with diagnostics).
pub fn load(args: &RenderArgs) -> anyhow::Result<SceneInput> {
    load_path(given_path(args), args.colours.as_deref())
}

/// The built-in example scene, compiled.
pub fn builtin_world(colours: Option<&Path>) -> anyhow::Result<yari::model::World> {
    let table = yari::colour::ColourTable::for_run(colours)?;
    Ok(yari::load::load_str(
        "built-in example",
        DEFAULT_SCENE,
        yari::load::InputKind::Yari,
        &table,
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?
    .world)
}

/// Loads `path`, or the built-in scene for `None`.
pub fn load_path(path: Option<PathBuf>, colours: Option<&Path>) -> anyhow::Result<SceneInput> {
    let world = match &path {
        Some(p) => load_world(p, colours)?,
        None => builtin_world(colours)?,
    };
    let scene = Scene::new(world);
    for d in &scene.dropped {
        eprintln!(
            "sunray: warning: {}: object {} dropped: {}",
            path.as_deref()
                .map_or_else(|| BUILTIN.into(), |p| p.display().to_string()),
            d.object,
            d.reason
        );
    }
    Ok(SceneInput { path, scene })
}

impl SceneInput {
    /// The render settings `sunray render` would use with these flags.
    pub fn settings(&self, args: &RenderArgs) -> Settings {
        Settings {
            render: args.render_options(&self.scene),
            accel: args.accel_options(),
            mailbox: args.mailbox == OnOff::On,
        }
    }

    /// The compiled model as shipped to the workers.
    pub fn model_bytes(&self) -> anyhow::Result<Vec<u8>> {
        Ok(yari::modelfile::to_bytes(&self.scene.world)?)
    }

    /// What the checkpoint remembers: an absolute path, or "" for the built-in scene.
    pub fn spec_path(&self) -> String {
        match &self.path {
            Some(p) => std::path::absolute(p)
                .unwrap_or_else(|_| p.clone())
                .display()
                .to_string(),
            None => String::new(),
        }
    }

    pub fn display_name(&self) -> String {
        self.path
            .as_ref()
            .map_or_else(|| BUILTIN.to_string(), |p| p.display().to_string())
    }

    /// As `sunray render`: the scene's name with `.png` in the current directory, or
    /// `sunray.png` for the built-in scene.
    pub fn default_output(&self) -> PathBuf {
        match &self.path {
            Some(p) => {
                let stem = p.file_stem().unwrap_or_else(|| "image".as_ref());
                PathBuf::from(stem).with_extension("png")
            }
            None => PathBuf::from("sunray.png"),
        }
    }

    /// The statistics of the whole image in `sunray render`'s form.
    pub fn stats(&self, settings: &Settings, counters: &Counters) -> RenderStats {
        let bounded = self
            .scene
            .prims
            .iter()
            .filter(|p| p.bounds().is_some())
            .count();
        let kind = settings.accel.kind.resolve(bounded);
        let mut s = RenderStats {
            scene: self.display_name(),
            width: settings.render.width,
            height: settings.render.height,
            samples: settings.render.samples,
            accel: kind.name().to_string(),
            mailbox: settings.mailbox && kind == AccelKind::Octree,
            objects: self.scene.world.objects.len(),
            primitives: self.scene.prims.len(),
            unbounded: self.scene.prims.len() - bounded,
            ..Default::default()
        };
        s.set_counters(counters);
        s
    }
}
