//! A scene ready to render: the compiled model and its primitives. [`load`] says where a
//! scene comes from (a file or the built-in example) and loads it; [`summary`] is what a farm
//! job needs of it besides the model.

pub mod load;
pub mod summary;

use crate::geometry::primitive::Dropped;
use crate::geometry::primitives::PrimitivesBuilder;
use crate::geometry::Primitives;
use yari::model::{Surface, World};
use yari::modelfile::{ModelFileError, ModelStream};

/// A scene ready to render: the compiled world and the primitives built from it.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The compiled model: camera, lights, surfaces, textures; its objects are not kept
    /// (they are [`Scene::prims`] now; [`Scene::objects`] says how many there were).
    pub world: World,
    /// The primitives the accelerators index, polygons already triangulated.
    pub prims: Primitives,
    /// How many objects the model had.
    pub objects: usize,
    /// Objects dropped as degenerate (to warn about).
    pub dropped: Vec<Dropped>,
    /// Used for a primitive whose surface index is out of range.
    default_surface: Surface,
}

impl Scene {
    /// Builds the primitives of `world`'s objects (freeing each once it is built), dropping
    /// (and listing) degenerate objects.
    pub fn new(mut world: World) -> Scene {
        let objects = std::mem::take(&mut world.objects);
        let mut builder = PrimitivesBuilder::new();
        for obj in objects {
            builder.add(&world.surfaces, &obj);
        }
        Scene::built(world, builder)
    }

    /// The scene of a model file read from `input` as a stream: each object becomes
    /// primitives as soon as it is decoded, so the model is never held whole.
    pub fn read_model(input: &mut impl std::io::Read) -> Result<Scene, ModelFileError> {
        let mut builder = PrimitivesBuilder::new();
        let world = yari::modelfile::read_stream(input, &mut |head, _, obj| {
            builder.add(&head.surfaces, &obj)
        })?;
        Ok(Scene::built(world, builder))
    }

    fn built(world: World, builder: PrimitivesBuilder) -> Scene {
        let objects = builder.objects();
        let (prims, dropped) = builder.finish();
        Scene::from_parts(world, prims, objects, dropped)
    }

    /// The scene of its parts (a prepared scene's, read back).
    pub fn from_parts(
        world: World,
        prims: Primitives,
        objects: usize,
        dropped: Vec<Dropped>,
    ) -> Scene {
        Scene {
            world,
            prims,
            objects,
            dropped,
            default_surface: Surface::default(),
        }
    }

    /// The surface of primitive `prim`.
    #[inline]
    pub fn surface(&self, prim: u32) -> &Surface {
        let s = self.prims.surface(prim) as usize;
        self.world.surfaces.get(s).unwrap_or(&self.default_surface)
    }
}

/// A scene being built from a model file whose bytes arrive in pieces (REM chunks): each
/// object becomes primitives as soon as it is decoded, so the model is never held whole.
#[derive(Default)]
pub struct SceneStream {
    stream: ModelStream,
    builder: PrimitivesBuilder,
}

impl SceneStream {
    /// A scene at the start of its model file.
    pub fn new() -> SceneStream {
        SceneStream::default()
    }

    /// Takes the next bytes of the model file.
    pub fn feed(&mut self, bytes: &[u8]) -> Result<(), ModelFileError> {
        let builder = &mut self.builder;
        self.stream
            .feed(bytes, &mut |head, _, obj| builder.add(&head.surfaces, &obj))
    }

    /// The scene, once the whole model file has arrived and checked.
    pub fn finish(self) -> Result<Scene, ModelFileError> {
        let world = self.stream.finish()?;
        Ok(Scene::built(world, self.builder))
    }
}
