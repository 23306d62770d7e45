//! Geometry: rays, bounding boxes and the primitives the renderer intersects.
//!
//! The compiled [`yari::model::World`] is turned into a flat list of [`Primitive`]s: spheres,
//! ellipsoids, triangles (polygons are triangulated, see [`polygon`]) and clipped quadrics.
//! Intersection returns only the ray parameter `t`; the normal is computed afterwards for the
//! closest hit alone.
//!
//! Precision: the hot path uses [`Real`] (`f64`) and glam's `DVec3` ([`Vec3`]); both aliases
//! live here so a switch is made in one place.

pub mod aabb;
pub mod overlap;
pub mod polygon;
pub mod primitive;
pub mod quadric;
pub mod sphere;
pub mod triangle;

pub use aabb::Aabb;
pub use primitive::{Primitive, PrimitiveKind};

/// The scalar type of the hot path.
pub type Real = f64;
/// The vector type of the hot path.
pub type Vec3 = glam::DVec3;

/// A ray `origin + t * dir`, `t` in `(0, t_max)`, at shutter time `time` in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub time: Real,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray {
            origin,
            dir,
            time: 0.0,
        }
    }
    pub fn at(&self, t: Real) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Per-ray constants shared by every primitive test (the watertight triangle test's shear,
/// the inverse direction for box tests), computed once per ray.
#[derive(Clone, Copy, Debug)]
pub struct RayPre {
    pub ray: Ray,
    pub inv_dir: Vec3,
    /// Axis along which `dir` is largest, and the two others (Woop et al. 2013).
    pub kx: usize,
    pub ky: usize,
    pub kz: usize,
    pub sx: Real,
    pub sy: Real,
    pub sz: Real,
}

impl RayPre {
    pub fn new(ray: Ray) -> RayPre {
        let d = ray.dir;
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        RayPre {
            ray,
            inv_dir: safe_inverse(d),
            kx,
            ky,
            kz,
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
        }
    }
}

/// Offsets a point off a surface along the normal `n` (unit, pointing to the side the new ray
/// leaves into), by an amount scaled to the magnitude of the point, so a ray spawned there does
/// not re-hit the surface it starts on.
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    let scale = p.abs().max_element().max(1.0);
    p + n * (scale * 1e-9)
}

/// `1 / d` per component, with an infinite quotient replaced by a huge finite one of the same
/// sign, so that the slab test never computes `0 * inf`.
fn safe_inverse(d: Vec3) -> Vec3 {
    let f = |x: Real| {
        let i = 1.0 / x;
        if i.is_finite() {
            i
        } else {
            1e300_f64.copysign(i)
        }
    };
    Vec3::new(f(d.x), f(d.y), f(d.z))
}
