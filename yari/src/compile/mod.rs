//! The YARI compiler (the thesis's `yc`): a syntax tree to a world-space [`World`].
//!
//! Semantics (see `docs/yari.md`):
//! - Preamble: the last `resolution`, `background`, `ambient`, `camera`, `samples` and
//!   `target_error` win;
//!   lights accumulate. A missing camera or resolution gets [`DEFAULT_CAMERA`] /
//!   [`DEFAULT_RESOLUTION`] with a warning; background and ambient default to black.
//! - The graphics stack: transformations apply in the order written — a point is moved
//!   first by the earliest transformation in effect, then by later ones. `begin` saves and
//!   `end` restores the transformation, the current attribute AND the motion vector.
//! - `attribute(...)` replaces the whole surface; unspecified fields take
//!   [`crate::model::Surface::default`]. Surfaces are deduplicated into [`World::surfaces`].
//!
//! # Layout
//! - this file: entry point, preamble, warnings, the world block's items.
//! - [`stream`](mod@stream): compiling item by item, each object handed over as it is made.
//! - `stack`: the graphics state (transformation, attribute, motion) and transformations.
//! - `surface`: attributes to surfaces, deduplication, colour lookup.
//! - `shapes`: primitives to world-space shapes.
//! - `mesh`: the `mesh(file = ...)` statement, a mesh file's faces placed in the scene.

mod mesh;
mod shapes;
mod stack;
pub mod stream;
mod surface;
#[cfg(test)]
mod tests;

use crate::ast::{Block, BodyItem, CameraDef, ColorSpec, Scene, Spanned, ViewStmt};
use crate::colour::ColourTable;
use crate::diag::{Diagnostic, Diagnostics, Severity};
use crate::model::{Camera, Features, Light, Object, Surface, World};
use crate::span::Span;
use glam::DVec3;
pub use mesh::MeshRead;
use stack::State;
use std::path::PathBuf;
pub use stream::{CompileStream, ObjectSink};

/// The resolution used when the scene gives none.
pub const DEFAULT_RESOLUTION: [u32; 2] = [512, 512];
/// The camera used when the scene gives none: `position = 0,0,10 ; at = 0,0,0 ; up = 0,1,0 ;
/// angle = 22.5`.
pub const DEFAULT_CAMERA: ([f64; 3], [f64; 3], [f64; 3], f64) =
    ([0.0, 0.0, 10.0], [0.0; 3], [0.0, 1.0, 0.0], 22.5);
/// At most this many warnings are kept; the rest are counted in one last warning.
pub const MAX_WARNINGS: usize = 100;

/// A compiled scene and the warnings about it.
#[derive(Clone, Debug, PartialEq)]
pub struct Compiled {
    /// The world, ready to render or write as a model file.
    pub world: World,
    /// Only warnings (at most [`MAX_WARNINGS`] and one that counts the rest).
    pub warnings: Diagnostics,
}

/// Compiles a scene. On failure the diagnostics hold the errors (and any warnings). A `mesh`
/// statement's relative file is found in the current directory; [`crate::load`] finds it
/// beside the YARI file, [`compile_in`] in a folder given.
pub fn compile(scene: &Scene, colours: &ColourTable) -> Result<Compiled, Diagnostics> {
    compile_stream(scene, CompileStream::new(colours))
}

/// [`compile`], finding the files of relative `mesh` statements in `folder`.
pub fn compile_in(
    scene: &Scene,
    colours: &ColourTable,
    folder: &std::path::Path,
) -> Result<Compiled, Diagnostics> {
    compile_stream(scene, CompileStream::new(colours).meshes_from(folder))
}

fn compile_stream(scene: &Scene, mut stream: CompileStream) -> Result<Compiled, Diagnostics> {
    let mut objects = Vec::new();
    for item in &scene.body.items {
        stream.item(item, &mut |_, o| objects.push(o));
    }
    let (mut world, warnings) = stream.finish(&scene.view)?;
    world.objects = objects;
    Ok(Compiled { world, warnings })
}

pub(crate) struct Compiler<'a> {
    colours: &'a ColourTable,
    pub(crate) diags: Diagnostics,
    warnings: usize,
    surfaces: surface::Dedup,
    /// The folder relative mesh files are found in (the YARI file's); none: the current one.
    folder: Option<PathBuf>,
    /// The mesh files placed so far.
    meshes: Vec<MeshRead>,
    /// While a mesh's faces are compiled: what is said of them, gathered.
    faces: Option<mesh::FaceMessages>,
}

impl<'a> Compiler<'a> {
    fn new(colours: &'a ColourTable) -> Compiler<'a> {
        Compiler {
            colours,
            diags: Diagnostics::default(),
            warnings: 0,
            surfaces: surface::Dedup::default(),
            folder: None,
            meshes: Vec::new(),
            faces: None,
        }
    }

    pub(crate) fn error(&mut self, span: Span, message: impl Into<String>) {
        if let Some(faces) = &mut self.faces {
            return faces.add(Severity::Error, message.into());
        }
        self.diags.push(Diagnostic::error(span, message));
    }

    pub(crate) fn warn(&mut self, span: Span, message: impl Into<String>) {
        if let Some(faces) = &mut self.faces {
            return faces.add(Severity::Warning, message.into());
        }
        self.warnings += 1;
        if self.warnings <= MAX_WARNINGS {
            self.diags.push(Diagnostic::warning(span, message));
        }
    }

    fn finish_warnings(&mut self) {
        if self.warnings > MAX_WARNINGS {
            let more = self.warnings - MAX_WARNINGS;
            self.diags.push(Diagnostic::warning(
                Span::default(),
                format!("{more} more warnings not shown"),
            ));
        }
    }

    /// A colour as RGB; an unknown name is an error (and black stands in).
    pub(crate) fn colour(&mut self, spec: &Spanned<ColorSpec>) -> DVec3 {
        match &spec.node {
            ColorSpec::Rgb(v) => {
                let c = DVec3::from_array(*v);
                if !c.is_finite() {
                    self.error(spec.span, "colour is not finite");
                }
                c
            }
            ColorSpec::Named(name) => match self.colours.get(name) {
                Some(c) => c,
                None => {
                    let hint = match self.colours.suggest(name) {
                        Some(s) => format!("; did you mean `{s}`?"),
                        None => String::new(),
                    };
                    self.error(spec.span, format!("unknown colour name `{name}`{hint}"));
                    DVec3::ZERO
                }
            },
        }
    }

    fn preamble(&mut self, view: &[Spanned<ViewStmt>]) -> World {
        let (mut resolution, mut camera, mut samples) = (None, None, None);
        let mut target_error = None;
        let (mut background, mut ambient) = (DVec3::ZERO, DVec3::ZERO);
        let mut lights = Vec::new();
        for stmt in view {
            let span = stmt.span;
            match &stmt.node {
                ViewStmt::Resolution(x, y) => {
                    if *x == 0 || *y == 0 {
                        self.error(
                            span,
                            format!("resolution must be at least 1x1, not {x}x{y}"),
                        );
                    }
                    resolution = Some([*x, *y]);
                }
                ViewStmt::Samples(n) => {
                    if *n == 0 {
                        self.error(span, "samples must be at least 1");
                    }
                    samples = Some(*n);
                }
                ViewStmt::TargetError(e) => {
                    if !(e.is_finite() && *e > 0.0) {
                        self.error(
                            span,
                            format!("target_error must be a number above 0 (linear radiance, 1 = white), not {e}"),
                        );
                    }
                    target_error = Some(*e);
                }
                ViewStmt::Background(c) => background = self.colour(c),
                ViewStmt::Ambient(c) => ambient = self.colour(c),
                ViewStmt::Light(l) => {
                    let color = self.colour(&l.color);
                    let position = self.finite_vec(l.position, span, "light position");
                    let radius = l.radius.unwrap_or(0.0);
                    if !(radius >= 0.0 && radius.is_finite()) {
                        self.error(
                            span,
                            format!("a light's radius must be 0 or more, not {radius}"),
                        );
                    }
                    lights.push(Light {
                        position,
                        color,
                        radius,
                    });
                }
                ViewStmt::Camera(c) => camera = Some((self.camera(c, span), span)),
            }
        }
        let resolution = resolution.unwrap_or_else(|| {
            let [w, h] = DEFAULT_RESOLUTION;
            self.warn(Span::default(), format!("no `resolution`; using {w}x{h}"));
            DEFAULT_RESOLUTION
        });
        let camera = match camera {
            Some((c, _)) => c,
            None => {
                let (p, a, u, angle) = DEFAULT_CAMERA;
                self.warn(
                    Span::default(),
                    format!(
                        "no `camera`; using camera(position = {},{},{}; at = {},{},{}; up = {},{},{}; angle = {angle})",
                        p[0], p[1], p[2], a[0], a[1], a[2], u[0], u[1], u[2]
                    ),
                );
                let def = CameraDef {
                    position: p,
                    at: a,
                    up: u,
                    angle,
                    aperture: None,
                    focus: None,
                };
                self.camera(&def, Span::default())
            }
        };
        if lights.is_empty() {
            self.warn(Span::default(), "no `light`; only ambient light will show");
        }
        World {
            resolution,
            background,
            ambient,
            camera,
            lights,
            samples: samples.unwrap_or(1),
            target_error,
            surfaces: Vec::new(),
            objects: Vec::new(),
            features: Features::default(),
        }
    }

    fn finite_vec(&mut self, v: [f64; 3], span: Span, what: &str) -> DVec3 {
        let v = DVec3::from_array(v);
        if !v.is_finite() {
            self.error(span, format!("{what} is not a finite number"));
        }
        v
    }

    fn camera(&mut self, c: &CameraDef, span: Span) -> Camera {
        let position = self.finite_vec(c.position, span, "camera position");
        let at = self.finite_vec(c.at, span, "camera `at`");
        let up = self.finite_vec(c.up, span, "camera `up`");
        let view = at - position;
        if up == DVec3::ZERO {
            self.error(span, "camera `up` must not be the zero vector");
        } else if view == DVec3::ZERO {
            self.error(span, "camera `at` must differ from its `position`");
        } else if view.cross(up).length() <= 1e-12 * view.length() * up.length()
            || !view.length().is_finite()
        {
            self.error(
                span,
                "camera `up` must not be parallel to the view direction (`at` - `position`)",
            );
        }
        if !(c.angle > 0.0 && c.angle < 90.0) {
            self.error(span, format!("camera `angle` (the half angle of view) must be between 0 and 90 degrees, not {}", c.angle));
        }
        let aperture = c.aperture.unwrap_or(0.0);
        if !(aperture >= 0.0 && aperture.is_finite()) {
            self.error(
                span,
                format!("camera `aperture` must be 0 or more, not {aperture}"),
            );
        }
        let focus_distance = c.focus.unwrap_or_else(|| view.length());
        if !(focus_distance > 0.0 && focus_distance.is_finite()) && view != DVec3::ZERO {
            self.error(
                span,
                format!("camera `focus` must be more than 0, not {focus_distance}"),
            );
        }
        Camera {
            position,
            at,
            up,
            half_angle_deg: c.angle,
            aperture,
            focus_distance,
        }
    }

    /// Compiles the items of a block in `state` (a copy of the enclosing state: `end`
    /// restores by dropping it). `depth` counts blocks, the world block being 1.
    fn block(
        &mut self,
        block: &Block,
        mut state: State,
        depth: usize,
        surfaces: &mut Vec<Surface>,
        out: &mut ObjectSink<'_>,
    ) {
        if depth > crate::parse::MAX_NESTING {
            self.error(
                block.span,
                format!(
                    "blocks are nested deeper than {} levels",
                    crate::parse::MAX_NESTING
                ),
            );
            return;
        }
        for item in &block.items {
            self.item(item, &mut state, depth, surfaces, out);
        }
    }

    /// Compiles one item of a block at `depth` in `state`, each object it makes going to
    /// `out` (its surface added to `surfaces` first).
    fn item(
        &mut self,
        item: &Spanned<BodyItem>,
        state: &mut State,
        depth: usize,
        surfaces: &mut Vec<Surface>,
        out: &mut ObjectSink<'_>,
    ) {
        match &item.node {
            BodyItem::Block(inner) => self.block(inner, state.clone(), depth + 1, surfaces, out),
            BodyItem::Attribute(fields) => state.set_attribute(self, fields, item.span),
            BodyItem::Transform(t) => state.apply(self, t, item.span),
            BodyItem::Mesh(m) => self.mesh(m, item.span, state, depth, surfaces, out),
            BodyItem::Primitive(p) => {
                if let Some(shape) = self.primitive(p, state, item.span) {
                    let surface = state.surface_index(self, surfaces, item.span);
                    let motion = state.motion;
                    out(
                        surfaces,
                        Object {
                            shape,
                            surface,
                            motion,
                        },
                    );
                }
            }
        }
    }
}

/// What a world uses: counts by kind and the flags of its surfaces, lights and camera.
pub fn features(world: &World) -> Features {
    let mut f = Features::default();
    for o in &world.objects {
        stream::count_object(&mut f, o);
    }
    stream::finish_features(f, world)
}
