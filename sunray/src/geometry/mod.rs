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
//!
//! # Layout
//!
//! - [`aabb`]: axis-aligned boxes and the slab test; [`overlap`]: primitive / box overlap
//!   (which octree voxels a primitive touches).
//! - [`primitive`]: a primitive as a plain value; [`primitives`]: the scene's compact tables.
//! - [`sphere`], [`triangle`], [`quadric`]: the intersection of each shape; [`kernels`]: the
//!   hot-path kernels in both precisions.
//! - [`polygon`]: polygons triangulated; [`smooth`]: interpolated normals; [`solid`]: closed
//!   transparent meshes bounding a volume.

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

use std::cell::Cell;

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

/// Per-ray constants shared by every primitive test: the inverse direction for box tests,
/// computed with the ray, and the watertight triangle test's shear, computed the first time
/// a triangle is tested (most shadow rays of a scene of spheres and quadrics never meet one;
/// tree11's shadow rays spent 5% of the render on it).
#[derive(Clone, Debug)]
pub struct RayPre {
    /// The ray itself.
    pub ray: Ray,
    /// `1 / dir` per component, infinities replaced by huge finite values (for the slab test).
    pub inv_dir: Vec3,
    shear: Cell<Shear>,
    /// Primitive numbers `skip[0]..skip[1]` the ray cannot meet (empty unless set by
    /// [`RayPre::leaving`]): their tests return no hit at once
    /// ([`Primitives::intersect_slot`]).
    skip: [u32; 2],
}

/// Woop et al.'s (2013) shear of a ray's direction ([`kernels::k64::shear`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shear {
    /// `[kx, ky, kz]`: `kz` the axis along which `|dir|` is largest (it goes last in the
    /// sheared frame), `kx`, `ky` the others, swapped when `dir[kz] < 0` to keep the winding.
    pub k: [usize; 3],
    /// `[dir[kx] / dir[kz], dir[ky] / dir[kz], 1 / dir[kz]]`.
    pub s: [Real; 3],
}

impl Shear {
    /// Not computed yet (no axis is 3).
    const UNSET: Shear = Shear {
        k: [3; 3],
        s: [0.0; 3],
    };
}

impl RayPre {
    /// Computes the inverse direction of `ray`.
    #[inline]
    pub fn new(ray: Ray) -> RayPre {
        RayPre {
            ray,
            inv_dir: kernels::k64::inverse(ray.dir),
            shear: Cell::new(Shear::UNSET),
            skip: [0, 0],
        }
    }

    /// The same ray, known to miss primitives `prims[0]..prims[1]`: the triangles of the flat
    /// polygon it leaves ([`Primitives::flat_face`]), when it starts on the polygon's side
    /// it moves away from. Skipping their tests changes no hit, since a ray that starts off a
    /// plane and moves away from it never reaches it (tree11's shadow rays from the ground
    /// tested its two triangles every time).
    pub fn leaving(mut self, prims: [u32; 2]) -> RayPre {
        self.skip = prims;
        self
    }

    /// Whether primitive `i` is one this ray is known to miss ([`RayPre::leaving`]).
    #[inline(always)]
    pub fn skips(&self, i: u32) -> bool {
        i.wrapping_sub(self.skip[0]) < self.skip[1].wrapping_sub(self.skip[0])
    }

    /// The same ray from another origin (what depends on the direction is kept).
    pub fn from_origin(&self, origin: Vec3) -> RayPre {
        RayPre {
            ray: Ray { origin, ..self.ray },
            ..self.clone()
        }
    }

    /// The shear of the direction, computed on first use.
    #[inline(always)]
    pub fn shear(&self) -> Shear {
        let s = self.shear.get();
        if s.k[2] < 3 {
            return s;
        }
        self.compute_shear()
    }

    #[cold]
    #[inline(never)]
    fn compute_shear(&self) -> Shear {
        let (k, s) = kernels::k64::shear(self.ray.dir);
        let shear = Shear { k, s };
        self.shear.set(shear);
        shear
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shear_is_computed_on_first_use_and_kept_from_another_origin() {
        let d = Vec3::new(0.3, -0.9, 0.2).normalize();
        let r = RayPre::new(Ray::new(Vec3::ONE, d));
        assert_eq!(r.shear.get(), Shear::UNSET);
        let (k, s) = kernels::k64::shear(d);
        assert_eq!(r.shear(), Shear { k, s });
        assert_eq!(r.shear.get(), Shear { k, s });
        let moved = r.from_origin(Vec3::ZERO);
        assert_eq!((moved.ray.dir, moved.inv_dir), (r.ray.dir, r.inv_dir));
        assert_eq!(moved.shear.get(), Shear { k, s });
    }
}
