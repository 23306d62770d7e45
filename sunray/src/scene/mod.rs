//! A scene ready to render: the compiled model and its primitives. [`load`] says where a
//! scene comes from (a file or the built-in example) and loads it.

pub mod load;

use crate::geometry::primitive::Dropped;
use crate::geometry::Primitive;
use yari::model::{Surface, World};

/// A scene ready to render: the compiled world and the primitives built from it.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The compiled model: camera, lights, surfaces, textures and objects.
    pub world: World,
    /// The primitives the accelerators index, polygons already triangulated.
    pub prims: Vec<Primitive>,
    /// Objects dropped as degenerate (to warn about).
    pub dropped: Vec<Dropped>,
    /// Used for a primitive whose surface index is out of range.
    default_surface: Surface,
}

impl Scene {
    /// Builds the primitives of `world`, dropping (and listing) degenerate objects.
    pub fn new(world: World) -> Scene {
        let (prims, dropped) = Primitive::build_all(&world);
        Scene {
            world,
            prims,
            dropped,
            default_surface: Surface::default(),
        }
    }

    /// The surface of primitive `prim`.
    #[inline]
    pub fn surface(&self, prim: u32) -> &Surface {
        let s = self.prims[prim as usize].surface as usize;
        self.world.surfaces.get(s).unwrap_or(&self.default_surface)
    }
}
