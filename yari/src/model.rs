//! The compiled world-space model (the output of `yc`): what a renderer loads.
//!
//! Everything is in world space with transformations already applied. Spheres stay exact:
//! a sphere under a similarity transform is a [`Shape::Sphere`]; under a non-uniform scale it
//! becomes an [`Shape::Ellipsoid`] with its exact affine map, never a mesh.
//! A polygon with vertex normals is a [`Shape::SmoothPolygon`].
//! [`Features`] says what the scene uses so the renderer sets up only that.
//! [`Camera::frame`] is the view frame the renderer shoots its eye rays from and the POV-Ray
//! export writes.

use glam::{DAffine3, DVec3};
use serde::{Deserialize, Serialize};

/// A compiled scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct World {
    /// Width and height in pixels.
    pub resolution: [u32; 2],
    /// Colour of rays that hit nothing, linear RGB.
    pub background: DVec3,
    /// Ambient light, linear RGB, scaled by each surface's `ka`.
    pub ambient: DVec3,
    /// The view; always valid after compiling (the default camera when the scene has none).
    pub camera: Camera,
    /// Point and spherical area lights, in the order written.
    pub lights: Vec<Light>,
    /// Samples per pixel requested by the scene (`samples(n)`); 1 = one ray per pixel centre.
    pub samples: u32,
    /// Distinct surfaces; objects refer to them by index.
    pub surfaces: Vec<Surface>,
    /// The target error requested by the scene (`target_error(E)`): each pixel rendered
    /// until the estimated standard error of its mean is at most E, instead of `samples`.
    /// (After `surfaces`: a version 3 model file's payload is this struct in postcard.)
    #[serde(default)]
    pub target_error: Option<f64>,
    /// The primitives in world space, in the order written.
    pub objects: Vec<Object>,
    /// What the scene uses; computed by [`crate::compile::features`].
    pub features: Features,
}

/// The camera in world space (thesis Fig. 2.1), checked by the compiler.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// The eye point (the lens centre when `aperture > 0`).
    pub position: DVec3,
    /// The point looked at; differs from `position`.
    pub at: DVec3,
    /// Which way is up in the image; not parallel to `at - position`.
    pub up: DVec3,
    /// Half angle of view in degrees, from the centre of the top pixel row to the centre of
    /// the bottom row, square pixels (the NFF convention with YARI's half angle).
    pub half_angle_deg: f64,
    /// Lens radius; 0 = pinhole.
    pub aperture: f64,
    /// Distance to the plane in focus.
    pub focus_distance: f64,
}

impl Camera {
    /// The view frame for an image `height` pixels high: what the renderer
    /// (`sunray::camera`) makes its eye rays from and the POV-Ray export ([`crate::pov`])
    /// writes, computed here once so that the two cannot drift apart. A degenerate view (eye
    /// at the look-at point, up parallel to the view) falls back to sane axes instead of NaNs.
    pub fn frame(&self, height: u32) -> CameraFrame {
        let forward = (self.at - self.position)
            .try_normalize()
            .unwrap_or(DVec3::NEG_Z);
        let right = forward
            .cross(self.up)
            .try_normalize()
            .unwrap_or_else(|| forward.any_orthonormal_vector());
        let up = right.cross(forward);
        let half = self.half_angle_deg.clamp(1e-6, 89.999).to_radians();
        let rows_between_centres = (height.max(2) - 1) as f64;
        let pixel = 2.0 * half.tan() / rows_between_centres;
        CameraFrame {
            forward,
            right,
            up,
            pixel,
        }
    }
}

/// A camera's orthonormal view frame and pixel size ([`Camera::frame`]). The half angle spans
/// from the image centre to the centre of the top pixel row; pixels are square; x grows to
/// the right as seen by the eye, y upwards.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraFrame {
    /// The view direction (unit).
    pub forward: DVec3,
    /// The image's x direction (unit).
    pub right: DVec3,
    /// The image's upward direction (unit).
    pub up: DVec3,
    /// Image-plane size of a pixel at distance 1.
    pub pixel: f64,
}

/// A light in world space.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    /// Its centre.
    pub position: DVec3,
    /// Its colour and intensity, linear RGB (components may exceed 1).
    pub color: DVec3,
    /// Radius of a spherical area light; 0 = point light.
    pub radius: f64,
}

/// Hall model surface (thesis Tables 3.1 and 3.2): ksr = 1 - kdr, kst = 1 - kdt.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Surface {
    /// Base colour, linear RGB.
    pub color: DVec3,
    /// Diffuse reflection kdr, 0..1; specular reflection is [`Surface::ksr`].
    pub kdr: f64,
    /// Diffuse transmission kdt, 0..1; specular transmission is [`Surface::kst`] (none at 1).
    pub kdt: f64,
    /// Ambient coefficient ka, >= 0.
    pub ka: f64,
    /// Specular highlight (Phong) exponent, >= 0.
    pub phong: f64,
    /// Index of refraction; > 0 whenever kdt < 1.
    pub refract: f64,
    /// A solid texture, or none.
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
    /// Specular reflection weight ksr = 1 - kdr (0 when opaque-diffuse). Inline: the
    /// tracer asks at every hit and every shadow ray's crossing, from another crate.
    #[inline]
    pub fn ksr(&self) -> f64 {
        (1.0 - self.kdr).clamp(0.0, 1.0)
    }
    /// Specular transmission weight kst = 1 - kdt (0 when solid).
    #[inline]
    pub fn kst(&self) -> f64 {
        (1.0 - self.kdt).clamp(0.0, 1.0)
    }
}

/// A solid texture (YARI `texture = id r,g,b sx,sy,sz`, `docs/yari.md` section 5).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Texture {
    /// The pattern.
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
    /// Rings about the texture z axis, wobbled by noise; the second colour is the dark veins.
    Wood = 1,
    /// Veins along x distorted by turbulence; the second colour is the veins.
    Marble = 2,
    /// The normal tilted by noise (the seascape of Fig. A.6); the second colour is unused.
    Bumps = 3,
    /// Clouds: the base colour mixed towards the second colour by turbulence.
    Turbulence = 4,
    /// Unit cells of texture space alternate; the second colour is the odd cells.
    Checker = 5,
}

impl TextureKind {
    /// The kind for a YARI texture id 1..5; `None` for any other id (0 means no texture).
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

/// One primitive with its surface and motion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Object {
    /// Its geometry in world space.
    pub shape: Shape,
    /// Index into [`World::surfaces`].
    pub surface: u32,
    /// World-space displacement over the shutter interval [0, 1]; zero = static.
    pub motion: DVec3,
}

/// A primitive's geometry in world space.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Shape {
    /// A sphere (also a sphere under a similarity transform).
    Sphere {
        /// The centre.
        center: DVec3,
        /// The radius, > 0.
        radius: f64,
    },
    /// The unit sphere at the origin mapped by `to_world` (a sphere under a non-similarity).
    Ellipsoid {
        /// Object-to-world map of the unit sphere; invertible.
        to_world: DAffine3,
    },
    /// A planar polygon, 3 or more vertices, convex or concave, in order.
    Polygon {
        /// The vertices in order, not repeating the first at the end.
        vertices: Vec<DVec3>,
    },
    /// A general quadric, possibly clipped.
    Quadric(Quadric),
    /// A planar polygon shaded smoothly: as [`Shape::Polygon`], with a normal at each vertex
    /// that the renderer interpolates across it (YARI's `normals = ...`, NFF's `pp`).
    /// Written last so that models without it serialize exactly as before this variant
    /// existed (the model file's version 1).
    SmoothPolygon {
        /// The vertices in order, not repeating the first at the end.
        vertices: Vec<DVec3>,
        /// One normal per vertex, in world space, finite and non-zero; unit length when a
        /// transformation placed them, as written otherwise (their length does not matter:
        /// the renderer normalises them).
        normals: Vec<DVec3>,
    },
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
    /// The upper triangle of Q, row by row (`a b c d e f g h i j`).
    pub q: [f64; 10],
    /// Half-spaces in world space; a point is on the surface only inside all of them
    /// (empty: unclipped).
    pub clip: Vec<HalfSpace>,
}

/// The points p with `normal . p <= offset`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HalfSpace {
    /// The outward normal of the bounding plane (need not be unit length).
    pub normal: DVec3,
    /// The plane's offset along `normal`, in units of `normal`'s length.
    pub offset: f64,
}

/// What a scene uses, so the renderer builds and pays for only those paths.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Features {
    /// Number of [`Shape::Sphere`] objects.
    pub spheres: usize,
    /// Number of [`Shape::Ellipsoid`] objects.
    pub ellipsoids: usize,
    /// Number of [`Shape::Polygon`] and [`Shape::SmoothPolygon`] objects.
    pub polygons: usize,
    /// Number of [`Shape::Quadric`] objects.
    pub quadrics: usize,
    /// Some surface has a texture.
    pub textures: bool,
    /// Some surface has kdt < 1 (transmits specularly).
    pub transparency: bool,
    /// Some surface has kdr < 1 (reflects specularly).
    pub reflection: bool,
    /// Some light has a radius > 0 (soft shadows).
    pub area_lights: bool,
    /// Some reflecting surface (kdr < 1) has gloss > 0.
    pub gloss: bool,
    /// Some transmitting surface (kdt < 1) has translucency > 0.
    pub translucency: bool,
    /// The camera's aperture is > 0.
    pub depth_of_field: bool,
    /// Some object has a non-zero motion vector.
    pub motion_blur: bool,
    /// More than one sample per pixel.
    pub antialiasing: bool,
}
