//! The compiled world-space model (the output of `yc`): what a renderer loads.
//!
//! Everything is in world space with transformations already applied. Spheres stay exact:
//! a sphere under a similarity transform is a [`Shape::Sphere`]; under a non-uniform scale it
//! becomes an [`Shape::Ellipsoid`] with its exact affine map, never a mesh.
//! [`Features`] says what the scene uses so the renderer sets up only that.

use glam::{DAffine3, DVec3};
use serde::{Deserialize, Serialize};

/// A compiled scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct World {
    /// Width and height in pixels.
    pub resolution: [u32; 2],
    pub background: DVec3,
    pub ambient: DVec3,
    pub camera: Camera,
    pub lights: Vec<Light>,
    /// Samples per pixel requested by the scene (`samples(n)`); 1 = one ray per pixel centre.
    pub samples: u32,
    /// Distinct surfaces; objects refer to them by index.
    pub surfaces: Vec<Surface>,
    pub objects: Vec<Object>,
    pub features: Features,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    pub position: DVec3,
    pub at: DVec3,
    pub up: DVec3,
    /// Half angle of view in degrees, from the centre of the top pixel row to the centre of
    /// the bottom row, square pixels (the NFF convention with YARI's half angle).
    pub half_angle_deg: f64,
    /// Lens radius; 0 = pinhole.
    pub aperture: f64,
    /// Distance to the plane in focus.
    pub focus_distance: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    pub position: DVec3,
    pub color: DVec3,
    /// Radius of a spherical area light; 0 = point light.
    pub radius: f64,
}

/// Hall model surface (thesis Tables 3.1 and 3.2): ksr = 1 - kdr, kst = 1 - kdt.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Surface {
    pub color: DVec3,
    pub kdr: f64,
    pub kdt: f64,
    pub ka: f64,
    pub phong: f64,
    pub refract: f64,
    pub texture: Option<Texture>,
    /// Blur of reflections, half-angle spread in degrees (0 = mirror).
    pub gloss: f64,
    /// Blur of transmission, half-angle spread in degrees (0 = clear).
    pub translucency: f64,
    /// Transmissivity per unit length inside the object, in [0, 1]; 1 = no absorption.
    pub transmissivity: f64,
}

impl Default for Surface {
    /// The thesis's default object: a diffuse, solid, white surface.
    fn default() -> Surface {
        Surface {
            color: DVec3::ONE,
            kdr: 1.0,
            kdt: 1.0,
            ka: 1.0,
            phong: 1.0,
            refract: 1.0,
            texture: None,
            gloss: 0.0,
            translucency: 0.0,
            transmissivity: 1.0,
        }
    }
}

impl Surface {
    /// Specular reflection weight ksr = 1 - kdr (0 when opaque-diffuse).
    pub fn ksr(&self) -> f64 {
        (1.0 - self.kdr).clamp(0.0, 1.0)
    }
    /// Specular transmission weight kst = 1 - kdt (0 when solid).
    pub fn kst(&self) -> f64 {
        (1.0 - self.kdt).clamp(0.0, 1.0)
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Texture {
    pub kind: TextureKind,
    /// The second colour (wood's dark veins, marble's veins, ...).
    pub color: DVec3,
    /// Feature size along x, y, z in texture space.
    pub scale: DVec3,
    /// World space to texture (object) space, so textures stick to transformed objects.
    pub world_to_texture: DAffine3,
}

/// YARI texture ids. Id 1 is wood (thesis Appendix C.5); the others are ours, documented.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TextureKind {
    Wood = 1,
    Marble = 2,
    Bumps = 3,
    Turbulence = 4,
    Checker = 5,
}

impl TextureKind {
    pub fn from_id(id: u32) -> Option<TextureKind> {
        Some(match id {
            1 => TextureKind::Wood,
            2 => TextureKind::Marble,
            3 => TextureKind::Bumps,
            4 => TextureKind::Turbulence,
            5 => TextureKind::Checker,
            _ => return None,
        })
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Object {
    pub shape: Shape,
    /// Index into [`World::surfaces`].
    pub surface: u32,
    /// World-space displacement over the shutter interval [0, 1]; zero = static.
    pub motion: DVec3,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Shape {
    Sphere {
        center: DVec3,
        radius: f64,
    },
    /// The unit sphere at the origin mapped by `to_world` (a sphere under a non-similarity).
    Ellipsoid {
        to_world: DAffine3,
    },
    /// A planar polygon, 3 or more vertices, convex or concave, in order.
    Polygon {
        vertices: Vec<DVec3>,
    },
    Quadric(Quadric),
}

/// A general quadric surface x^T Q x = 0 in homogeneous coordinates x = (x, y, z, 1), where
/// the symmetric matrix Q is stored as its upper triangle row by row:
///
/// ```text
/// q = [a, b, c, d, e, f, g, h, i, j]      Q = | a b c d |
///                                             | b e f g |
///  a x^2 + 2b xy + 2c xz + 2d x               | c f h i |
///  + e y^2 + 2f yz + 2g y                     | d g i j |
///  + h z^2 + 2i z + j = 0
/// ```
///
/// YARI's `quadric(a b c d e f g h i j)` uses the same order, so a transform M maps Q to
/// M^-T Q M^-1 exactly. `clip` keeps only the points inside every half-space.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quadric {
    pub q: [f64; 10],
    pub clip: Vec<HalfSpace>,
}

/// The points p with `normal . p <= offset`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HalfSpace {
    pub normal: DVec3,
    pub offset: f64,
}

/// What a scene uses, so the renderer builds and pays for only those paths.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Features {
    pub spheres: usize,
    pub ellipsoids: usize,
    pub polygons: usize,
    pub quadrics: usize,
    pub textures: bool,
    /// Some surface has kdt < 1 (transmits specularly).
    pub transparency: bool,
    /// Some surface has kdr < 1 (reflects specularly).
    pub reflection: bool,
    pub area_lights: bool,
    pub gloss: bool,
    pub translucency: bool,
    pub depth_of_field: bool,
    pub motion_blur: bool,
    /// More than one sample per pixel.
    pub antialiasing: bool,
}
