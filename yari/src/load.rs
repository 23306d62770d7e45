//! Loading a scene from a file of any supported kind into a compiled [`World`].
//!
//! A YARI scene's `mesh(file = ...)` statements read their files as it is compiled, relative
//! to the YARI file's folder ([`Loaded::meshes`], [`Loaded::inputs`]).
//!
//! The kind is found from the content and the extension: a file that starts with the model
//! file magic is a compiled model ([`crate::modelfile`]); otherwise `.yari` is YARI,
//! `.nff` is NFF, `.off` is OFF (all three parsed and compiled), `.obj`, `.ply`, `.gltf` and
//! `.glb` are meshes
//! ([`crate::mesh`], framed and compiled), and `.srw` is a model file.
//!
//! Every kind is read as a stream ([`stream_path`]): each object goes to the caller as soon
//! as it is compiled or decoded, so a renderer builds its own geometry without the world's
//! objects ever being held whole. NFF, OFF and YARI are read in one pass, straight from the
//! file to the compiler (YARI through a window of its text around the statement being
//! parsed; each item of its syntax tree is freed once compiled). No text is kept: the lines that diagnostics point at are
//! read again to show them ([`Source::excerpt`]).

use crate::colour::ColourTable;
use crate::compile::{CompileStream, MeshRead, ObjectSink};
use crate::diag::{Diagnostic, Diagnostics, SceneError};
use crate::lines::{TextFailure, TextLines};
use crate::mesh::{MeshError, MeshKind, MeshSummary, ToYari};
use crate::model::World;
use crate::modelfile::{self, ModelFileError};
use crate::span::Source;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// What kind of file a scene comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    /// YARI text (`.yari`), parsed and compiled.
    Yari,
    /// Haines's Neutral File Format (`.nff`), converted to YARI and compiled.
    Nff,
    /// Object File Format (`.off`), a polygon mesh converted to YARI and compiled.
    Off,
    /// Wavefront OBJ (`.obj`), with its MTL materials, framed and compiled.
    Obj,
    /// PLY (`.ply`), ASCII or binary, framed and compiled.
    Ply,
    /// glTF 2.0 (`.gltf`, `.glb`), framed and compiled.
    Gltf,
    /// A compiled model file.
    Model,
}

impl InputKind {
    /// The kind named by a path's extension (case ignored), if any.
    pub fn from_extension(path: &Path) -> Option<InputKind> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "yari" => InputKind::Yari,
            "nff" => InputKind::Nff,
            "off" => InputKind::Off,
            "obj" => InputKind::Obj,
            "ply" => InputKind::Ply,
            "gltf" | "glb" => InputKind::Gltf,
            e if e == modelfile::EXTENSION => InputKind::Model,
            _ => return None,
        })
    }

    /// The mesh format of this kind, if it is one.
    pub fn mesh(self) -> Option<MeshKind> {
        match self {
            InputKind::Obj => Some(MeshKind::Obj),
            InputKind::Ply => Some(MeshKind::Ply),
            InputKind::Gltf => Some(MeshKind::Gltf),
            _ => None,
        }
    }
}

/// A loaded scene.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The compiled world.
    pub world: World,
    /// What the file was.
    pub kind: InputKind,
    /// Warnings from the compiler (empty for a model file).
    pub warnings: Diagnostics,
    /// The text the warnings point into (`None` for a model file).
    pub source: Option<Source>,
    /// For a mesh file: what it held (counts and bounds).
    pub mesh: Option<MeshSummary>,
    /// For a YARI scene: the mesh files its `mesh` statements placed, in order.
    pub meshes: Vec<MeshRead>,
}

impl Loaded {
    /// The files other than the scene file that its world was made from: the meshes a YARI
    /// scene placed, and the material libraries and buffers of every mesh. A copy of the
    /// world made before is stale when one of them has changed.
    pub fn inputs(&self) -> Vec<PathBuf> {
        let mut files = Vec::new();
        for m in &self.meshes {
            files.push(m.path.clone());
            files.extend(m.summary.companions.iter().cloned());
        }
        if let Some(m) = &self.mesh {
            files.extend(m.companions.iter().cloned());
        }
        files
    }

    /// The warnings rendered as `file:line:col: warning: ...` with carets; for a mesh file
    /// (whose faces the compiler sees without a place) `file: warning: ...` once per message,
    /// with how many faces it was said of.
    pub fn render_warnings(&self) -> String {
        match (&self.source, &self.mesh) {
            (Some(src), Some(_)) => summarized(&src.name, &self.warnings),
            (Some(src), None) => self.warnings.render(src),
            (None, _) => String::new(),
        }
    }
}

/// A scene that could not be loaded. Display gives the whole message (for a bad scene, every
/// diagnostic with its `file:line:col` and caret).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LoadError {
    /// The file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why it could not be read.
        source: std::io::Error,
    },
    /// A scene file (not a model file) that is not UTF-8.
    #[error("{}: not a text file (not UTF-8)", path.display())]
    NotText {
        /// The file.
        path: PathBuf,
    },
    /// Neither the model file magic nor a known extension.
    #[error("{}: unknown scene format; expected a .yari, .nff, .off, .obj, .ply, .gltf or .glb scene or a .srw model", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The scene does not parse or compile; the error holds every diagnostic.
    #[error("{}", .0.to_string().trim_end())]
    Scene(#[from] SceneError),
    /// A mesh file that cannot be read: one line with the file and the line or byte.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A model file that is damaged, of another version, or breaks the compiler's guarantees.
    #[error("{}: {source}", path.display())]
    Model {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        source: ModelFileError,
    },
}

/// Loads and compiles (or reads, for a model file) the scene at `path`.
pub fn load_path(path: &Path, colours: &ColourTable) -> Result<Loaded, LoadError> {
    let mut objects = Vec::new();
    let mut loaded = stream_path(path, colours, &mut |_, o| objects.push(o))?;
    loaded.world.objects = objects;
    Ok(loaded)
}

/// Loads and compiles (or reads, for a model file) the scene at `path` as a stream: each
/// object goes to `out` as soon as it is made, with the surfaces so far; the world returned
/// has no objects (its features count them). The objects handed over before an error are
/// not to be used.
pub fn stream_path(
    path: &Path,
    colours: &ColourTable,
    out: &mut ObjectSink<'_>,
) -> Result<Loaded, LoadError> {
    let io = |source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut input = BufReader::with_capacity(1 << 16, std::fs::File::open(path).map_err(io)?);
    let kind = if modelfile::has_magic(input.fill_buf().map_err(io)?) {
        InputKind::Model
    } else {
        InputKind::from_extension(path).ok_or_else(|| LoadError::UnknownFormat {
            path: path.to_path_buf(),
        })?
    };
    if kind == InputKind::Model {
        let world = modelfile::read_stream(&mut input, &mut |head, _, o| out(&head.surfaces, o))
            .map_err(|source| LoadError::Model {
                path: path.to_path_buf(),
                source,
            })?;
        return Ok(loaded(world, kind, Diagnostics::default(), None));
    }
    let name = path.display().to_string();
    if let Some(mesh) = kind.mesh() {
        return compile_mesh(mesh, kind, path, &name, &mut input, colours, out);
    }
    let mut lines = TextLines::new(input);
    let compiled = compile_text(&mut lines, kind, colours, folder_of(path), out);
    if let Some(failure) = lines.failure() {
        return Err(match failure {
            TextFailure::Io(source) => io(source),
            _ => LoadError::NotText {
                path: path.to_path_buf(),
            },
        });
    }
    let excerpt = |diags: &Diagnostics| -> Result<Source, LoadError> {
        let offsets: Vec<u32> = diags
            .items
            .iter()
            .flat_map(|d| [d.span.start, d.span.end])
            .collect();
        if offsets.is_empty() {
            return Ok(Source::new(name.as_str(), ""));
        }
        let file = std::fs::File::open(path).map_err(io)?;
        Source::excerpt(name.as_str(), BufReader::new(file), &offsets).map_err(io)
    };
    match compiled {
        Ok((world, warnings, meshes)) => {
            let source = excerpt(&warnings)?;
            Ok(Loaded {
                meshes,
                ..loaded(world, kind, warnings, Some(source))
            })
        }
        Err(diagnostics) => Err(SceneError {
            source_text: excerpt(&diagnostics)?,
            diagnostics,
        }
        .into()),
    }
}

/// `file: warning: MESSAGE` once per distinct message, in the order first said, with a count
/// when said more than once.
fn summarized(name: &str, diags: &Diagnostics) -> String {
    let mut said: Vec<(&str, usize)> = Vec::new();
    for d in diags.warnings() {
        match said.iter_mut().find(|(m, _)| *m == d.message) {
            Some((_, n)) => *n += 1,
            None => said.push((&d.message, 1)),
        }
    }
    said.iter()
        .map(|(m, n)| match n {
            1 => format!("{name}: warning: {m}\n"),
            n => format!("{name}: warning: {m} ({n} faces)\n"),
        })
        .collect()
}

fn loaded(world: World, kind: InputKind, warnings: Diagnostics, source: Option<Source>) -> Loaded {
    Loaded {
        world,
        kind,
        warnings,
        source,
        mesh: None,
        meshes: Vec::new(),
    }
}

/// The folder of the scene file `path`, where its relative mesh files are found (empty, the
/// current folder, for a bare file name). The modeler finds a project's mesh files the same
/// way.
pub fn folder_of(path: &Path) -> &Path {
    path.parent().unwrap_or(Path::new(""))
}

/// Reads and compiles the mesh `input` (the file `path`, called `name`), each face as soon
/// as it is read, framed by [`crate::mesh::frame`]. The compiler's diagnostics have no place
/// in the file (they come with its name and the compiler's words).
fn compile_mesh(
    mesh: MeshKind,
    kind: InputKind,
    path: &Path,
    name: &str,
    input: &mut dyn BufRead,
    colours: &ColourTable,
    out: &mut ObjectSink<'_>,
) -> Result<Loaded, LoadError> {
    let mut compiler = CompileStream::new(colours);
    let mut to_yari = ToYari::default();
    let summary = crate::mesh::read_each(mesh, path, input, &mut |face| {
        to_yari.face(face, &mut |item| compiler.item(&item, &mut *out))
    })?;
    let view = crate::mesh::frame::view(&summary.bounds);
    let source = Source::new(name, "");
    match compiler.finish(&view) {
        Ok((world, mut warnings)) => {
            if summary.skipped_primitives > 0 {
                let n = summary.skipped_primitives;
                let what = if n == 1 { "primitive" } else { "primitives" };
                warnings.push(Diagnostic::warning(
                    crate::span::Span::default(),
                    format!("{n} {what} of points or lines left out: only faces are rendered"),
                ));
            }
            Ok(Loaded {
                mesh: Some(summary),
                ..loaded(world, kind, warnings, Some(source))
            })
        }
        // The compiler refused a face: no place in the file to show, so its first words.
        Err(diagnostics) => {
            let first = diagnostics.errors().next().map(|d| d.message.clone());
            Err(MeshError::new(
                path,
                crate::mesh::Place::File,
                format!(
                    "a face cannot be compiled: {}",
                    first.unwrap_or_else(|| "no reason given".into())
                ),
            )
            .into())
        }
    }
}

/// Parses and compiles scene text of a given kind; `name` is the file name in messages.
/// [`InputKind::Model`] is not text: it gives [`LoadError::UnknownFormat`].
pub fn load_str(
    name: &str,
    text: impl Into<String>,
    kind: InputKind,
    colours: &ColourTable,
) -> Result<Loaded, LoadError> {
    let mut objects = Vec::new();
    let mut loaded = stream_str(name, text, kind, colours, &mut |_, o| objects.push(o))?;
    loaded.world.objects = objects;
    Ok(loaded)
}

/// [`load_str`] as a stream: each object goes to `out` (see [`stream_path`]).
pub fn stream_str(
    name: &str,
    text: impl Into<String>,
    kind: InputKind,
    colours: &ColourTable,
    out: &mut ObjectSink<'_>,
) -> Result<Loaded, LoadError> {
    if kind == InputKind::Model {
        return Err(LoadError::UnknownFormat {
            path: PathBuf::from(name),
        });
    }
    let src = Source::new(name, text);
    if let Some(mesh) = kind.mesh() {
        let mut input = src.text.as_bytes();
        return compile_mesh(mesh, kind, Path::new(name), name, &mut input, colours, out);
    }
    let mut lines = TextLines::new(src.text.as_bytes());
    match compile_text(&mut lines, kind, colours, folder_of(Path::new(name)), out) {
        Ok((world, warnings, meshes)) => Ok(Loaded {
            meshes,
            ..loaded(world, kind, warnings, Some(src))
        }),
        Err(diagnostics) => Err(SceneError {
            source_text: src,
            diagnostics,
        }
        .into()),
    }
}

/// Reads and compiles the text of `lines`: the world without its objects (they went to
/// `out`), the warnings and the meshes a YARI scene placed (relative files found in
/// `folder`), or every diagnostic. The NFF and OFF readers warn too (a `pp`
/// vertex with a zero normal, say): their warnings come first, then the compiler's; when
/// the reader finds an error only its diagnostics are given, and when the compiler does
/// only the compiler's.
fn compile_text<R: BufRead>(
    lines: &mut TextLines<R>,
    kind: InputKind,
    colours: &ColourTable,
    folder: &Path,
    out: &mut ObjectSink<'_>,
) -> Result<(World, Diagnostics, Vec<MeshRead>), Diagnostics> {
    let mut compiler = CompileStream::new(colours).meshes_from(folder);
    let (view, mut warnings) = match kind {
        InputKind::Nff => {
            let mut mapping = crate::nff::Mapping::default();
            let warnings = crate::nff::read_each(lines, &mut |e| {
                if let Some(item) = mapping.entity(e) {
                    compiler.item(&item, &mut *out);
                }
            })?;
            (mapping.view(), warnings)
        }
        InputKind::Off => {
            crate::off::read_each(lines, &mut |item| compiler.item(&item, &mut *out))?
        }
        _ => {
            // YARI (meshes and models never come here). Each item of the world block is compiled as soon as it is parsed, and freed;
            // the text is read as the parse needs it, never held whole.
            let view = crate::parse::parse_each_streamed(lines, &mut |item| {
                compiler.item(&item, &mut *out)
            });
            lines.drain();
            (view?, Diagnostics::default())
        }
    };
    let meshes = compiler.take_meshes();
    let (world, compiled) = compiler.finish(&view)?;
    warnings.items.extend(compiled.items);
    Ok((world, warnings, meshes))
}

#[cfg(test)]
mod mesh_tests;
#[cfg(test)]
mod stream_tests;
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_render_with_file_line_column_and_caret() {
        let e = load_str(
            "bad.yari",
            "begin\n  sphere(center=0,0,0; radius=1)\nend\n",
            InputKind::Yari,
            &ColourTable::builtin(),
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "bad.yari:2:33: error: expected `;` after `sphere(...)`, found `end`\n    sphere(center=0,0,0; radius=1)\n                                  ^"
        );
    }

    #[test]
    fn nff_reader_warnings_reach_the_caller_with_their_place() {
        let nff = "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 30\nhither 1\nresolution 4 4\n\
                   f 1 1 1 1.5 0 1 0 1\ns 0 0 0 1\n";
        let loaded = load_str("w.nff", nff, InputKind::Nff, &ColourTable::builtin()).unwrap();
        // The reader's (Kd out of range), then the compiler's (no light).
        let shown = loaded.render_warnings();
        assert_eq!(loaded.warnings.warnings().count(), 2, "{shown}");
        assert!(shown.starts_with("w.nff:8:9: warning: Kd = 1.5"), "{shown}");
        assert!(shown.contains("w.nff:1:1: warning: no `light`"), "{shown}");
    }

    #[test]
    fn dispatches_on_magic_and_extension() {
        let dir = std::env::temp_dir().join(format!("yari-load-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let scene = "resolution(4,4); camera(position=0,0,5; at=0,0,0; up=0,1,0; angle=20); light(position=0,5,0; color=white);\nbegin sphere(center=0,0,0; radius=1); end\n";
        let yari = dir.join("a.yari");
        std::fs::write(&yari, scene).unwrap();
        let loaded = load_path(&yari, &ColourTable::builtin()).unwrap();
        assert_eq!(
            (loaded.kind, loaded.world.features.spheres),
            (InputKind::Yari, 1)
        );
        assert!(loaded.warnings.items.is_empty());
        // A model file is recognised by its magic whatever its name.
        let model = dir.join("model.bin");
        modelfile::save_atomic(&loaded.world, &model).unwrap();
        let again = load_path(&model, &ColourTable::builtin()).unwrap();
        assert_eq!(
            (again.kind, &again.world),
            (InputKind::Model, &loaded.world)
        );
        let srw = dir.join("broken.srw");
        std::fs::write(&srw, b"not a model").unwrap();
        assert!(matches!(
            load_path(&srw, &ColourTable::builtin()),
            Err(LoadError::Model { .. })
        ));
        let txt = dir.join("a.txt");
        std::fs::write(&txt, scene).unwrap();
        assert!(matches!(
            load_path(&txt, &ColourTable::builtin()),
            Err(LoadError::UnknownFormat { .. })
        ));
        assert!(matches!(
            load_path(&dir.join("missing.yari"), &ColourTable::builtin()),
            Err(LoadError::Io { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
