//! Shadow rays: how much of a light reaches a point. An opaque surface in the way blocks it;
//! each crossing of a transparent surface filters it by `kst * colour` of that surface.
//!
//! One walk of the accelerator settles a shadow ray. Its any-hit query calls
//! [`Crossings::meets`] for every primitive the ray meets before the light: an opaque one ends
//! the walk (blocked); a transparent one multiplies the filter by its factor once per crossing
//! (a closed glass sphere is crossed twice), and the walk goes on, until the light left is
//! negligible ([`NEGLIGIBLE`]). The filters multiply, so the order in which the walk meets the
//! surfaces does not matter. (Before, a ray that met glass walked the tree once for any hit,
//! once more for an opaque one, then once per transparent surface crossed, each time from
//! just past the last crossing: gears' shadow rays cost 41M intersection tests instead of
//! 8.4M opaque.)

use super::hall::{FlatFace, Tracer};
use crate::accel::Accel;
use crate::geometry::{offset_from, Primitives, Ray, RayPre, Real, Vec3, OFFSET_RELATIVE};
use crate::scene::Scene;
use smallvec::SmallVec;
use std::cell::{Cell, RefCell};

/// A shadow ray whose light is filtered below this (in every channel) is blocked: it could
/// not change a pixel by more than a millionth of the light's intensity.
pub const NEGLIGIBLE: Real = 1e-6;

/// Crossings a walk keeps without allocating: a shadow ray through two glass spheres
/// crosses four surfaces; one that meets more spills to the heap.
const INLINE: usize = 8;

/// The state of one shadow ray's walk: the filter so far, the transparent primitives already
/// counted (an octree without the mailbox can offer a primitive once per voxel) and where
/// the crossings counted are along the ray.
pub struct Crossings<'a> {
    scene: &'a Scene,
    ray: &'a RayPre,
    t_max: Real,
    filter: Cell<Vec3>,
    counted: RefCell<SmallVec<[u32; INLINE]>>,
    at: RefCell<SmallVec<[Real; INLINE]>>,
    /// Intersection tests made to find a primitive's further crossings.
    tests: Cell<u64>,
}

impl<'a> Crossings<'a> {
    /// A walk along `ray` up to `t_max`, nothing met yet.
    pub fn new(scene: &'a Scene, ray: &'a RayPre, t_max: Real) -> Crossings<'a> {
        Crossings {
            scene,
            ray,
            t_max,
            filter: Cell::new(Vec3::ONE),
            counted: RefCell::new(SmallVec::new()),
            at: RefCell::new(SmallVec::new()),
            tests: Cell::new(0),
        }
    }

    /// The ray meets primitive `i` in `(0, t_max)`, first at `t` (what the walk's test found):
    /// true ends the walk (an opaque surface, or the light left negligible), false goes on.
    ///
    /// Each of the primitive's crossings filters once, except one at the same place as a
    /// crossing already counted (within the offset secondary rays start at,
    /// [`OFFSET_RELATIVE`]): a ray through the edge shared by two triangles of a face meets
    /// both, and crosses the face once. (The loop this replaced stepped past such a second
    /// hit the same way.)
    pub fn meets(&self, i: u32, t: Real) -> bool {
        let s = self.scene.surface(i);
        let kst = s.kst();
        if kst <= 0.0 {
            return true;
        }
        let mut counted = self.counted.borrow_mut();
        if counted.contains(&i) {
            return false;
        }
        counted.push(i);
        let mut at = self.at.borrow_mut();
        let mut filter = self.filter.get();
        let origin = self.ray.ray.origin.abs().max_element();
        let further = further_root(&self.scene.prims, i, t, self.ray, self.t_max, &self.tests);
        for t in std::iter::once(t).chain(further) {
            let scale = origin.max(self.ray.ray.at(t).abs().max_element());
            let same_place = 4.0 * OFFSET_RELATIVE * scale;
            if at.iter().any(|&u| (u - t).abs() <= same_place) {
                continue;
            }
            at.push(t);
            filter *= s.color * kst;
        }
        self.filter.set(filter);
        filter.max_element() < NEGLIGIBLE
    }

    /// The filter of every crossing met (the light that reaches the point if the walk ended
    /// without an opaque surface).
    pub fn filter(&self) -> Vec3 {
        self.filter.get()
    }

    /// The extra intersection tests the walk made.
    pub fn tests(&self) -> u64 {
        self.tests.get()
    }
}

/// Where primitive `i` meets `ray` again in `(first, t_max)`, `first` its nearest crossing
/// (found by the walk's own test): a quadric's further root, searched from just past `first`
/// (a quadric meets a line at most twice, clipping only removes roots); never for a flat
/// primitive, which meets it once.
fn further_root(
    prims: &Primitives,
    i: u32,
    first: Real,
    ray: &RayPre,
    t_max: Real,
    tests: &Cell<u64>,
) -> Option<Real> {
    if prims.is_planar(i) {
        return None;
    }
    tests.set(tests.get() + 1);
    prims
        .intersect(i, ray, first, t_max)
        .filter(|&next| next > first)
}

impl Tracer<'_> {
    /// The filter a shadow ray from `p` (leaving on the side of `side`) towards light number
    /// `light`, at distance `dist` in direction `l`, receives: 1 if unblocked, 0 if an opaque
    /// surface is in the way, and the product of `kst * colour` of every transparent surface
    /// crossed. `ray` is the ray that found `p` (its origin scales the offset, its time is the
    /// shadow ray's). The light's last opaque occluder is tried before the tree
    /// ([`crate::accel::Occluders`]).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn shadow(
        &mut self,
        face: Option<&FlatFace>,
        p: Vec3,
        side: Vec3,
        light: usize,
        l: Vec3,
        dist: Real,
        ray: &Ray,
    ) -> Vec3 {
        self.counters.shadow += 1;
        let origin = offset_from(p, side, ray.origin);
        let t_max = (p + l * dist - origin).dot(l);
        let mut pre = RayPre::new(Ray {
            origin,
            dir: l,
            time: ray.time,
        });
        if let Some(face) = face.filter(|f| f.left_by(side, l)) {
            pre = pre.leaving(face.prims);
        }
        let scene = self.scene;
        let prims = &scene.prims;
        if !scene.world.features.transparency {
            let (scratch, c) = (&mut *self.scratch, &mut *self.counters);
            let blocked = self.accel.occluded(prims, &pre, t_max, light, scratch, c);
            return if blocked { Vec3::ZERO } else { Vec3::ONE };
        }
        if Accel::last_occluder_blocks(prims, &pre, t_max, light, self.scratch, self.counters) {
            return Vec3::ZERO;
        }
        let walk = Crossings::new(scene, &pre, t_max);
        let blocker = self.accel.any(
            prims,
            &pre,
            t_max,
            &|i, t| walk.meets(i, t),
            self.scratch,
            self.counters,
        );
        self.counters.intersection_tests += walk.tests();
        let Some(hit) = blocker else {
            self.scratch.occluders.forget(light);
            return walk.filter();
        };
        // The walk also ends at glass that leaves too little light; only an opaque surface
        // is sure to block the next ray it meets.
        if scene.surface(hit.prim).kst() <= 0.0 {
            self.scratch.occluders.set(light, hit.prim);
        }
        Vec3::ZERO
    }
}

#[cfg(test)]
mod tests;
