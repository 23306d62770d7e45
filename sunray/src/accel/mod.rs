//! Acceleration structures: which primitives a ray is tested against.
//!
//! - [`exhaustive`]: every primitive, in index order (the thesis's exhaustive mode).
//! - [`octree`]: Glassner's adaptive octree with voxel-by-voxel traversal (thesis 4.2.1).
//! - [`bvh`]: a binned-SAH bounding volume hierarchy, collapsed to 4 children per node.
//! - [`cache`]: built BVHs kept on the host, so each host builds one per scene once.
//! - [`mailbox`] and [`occluders`]: per-thread state that saves work and never changes a
//!   result (the intersection buffer; the last occluder of each light).
//!
//! All of them return the same closest hit: the smallest `t`, ties broken by the lower
//! primitive index, and every primitive's `t` comes from the same function; so the images of
//! all accelerators are identical. Unbounded primitives (quadrics without a bounding clip) are
//! kept in a separate list that every query tests.

pub mod bvh;
pub mod cache;
pub mod exhaustive;
pub mod mailbox;
pub mod occluders;
pub mod octree;

use crate::geometry::{Primitives, RayPre, Real};
use crate::stats::Counters;
pub use mailbox::Mailbox;
pub use occluders::Occluders;

/// The most boxes [`Accel::outer_boxes`] gives: the BVH's cut 64 boxes deep rather than the
/// root's 4 children left 11% fewer instructions to SPD tetra 6 (its gaps between
/// sub-tetrahedra are background the 4 boxes covered), 1-3% fewer to jacks, sombrero, tree
/// and teapot, and the same to balls (`valgrind --tool=cachegrind`, 512x512, one sample);
/// 256 gained 2% more on tetra 6 and nothing elsewhere.
pub const FOOTPRINT_BOXES: usize = 64;

/// The closest hit of a ray: parameter and primitive index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit, in units of the ray's `dir`.
    pub t: Real,
    /// Index of the primitive hit in the scene's primitive list.
    pub prim: u32,
}

impl Hit {
    /// Whether (t, prim) comes before `best` (smaller t, then smaller index).
    #[inline]
    pub fn improves(t: Real, prim: u32, best: &Option<Hit>) -> bool {
        match best {
            None => true,
            Some(b) => t < b.t || (t == b.t && prim < b.prim),
        }
    }
}

/// Which accelerator to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum AccelKind {
    /// Exhaustive for tiny scenes, the BVH otherwise (see [`AccelKind::resolve`]).
    Auto,
    /// Glassner's adaptive octree with a voxel-by-voxel walk (thesis 4.2.1).
    Octree,
    /// The binned-SAH BVH with 4-wide nodes.
    Bvh,
    /// Every bounded primitive in index order (the thesis's exhaustive mode).
    Exhaustive,
}

/// Build parameters.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AccelOptions {
    /// The structure to build; `Auto` picks by primitive count when building.
    pub kind: AccelKind,
    /// Octree: subdivide a voxel holding more than this many primitives.
    pub max_per_voxel: usize,
    /// Octree: maximum subdivision depth.
    pub max_depth: u32,
}

impl Default for AccelOptions {
    fn default() -> AccelOptions {
        AccelOptions {
            kind: AccelKind::Auto,
            max_per_voxel: 10,
            max_depth: 8,
        }
    }
}

impl AccelKind {
    /// `auto`: exhaustive up to 8 primitives (nothing to gain), the BVH above that. The BVH
    /// beat the octree on every SPD scene we measured (see docs/renderer.md); the octree stays
    /// selectable for the thesis's comparisons.
    pub fn resolve(self, bounded: usize) -> AccelKind {
        match self {
            AccelKind::Auto if bounded <= 8 => AccelKind::Exhaustive,
            AccelKind::Auto => AccelKind::Bvh,
            k => k,
        }
    }
    /// The lower-case name the command line and the statistics use.
    pub fn name(self) -> &'static str {
        match self {
            AccelKind::Auto => "auto",
            AccelKind::Octree => "octree",
            AccelKind::Bvh => "bvh",
            AccelKind::Exhaustive => "exhaustive",
        }
    }
}

/// A built accelerator over a scene's primitives.
#[derive(Clone, Debug)]
pub struct Accel {
    /// The structure actually built (`Auto` resolved).
    pub kind: AccelKind,
    structure: Structure,
    /// Primitives with no bounds, tested by every query.
    unbounded: Vec<u32>,
}

#[derive(Clone, Debug)]
enum Structure {
    Exhaustive(Vec<u32>),
    Octree(octree::Octree),
    Bvh(bvh::Bvh),
}

/// The primitives of `prims` that have bounds, with their bounds.
pub fn bounded(prims: &Primitives) -> impl Iterator<Item = (u32, crate::geometry::Aabb)> + '_ {
    (0..prims.len() as u32).filter_map(|i| prims.bounds(i).map(|b| (i, b)))
}

/// See [`Accel::outer_boxes`].
#[derive(Clone, Debug, PartialEq)]
pub struct OuterBoxes {
    /// A ray whose slab test misses every one of these hits nothing.
    pub boxes: Vec<crate::geometry::Aabb>,
    /// What such a ray adds to [`Counters::voxels`] all the same.
    pub voxels_on_miss: u64,
}

/// Per-thread scratch state of queries (the mailbox, the occluder cache). It only saves work: results never
/// depend on it.
#[derive(Clone, Debug)]
pub struct Scratch {
    /// The per-primitive mailbox (a no-op when the mailbox is off).
    pub mailbox: Mailbox,
    /// The last opaque occluder of each light (shadow rays test it first).
    pub occluders: Occluders,
}

impl Scratch {
    /// Scratch for a scene of `prims` primitives; `mailbox` turns the mailbox on.
    pub fn new(prims: usize, mailbox: bool) -> Scratch {
        Scratch {
            mailbox: Mailbox::new(prims, mailbox),
            occluders: Occluders::default(),
        }
    }
}

impl Accel {
    /// Builds the chosen structure over the bounded primitives; the unbounded ones are kept in
    /// a list every query tests.
    pub fn build(prims: &mut Primitives, opts: &AccelOptions) -> Accel {
        let unbounded = prims.unbounded();
        let kind = opts.kind.resolve(prims.len() - unbounded.len());
        let structure = match kind {
            AccelKind::Octree => {
                let overlaps = |i: u32, b: &crate::geometry::Aabb| prims.overlaps_box(i, b);
                let bounded: Vec<_> = bounded(prims).collect();
                Structure::Octree(octree::Octree::build(&bounded, &overlaps, opts))
            }
            AccelKind::Bvh => Structure::Bvh(bvh::Bvh::build(prims)),
            _ => Structure::Exhaustive(bounded(prims).map(|(i, _)| i).collect()),
        };
        Accel {
            kind,
            structure,
            unbounded,
        }
    }

    /// Cells of the structure: octree voxels (all nodes) or BVH nodes; 0 for exhaustive.
    pub fn node_count(&self) -> usize {
        match &self.structure {
            Structure::Exhaustive(_) => 0,
            Structure::Octree(o) => o.node_count(),
            Structure::Bvh(b) => b.node_count(),
        }
    }

    /// Boxes that every ray meeting anything enters, and the voxels a ray that misses them
    /// all counts: for the BVH at most [`FOOTPRINT_BOXES`] boxes of a cut through the tree
    /// ([`bvh::Bvh::cut_boxes`]), every leaf under one of them, such a ray counted as one
    /// visit (the root's). None when no such boxes are known: unbounded primitives (every ray
    /// may hit them), the octree and the exhaustive list (whose misses count differently).
    pub fn outer_boxes(&self) -> Option<OuterBoxes> {
        if !self.unbounded.is_empty() {
            return None;
        }
        match &self.structure {
            Structure::Bvh(b) => Some(OuterBoxes {
                voxels_on_miss: u64::from(b.node_count() > 0),
                boxes: b.cut_boxes(FOOTPRINT_BOXES),
            }),
            Structure::Exhaustive(_) | Structure::Octree(_) => None,
        }
    }

    /// Primitives without bounds, tested against every ray.
    pub fn unbounded_count(&self) -> usize {
        self.unbounded.len()
    }

    /// The closest hit in `(0, t_max)`.
    pub fn closest(
        &self,
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        scratch: &mut Scratch,
        c: &mut Counters,
    ) -> Option<Hit> {
        let mut best = if self.unbounded.is_empty() {
            None
        } else {
            exhaustive::closest_in(prims, &self.unbounded, r, t_max, None, c)
        };
        match &self.structure {
            Structure::Exhaustive(list) => {
                best = exhaustive::closest_in(prims, list, r, t_max, best, c);
            }
            Structure::Octree(o) => {
                scratch.mailbox.next_ray();
                best = o.closest(prims, r, t_max, best, &mut scratch.mailbox, c);
            }
            Structure::Bvh(b) => best = b.closest(prims, r, t_max, best, c),
        }
        best
    }

    /// The closest hit in `(0, t_max)` of each of up to [`bvh::packet::PACKET`] rays, as
    /// [`Accel::closest`] finds it: the BVH walks them together ([`bvh::packet`]), the other
    /// structures one after another.
    pub fn closest_packet(
        &self,
        prims: &Primitives,
        rays: &[RayPre],
        t_max: Real,
        scratch: &mut Scratch,
        c: &mut Counters,
    ) -> [Option<Hit>; bvh::packet::PACKET] {
        let mut best = [None; bvh::packet::PACKET];
        match &self.structure {
            Structure::Bvh(b) => {
                if !self.unbounded.is_empty() {
                    for (k, r) in rays.iter().enumerate().take(best.len()) {
                        best[k] = exhaustive::closest_in(prims, &self.unbounded, r, t_max, None, c);
                    }
                }
                b.closest_packet(prims, rays, u32::MAX, t_max, &mut best, c);
            }
            _ => {
                for (k, r) in rays.iter().enumerate().take(best.len()) {
                    best[k] = self.closest(prims, r, t_max, scratch, c);
                }
            }
        }
        best
    }

    /// Some hit in `(0, t_max)` for which `accept(prim, t)` holds, `t` where the ray meets
    /// `prim` (its nearest crossing in the interval; for shadow rays: an opaque occluder), or
    /// None.
    pub fn any(
        &self,
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        accept: &dyn Fn(u32, Real) -> bool,
        scratch: &mut Scratch,
        c: &mut Counters,
    ) -> Option<Hit> {
        if !self.unbounded.is_empty() {
            if let Some(h) = exhaustive::any_in(prims, &self.unbounded, r, t_max, accept, c) {
                return Some(h);
            }
        }
        match &self.structure {
            Structure::Exhaustive(list) => exhaustive::any_in(prims, list, r, t_max, accept, c),
            Structure::Octree(o) => {
                scratch.mailbox.next_ray();
                o.any(prims, r, t_max, accept, &mut scratch.mailbox, c)
            }
            Structure::Bvh(b) => b.any(prims, r, t_max, accept, c),
        }
    }
}

impl Accel {
    /// Whether light `light`'s last opaque occluder ([`Occluders`]) lies on `r` in
    /// `(0, t_max)`: one test that settles most blocked shadow rays.
    pub fn last_occluder_blocks(
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        light: usize,
        scratch: &Scratch,
        c: &mut Counters,
    ) -> bool {
        let Some(i) = scratch.occluders.get(light).filter(|&i| !r.skips(i)) else {
            return false;
        };
        c.intersection_tests += 1;
        prims.intersect(i, r, 0.0, t_max).is_some()
    }

    /// Whether anything lies on shadow ray `r` in `(0, t_max)` towards light `light`, every
    /// primitive taken as opaque: the light's last occluder first, then the tree, whose
    /// blocker becomes the light's occluder (and whose miss makes the light forget it).
    pub fn occluded(
        &self,
        prims: &Primitives,
        r: &RayPre,
        t_max: Real,
        light: usize,
        scratch: &mut Scratch,
        c: &mut Counters,
    ) -> bool {
        if Accel::last_occluder_blocks(prims, r, t_max, light, scratch, c) {
            return true;
        }
        let Some(hit) = self.any(prims, r, t_max, &|_, _| true, scratch, c) else {
            scratch.occluders.forget(light);
            return false;
        };
        scratch.occluders.set(light, hit.prim);
        true
    }
}

#[cfg(test)]
mod tests;
