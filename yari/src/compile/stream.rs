//! Compiling a scene as a stream: the world block's items are compiled one at a time
//! ([`CompileStream::item`]), each object handed over as soon as it is built, and the
//! preamble at the end ([`CompileStream::finish`]), so a reader that goes through its file
//! once never holds the syntax tree or the world's objects whole.
//!
//! The world block does not depend on the preamble (surfaces, transformations and objects
//! come from the block alone), and the preamble's diagnostics are put before the block's,
//! so the result is what [`super::compile`] gives for the whole tree: it is this stream fed
//! the tree's items.

use super::stack::State;
use super::{Compiler, MAX_WARNINGS};
use crate::ast::{BodyItem, Spanned, ViewStmt};
use crate::colour::ColourTable;
use crate::diag::{Diagnostics, Severity};
use crate::model::{Features, Object, Shape, Surface, World};

/// Where compiled objects go: each with the surfaces found so far (its own among them).
pub type ObjectSink<'s> = dyn FnMut(&[Surface], Object) + 's;

/// A scene being compiled item by item.
pub struct CompileStream<'a> {
    body: Compiler<'a>,
    state: State,
    surfaces: Vec<Surface>,
    features: Features,
}

impl<'a> CompileStream<'a> {
    /// A compiler at the start of the world block, looking colour names up in `colours`.
    pub fn new(colours: &'a ColourTable) -> CompileStream<'a> {
        CompileStream {
            body: Compiler::new(colours),
            state: State::new(),
            surfaces: Vec::new(),
            features: Features::default(),
        }
    }

    /// Finds the files of relative `mesh(file = ...)` statements in `folder` (the YARI
    /// file's) instead of the current directory.
    pub fn meshes_from(mut self, folder: &std::path::Path) -> CompileStream<'a> {
        self.body.folder = Some(folder.to_path_buf());
        self
    }

    /// The mesh files placed so far, taken out of the stream (for [`Self::finish`]'s caller).
    pub fn take_meshes(&mut self) -> Vec<super::MeshRead> {
        std::mem::take(&mut self.body.meshes)
    }

    /// Compiles the next item of the world block, handing each object it makes to `out`.
    pub fn item(&mut self, item: &Spanned<BodyItem>, out: &mut ObjectSink<'_>) {
        let features = &mut self.features;
        let mut counted = |surfaces: &[Surface], o: Object| {
            count_object(features, &o);
            out(surfaces, o)
        };
        self.body
            .item(item, &mut self.state, 1, &mut self.surfaces, &mut counted);
    }

    /// Compiles the preamble and ends the scene: the world without its objects (they went
    /// to the sink; its features count them) and the warnings, or every diagnostic when
    /// there is an error.
    pub fn finish(self, view: &[Spanned<ViewStmt>]) -> Result<(World, Diagnostics), Diagnostics> {
        let mut c = Compiler::new(self.body.colours);
        let mut world = c.preamble(view);
        for d in self.body.diags.items {
            match d.severity {
                Severity::Error => c.diags.push(d),
                Severity::Warning => c.warn(d.span, d.message),
            }
        }
        // Warnings the block counted but did not keep still count.
        c.warnings += self.body.warnings.saturating_sub(MAX_WARNINGS);
        c.finish_warnings();
        world.surfaces = self.surfaces;
        world.features = finish_features(self.features, &world);
        if c.diags.has_errors() {
            Err(c.diags)
        } else {
            Ok((world, c.diags))
        }
    }
}

/// Adds one object to the counts of `features`.
pub(crate) fn count_object(f: &mut Features, o: &Object) {
    match o.shape {
        Shape::Sphere { .. } => f.spheres += 1,
        Shape::Ellipsoid { .. } => f.ellipsoids += 1,
        Shape::Polygon { .. } | Shape::SmoothPolygon { .. } => f.polygons += 1,
        Shape::Quadric(_) => f.quadrics += 1,
    }
    f.motion_blur |= o.motion != glam::DVec3::ZERO;
}

/// `f` (the objects' counts) with the flags of `world`'s surfaces, lights and camera.
pub(crate) fn finish_features(mut f: Features, world: &World) -> Features {
    for s in &world.surfaces {
        f.textures |= s.texture.is_some();
        f.transparency |= s.kst() > 0.0;
        f.reflection |= s.ksr() > 0.0;
        f.gloss |= s.gloss > 0.0 && s.ksr() > 0.0;
        f.translucency |= s.translucency > 0.0 && s.kst() > 0.0;
    }
    f.area_lights = world.lights.iter().any(|l| l.radius > 0.0);
    f.depth_of_field = world.camera.aperture > 0.0;
    f.antialiasing = world.samples > 1;
    f
}
