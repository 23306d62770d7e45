//! Geometry: rays, bounding boxes and the primitives the renderer intersects.
//!
//! The compiled [`yari::model::World`] is turned into the scene's [`Primitives`]: spheres,
//! ellipsoids, triangles (polygons are triangulated, see [`polygon`]; faces of closed
//! transparent meshes bound a volume, see [`solid`]) and clipped quadrics, with static
//! triangles in an indexed mesh and static spheres in a table of their own
//! ([`primitives`]); anything else is a plain [`Primitive`]. Triangles of polygons with
//! vertex normals are shaded with the interpolated normal ([`smooth`]).
//! Intersection returns only the ray parameter `t`; the normal is computed afterwards for the
//! closest hit alone.
//!
//! Precision: the hot path uses [`Real`] (`f64`) and glam's `DVec3` ([`Vec3`]); both aliases
//! live here so a switch is made in one place. Its kernels (triangle, sphere, slab) are in
//! [`kernels`], written once for both precisions.

pub mod aabb;
pub mod kernels;
pub mod overlap;
pub mod polygon;
pub mod primitive;
pub mod primitives;
pub mod quadric;
pub mod smooth;
pub mod solid;
pub mod sphere;
pub mod triangle;

pub use aabb::Aabb;
pub use primitive::{Primitive, PrimitiveKind};
pub use primitives::Primitives;

/// The scalar type of the hot path.
pub type Real = f64;
/// The vector type of the hot path.
pub type Vec3 = glam::DVec3;

/// A ray `origin + t * dir`, `t` in `(0, t_max)`, at shutter time `time` in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts (world coordinates).
    pub origin: Vec3,
    /// Direction; not necessarily unit length, so `t` is in units of `|dir|`.
    pub dir: Vec3,
    /// Shutter time in [0, 1], for moving primitives (0 when there is no motion blur).
    pub time: Real,
}

impl Ray {
    /// A ray at shutter time 0.
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray {
            origin,
            dir,
            time: 0.0,
        }
    }
    /// The point at parameter `t`: `origin + t * dir`.
    pub fn at(&self, t: Real) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Per-ray constants shared by every primitive test (the watertight triangle test's shear,
/// the inverse direction for box tests), computed once per ray.
#[derive(Clone, Copy, Debug)]
pub struct RayPre {
    /// The ray itself.
    pub ray: Ray,
    /// `1 / dir` per component, infinities replaced by huge finite values (for the slab test).
    pub inv_dir: Vec3,
    /// First axis of Woop et al.'s (2013) shear: `kx`, `ky` are the two axes other than `kz`,
    /// swapped when `dir[kz] < 0` to keep the winding.
    pub kx: usize,
    /// Second axis of the shear: with `kx`, the axes other than `kz`.
    pub ky: usize,
    /// The axis along which `|dir|` is largest; it goes last in the sheared frame.
    pub kz: usize,
    /// Shear constant `dir[kx] / dir[kz]`.
    pub sx: Real,
    /// Shear constant `dir[ky] / dir[kz]`.
    pub sy: Real,
    /// Scale `1 / dir[kz]`.
    pub sz: Real,
}

impl RayPre {
    /// Computes the shear and inverse direction of `ray` once.
    pub fn new(ray: Ray) -> RayPre {
        let ([kx, ky, kz], [sx, sy, sz], inv_dir) = kernels::k64::shear_and_inverse(ray.dir);
        RayPre {
            ray,
            inv_dir,
            kx,
            ky,
            kz,
            sx,
            sy,
            sz,
        }
    }
}

/// Offsets a point off a surface along the normal `n` (unit, pointing to the side the new ray
/// leaves into), by an amount scaled to the magnitude of the point, so a ray spawned there does
/// not re-hit the surface it starts on. Assumes a scene of unit scale or larger; the renderer
/// uses [`offset_from`], which also works for tiny scenes.
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    let scale = p.abs().max_element().max(1.0);
    p + n * (scale * 1e-9)
}

/// Relative size of the offset of [`offset_from`]: about 2^23 units in the last place of the
/// largest coordinate involved, far above the error of a computed hit point (a few ulps) and
/// far below any feature a scene resolves (see docs/accuracy.md).
pub const OFFSET_RELATIVE: Real = 1e-9;

/// Offsets hit point `p`, found by a ray that started at `from`, off its surface along the unit
/// normal `n` (pointing to the side the new ray leaves into). The error of `p = o + t d` is a
/// few ulps of the larger of |p| and |o|, so the offset is scaled to that, not to 1: the same
/// scene scaled by 1e-4 or 1e+4, or moved 1e5 away from the origin, renders the same.
#[inline]
pub fn offset_from(p: Vec3, n: Vec3, from: Vec3) -> Vec3 {
    let scale = p
        .abs()
        .max_element()
        .max(from.abs().max_element())
        .max(1e-200);
    p + n * (scale * OFFSET_RELATIVE)
}
