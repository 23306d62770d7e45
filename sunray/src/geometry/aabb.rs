//! Axis-aligned bounding boxes and the slab test.

use super::{RayPre, Real, Vec3};

/// An axis-aligned box in world coordinates; empty when `min > max` on any axis.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Aabb {
    /// The lower corner.
    pub min: Vec3,
    /// The upper corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (union identity).
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(Real::INFINITY),
        max: Vec3::splat(Real::NEG_INFINITY),
    };

    /// The box with these corners (not checked: `min > max` gives an empty box).
    pub fn new(min: Vec3, max: Vec3) -> Aabb {
        Aabb { min, max }
    }
    /// The smallest box holding every point ([`Aabb::EMPTY`] for none).
    pub fn from_points(points: &[Vec3]) -> Aabb {
        points.iter().fold(Aabb::EMPTY, |b, &p| b.grow(p))
    }
    /// The box grown to hold `p`.
    pub fn grow(self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }
    /// The smallest box holding both.
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }
    /// The common part; empty (see [`Aabb::is_empty`]) when they do not overlap.
    pub fn intersection(self, o: Aabb) -> Aabb {
        Aabb {
            min: self.min.max(o.min),
            max: self.max.min(o.max),
        }
    }
    /// True when `min > max` on some axis.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }
    /// True when no corner coordinate is infinite or NaN ([`Aabb::EMPTY`] is not finite).
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }
    /// The midpoint of the corners.
    pub fn centre(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
    /// The side lengths, `max - min`.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }
    /// The total area of the six faces (0 for an empty box), for the SAH.
    pub fn surface_area(&self) -> Real {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
    /// True when the closed boxes share a point (touching counts).
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.min.x <= o.max.x
            && o.min.x <= self.max.x
            && self.min.y <= o.max.y
            && o.min.y <= self.max.y
            && self.min.z <= o.max.z
            && o.min.z <= self.max.z
    }
    /// The box grown by a relative margin (of its size and of its distance from the origin),
    /// so that a point rounded onto its face is still inside.
    pub fn padded(self) -> Aabb {
        let scale = self.min.abs().max(self.max.abs()).max_element().max(1e-300);
        let pad = Vec3::splat(scale * 1e-9) + self.extent() * 1e-9;
        Aabb {
            min: self.min - pad,
            max: self.max + pad,
        }
    }

    /// Slab test: the parameter interval `[t0, t1]` of the ray inside the box, clipped to
    /// `[t_min, t_max]`, or None. `inv_dir` is finite (see `RayPre`).
    #[inline]
    pub fn hit(&self, r: &RayPre, t_min: Real, t_max: Real) -> Option<(Real, Real)> {
        super::kernels::k64::slab(self.min, self.max, r.ray.origin, r.inv_dir, t_min, t_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;

    #[test]
    fn slab_interval_of_axis_ray() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let r = RayPre::new(Ray::new(Vec3::new(-5.0, 0.0, 0.0), Vec3::X));
        let (t0, t1) = b.hit(&r, 0.0, 100.0).unwrap();
        assert_eq!((t0, t1), (4.0, 6.0));
        let miss = RayPre::new(Ray::new(Vec3::new(-5.0, 2.0, 0.0), Vec3::X));
        assert!(b.hit(&miss, 0.0, 100.0).is_none());
    }

    #[test]
    fn ray_in_face_plane_is_not_lost() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let r = RayPre::new(Ray::new(Vec3::new(-1.0, 0.0, 0.5), Vec3::X));
        assert!(b.hit(&r, 0.0, 10.0).is_some());
    }
}
