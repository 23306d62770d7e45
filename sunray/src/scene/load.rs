//! Where a scene comes from ([`SceneSource`]: a file or the built-in example) and loading it:
//! read or compiled, its primitives built, and every warning (the compiler's, and the objects
//! dropped as degenerate) collected for the caller to print.
//!
//! Every kind is read as a stream: each object becomes primitives as soon as it is compiled
//! or decoded, so the world's objects are never held whole. A job's scene
//! ([`compile_for_job`]) becomes model file bytes and counts instead: the submitting host
//! ships it and builds no primitive.

use super::summary::SceneSummary;
use super::Scene;
use crate::geometry::primitive::Dropped;
use crate::geometry::primitives::PrimitivesBuilder;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::time::Instant;
use yari::colour::{ColourFileError, ColourTable};
use yari::load::{InputKind, LoadError};
use yari::model::{Object, Surface};
use yari::modelfile::ModelEncoder;

/// The SCENE argument that names the built-in example scene (the default of `render` and
/// `submit`).
pub const BUILTIN: &str = "@example";

/// The built-in example scene: glass, mirror, marble and wood on a checkered floor.
pub const DEFAULT_SCENE: &str = include_str!("default_scene.yari");

/// Where a scene comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SceneSource {
    /// The built-in example scene ([`DEFAULT_SCENE`]).
    Builtin,
    /// A .yari, .nff or .off scene, or a compiled model.
    File(PathBuf),
}

impl SceneSource {
    /// The scene a SCENE argument names: [`BUILTIN`] or an empty argument is the built-in one.
    pub fn from_arg(arg: &Path) -> SceneSource {
        if arg.as_os_str().is_empty() || arg.as_os_str() == BUILTIN {
            SceneSource::Builtin
        } else {
            SceneSource::File(arg.to_path_buf())
        }
    }

    /// The file, `None` for the built-in scene.
    pub fn path(&self) -> Option<&Path> {
        match self {
            SceneSource::Builtin => None,
            SceneSource::File(p) => Some(p),
        }
    }

    /// The name in messages and statistics: the path as given, or [`BUILTIN`].
    pub fn display_name(&self) -> String {
        match self {
            SceneSource::Builtin => BUILTIN.to_string(),
            SceneSource::File(p) => p.display().to_string(),
        }
    }

    /// The image written when no output is given: the scene's name with `.png` in the current
    /// directory, `example.png` for the built-in scene.
    pub fn default_output(&self) -> PathBuf {
        let stem = match self {
            SceneSource::Builtin => "example".as_ref(),
            SceneSource::File(p) => p.file_stem().unwrap_or_else(|| "image".as_ref()),
        };
        PathBuf::from(stem).with_extension("png")
    }

    /// What a checkpoint remembers: the absolute path, or "" for the built-in scene
    /// (the inverse of [`SceneSource::from_remembered`]).
    pub fn remembered(&self) -> String {
        match self {
            SceneSource::Builtin => String::new(),
            SceneSource::File(p) => std::path::absolute(p)
                .unwrap_or_else(|_| p.clone())
                .display()
                .to_string(),
        }
    }

    /// The scene a checkpoint remembered with [`SceneSource::remembered`].
    pub fn from_remembered(s: &str) -> SceneSource {
        if s.is_empty() {
            SceneSource::Builtin
        } else {
            SceneSource::File(PathBuf::from(s))
        }
    }
}

/// A scene that could not be loaded. Display gives the whole message (for a bad scene, every
/// diagnostic with its `file:line:col` and caret).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneLoadError {
    /// The colour-name file could not be read.
    #[error("{0}")]
    Colours(#[from] ColourFileError),
    /// The scene could not be read or compiled.
    #[error("{0}")]
    Scene(#[from] LoadError),
}

/// A loaded scene, its warnings, and how long it took.
pub struct LoadedScene {
    /// Where it came from.
    pub source: SceneSource,
    /// The model and its primitives.
    pub scene: Scene,
    /// The compiler's warnings (with carets) and one line per dropped object, ready to print.
    pub warnings: Vec<String>,
    /// Seconds spent reading and compiling.
    pub load_s: f64,
    /// Seconds spent building the primitives.
    pub prepare_s: f64,
}

/// Loads a scene, with the colour names of `colours` (else `$YARI_COLORS`) added to the
/// built-in table. The file is read as a stream, each object becoming primitives as it is
/// compiled or decoded.
pub fn load(source: &SceneSource, colours: Option<&Path>) -> Result<LoadedScene, SceneLoadError> {
    let t_load = Instant::now();
    let table = ColourTable::for_run(colours)?;
    if let Some(path) = source.path().filter(|p| is_model_file(p)) {
        return load_model_file(source, path, t_load);
    }
    let mut builder = PrimitivesBuilder::new();
    let loaded = stream(source, &table, &mut |surfaces, o| builder.add(surfaces, &o))?;
    let warnings = compiler_warnings(&loaded);
    // Compiling and building the primitives go together: all of it counts as loading.
    let load_s = t_load.elapsed().as_secs_f64();
    let scene = Scene::built(loaded.world, builder);
    Ok(finish(source, scene, warnings, load_s, Instant::now()))
}

/// A scene compiled for a job that ships it: its model file's bytes, as SunRay III workers
/// get them, and what the job's statistics need of it. The submitting host never renders
/// it, so its primitives are counted ([`PrimitivesBuilder::counting`]), never built.
pub struct CompiledScene {
    /// Where it came from.
    pub source: SceneSource,
    /// The compiled model file's bytes.
    pub model: Vec<u8>,
    /// Its counts and its own render settings.
    pub summary: SceneSummary,
    /// The compiler's warnings (with carets) and one line per dropped object, ready to print.
    pub warnings: Vec<String>,
    /// Seconds spent reading, compiling and counting.
    pub load_s: f64,
    /// The files other than the scene file it was made from (meshes a YARI scene placed,
    /// material libraries, buffers).
    pub inputs: Vec<PathBuf>,
}

/// Compiles a scene for a job ([`CompiledScene`]), with the colour names of `colours`: read
/// as a stream, each object encoded and counted as it is compiled; a compiled model is read
/// whole (it is what is shipped) and counted.
pub fn compile_for_job(
    source: &SceneSource,
    colours: Option<&Path>,
) -> Result<CompiledScene, SceneLoadError> {
    let t_load = Instant::now();
    let table = ColourTable::for_run(colours)?;
    let mut counter = PrimitivesBuilder::counting();
    if let Some(path) = source.path().filter(|p| is_model_file(p)) {
        let name = path.display().to_string();
        let model = std::fs::read(path).map_err(|e| {
            SceneLoadError::Scene(LoadError::Io {
                path: path.to_path_buf(),
                source: e,
            })
        })?;
        let world = yari::modelfile::read_stream(&mut &model[..], &mut |head, _, o| {
            counter.add(&head.surfaces, &o)
        })
        .map_err(|e| model_error(e, &name))?;
        return Ok(compiled(source, world, counter, model, Vec::new(), t_load));
    }
    let mut encoder = ModelEncoder::new();
    let loaded = stream(source, &table, &mut |surfaces, o| {
        encoder.push(&o);
        counter.add(surfaces, &o);
    })?;
    let warnings = compiler_warnings(&loaded);
    let model = encoder
        .finish(&loaded.world)
        .map_err(|e| model_error(e, "the compiled scene"))?;
    let inputs = loaded.inputs();
    Ok(CompiledScene {
        inputs,
        ..compiled(source, loaded.world, counter, model, warnings, t_load)
    })
}

fn compiled(
    source: &SceneSource,
    world: yari::model::World,
    counter: PrimitivesBuilder,
    model: Vec<u8>,
    mut warnings: Vec<String>,
    t_load: Instant,
) -> CompiledScene {
    warnings.extend(dropped_lines(source, counter.dropped()));
    let counts = counter.counts();
    CompiledScene {
        source: source.clone(),
        model,
        summary: SceneSummary {
            objects: counter.objects(),
            primitives: counts.primitives,
            unbounded: counts.unbounded,
            resolution: world.resolution,
            samples: world.samples,
            target_error: world.target_error,
        },
        warnings,
        load_s: t_load.elapsed().as_secs_f64(),
        inputs: Vec::new(),
    }
}

/// Streams the scene of `source` (a text scene, or the built-in one) to `out`, object by
/// object.
fn stream(
    source: &SceneSource,
    table: &ColourTable,
    out: &mut dyn FnMut(&[Surface], Object),
) -> Result<yari::load::Loaded, SceneLoadError> {
    Ok(match source {
        SceneSource::File(p) => yari::load::stream_path(p, table, out)?,
        SceneSource::Builtin => yari::load::stream_str(
            "built-in example",
            DEFAULT_SCENE,
            InputKind::Yari,
            table,
            out,
        )?,
    })
}

/// The compiler's warnings, as one block ready to print (none when it had nothing to say).
fn compiler_warnings(loaded: &yari::load::Loaded) -> Vec<String> {
    let compiler = loaded.render_warnings();
    if compiler.trim().is_empty() {
        Vec::new()
    } else {
        vec![compiler.trim_end().to_string()]
    }
}

/// One warning line per object dropped as degenerate.
fn dropped_lines(source: &SceneSource, dropped: &[Dropped]) -> Vec<String> {
    let name = source.display_name();
    dropped
        .iter()
        .map(|d| {
            format!(
                "sunray: warning: {name}: object {} dropped: {}",
                d.object, d.reason
            )
        })
        .collect()
}

/// True when the file at `path` starts like a compiled model (whatever its name).
fn is_model_file(path: &Path) -> bool {
    let mut magic = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .is_ok_and(|_| yari::modelfile::has_magic(&magic))
}

fn model_error(source: yari::modelfile::ModelFileError, path: &str) -> SceneLoadError {
    SceneLoadError::Scene(LoadError::Model {
        path: PathBuf::from(path),
        source,
    })
}

/// A compiled model file, decoded as a stream into the scene's primitives.
fn load_model_file(
    source: &SceneSource,
    path: &Path,
    t_load: Instant,
) -> Result<LoadedScene, SceneLoadError> {
    let io = |e: std::io::Error| {
        SceneLoadError::Scene(LoadError::Io {
            path: path.to_path_buf(),
            source: e,
        })
    };
    let mut file = std::io::BufReader::new(std::fs::File::open(path).map_err(io)?);
    let scene =
        Scene::read_model(&mut file).map_err(|e| model_error(e, &path.display().to_string()))?;
    // Decoding and building the primitives go together: all of it counts as loading.
    let load_s = t_load.elapsed().as_secs_f64();
    Ok(finish(source, scene, Vec::new(), load_s, Instant::now()))
}

fn finish(
    source: &SceneSource,
    scene: Scene,
    mut warnings: Vec<String>,
    load_s: f64,
    t_prepare: Instant,
) -> LoadedScene {
    let prepare_s = t_prepare.elapsed().as_secs_f64();
    warnings.extend(dropped_lines(source, &scene.dropped));
    LoadedScene {
        source: source.clone(),
        scene,
        warnings,
        load_s,
        prepare_s,
    }
}

#[cfg(test)]
mod counting_tests;
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scene_argument_names_a_file_or_the_builtin_scene() {
        assert_eq!(
            SceneSource::from_arg(Path::new(BUILTIN)),
            SceneSource::Builtin
        );
        assert_eq!(SceneSource::from_arg(Path::new("")), SceneSource::Builtin);
        let f = SceneSource::from_arg(Path::new("dir/king.yari"));
        assert_eq!(f.path(), Some(Path::new("dir/king.yari")));
        assert_eq!(f.default_output(), PathBuf::from("king.png"));
        assert_eq!(
            SceneSource::Builtin.default_output(),
            PathBuf::from("example.png")
        );
        assert_eq!(
            SceneSource::from_remembered(&SceneSource::Builtin.remembered()),
            SceneSource::Builtin
        );
        assert!(Path::new(&f.remembered()).is_absolute());
    }

    #[test]
    fn the_builtin_scene_loads_without_warnings() {
        let l = load(&SceneSource::Builtin, None).unwrap();
        assert!(l.warnings.is_empty(), "{:?}", l.warnings);
        assert!(!l.scene.prims.is_empty());
    }
}
