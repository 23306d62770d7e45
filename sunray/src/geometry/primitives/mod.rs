//! The scene's primitives, stored compactly: what the accelerators index and the shader
//! asks about, by primitive number (the model's objects in order, a polygon's triangles one
//! after another; ties between equal hits go to the lower number).
//!
//! Most primitives of a big scene are static triangles and spheres; they are kept in compact
//! tables ([`mesh`]: indexed triangles of 24 bytes and shared corners; static spheres of 40
//! bytes), in the order of the BVH's leaves once one is built. Everything else (ellipsoids, quadrics, moving shapes) is a
//! [`Primitive`]. A primitive's *slot* says which table holds it and where; the BVH's
//! leaves list slots, so a leaf's triangles are read from the mesh directly. Every query
//! computes `t` with the same function and the same numbers as [`Primitive`] would, so the
//! images are those of the plain list, to the bit.
//!
//! # Layout
//! - [`mesh`]: the indexed triangle mesh.
//! - [`smooth`]: the side table of smooth triangles' corner normals.
//! - [`builder`]: objects to primitives (triangulation, closed transparent meshes, dropped
//!   objects), one object at a time, so a model can be decoded as a stream.
//! - [`parts`]: the finished primitives as their large tables and the rest, for a prepared
//!   scene file (the tables viewed in place when it is read back).

pub mod builder;
pub mod mesh;
pub mod parts;
pub mod smooth;

use super::smooth::SmoothHit;
use super::sphere::intersect_sphere;
use super::triangle::intersect_triangle;
use super::{Aabb, Primitive, PrimitiveKind, RayPre, Real, Vec3};
use crate::store::Store;
pub use builder::{PrimitiveCounts, PrimitivesBuilder};
use mesh::Mesh;
use smooth::SmoothTable;

/// Slot kinds, in a slot's top two bits.
const TRIANGLE: u32 = 0;
const SPHERE: u32 = 1 << 30;
const OTHER: u32 = 2 << 30;
const KIND: u32 = 3 << 30;
/// The most primitives of one kind (a slot's low 30 bits).
pub const MAX_PER_KIND: usize = (1 << 30) - 1;

/// A static sphere.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StaticSphere {
    /// Centre in world units.
    pub centre: Vec3,
    /// Radius in world units, > 0.
    pub radius: Real,
    /// Its primitive number.
    pub prim: u32,
    /// Its surface.
    pub surface: u32,
}

/// Where a primitive is kept: its table (top two bits) and its index there.
pub type Slot = u32;

/// The scene's primitives (see the module's text).
#[derive(Clone, Debug, Default)]
pub struct Primitives {
    /// Primitive number to slot.
    slots: Store<Slot>,
    mesh: Mesh,
    spheres: Vec<StaticSphere>,
    /// Primitive numbers of `others`.
    other_prims: Vec<u32>,
    others: Vec<Primitive>,
    /// The bounds of `others` (a clipped quadric's take a while to find), None if unbounded.
    other_bounds: Vec<Option<Aabb>>,
    /// Corner normals of the smooth triangles (of the mesh or among `others`), by primitive.
    smooth: SmoothTable,
    /// The static polygons of more than one triangle that are flat ([`flat`]), as ranges
    /// of primitive numbers `[first, end)`, in order.
    flat_polygons: Vec<[u32; 2]>,
    /// Whether an accelerator's order was adopted ([`Primitives::adopt_order`]).
    ordered: bool,
}

/// Whether polygon `vertices` with unit plane normal `normal` is flat: every corner within
/// 1e-12 of its size from the plane through the first. A ray that leaves such a polygon
/// (from the offset secondary rays start at, 1e-9 of the coordinates) cannot meet it again;
/// a warped one may shadow itself.
pub fn flat(vertices: &[Vec3], normal: Vec3) -> bool {
    let Some(&v0) = vertices.first() else {
        return false;
    };
    let (lo, hi) = vertices
        .iter()
        .fold((v0, v0), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    let size = (hi - lo).length();
    size.is_finite()
        && vertices
            .iter()
            .all(|v| (*v - v0).dot(normal).abs() <= 1e-12 * size)
}

/// Moves `items[k]` to `new[k]`.
fn permute<T: Copy>(items: &mut Vec<T>, new: &[u32]) {
    let Some(&first) = items.first() else {
        return;
    };
    let mut out = vec![first; items.len()];
    for (item, &to) in items.iter().zip(new) {
        out[to as usize] = *item;
    }
    *items = out;
}

impl Primitives {
    /// The primitives of a plain list, in its order (tests and benchmarks build scenes so).
    /// Triangles count as open faces or solid ones as their `solid` says.
    pub fn from_list(list: Vec<Primitive>) -> Primitives {
        let mut b = PrimitivesBuilder::new();
        for p in list {
            b.add_primitive(p);
        }
        b.finish().0
    }

    /// How many primitives there are.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// The slot of primitive `i`.
    #[inline(always)]
    pub fn slot(&self, i: u32) -> Slot {
        self.slots[i as usize]
    }

    /// The primitives of the flat face primitive `i` lies on, `[first, end)`: every triangle
    /// of its polygon when the polygon is static and flat, the triangle alone when its normal
    /// is its own plane's; None for everything else (a warped polygon's triangles and others
    /// shaded with a normal not their plane's, spheres, quadrics, moving triangles). A ray
    /// leaving the face's plane misses them all ([`RayPre::leaving`]).
    pub fn flat_face(&self, i: u32) -> Option<[u32; 2]> {
        let slot = *self.slots.get(i as usize)?;
        if slot & KIND != TRIANGLE {
            return None;
        }
        let polygons = &self.flat_polygons;
        let k = polygons.partition_point(|r| r[1] <= i);
        match polygons.get(k) {
            Some(r) if r[0] <= i => Some(*r),
            _ => Mesh::has_plane_normal(&self.mesh.triangles[(slot & !KIND) as usize])
                .then_some([i, i + 1]),
        }
    }

    /// The primitive number of `slot`.
    #[inline(always)]
    pub fn prim_of(&self, slot: Slot) -> u32 {
        let k = (slot & !KIND) as usize;
        match slot & KIND {
            TRIANGLE => self.mesh.triangles[k].prim,
            SPHERE => self.spheres[k].prim,
            _ => self.other_prims[k],
        }
    }

    /// Primitive `i`'s nearest `t` in `(t_min, t_max)`.
    #[inline(always)]
    pub fn intersect(&self, i: u32, r: &RayPre, t_min: Real, t_max: Real) -> Option<Real> {
        self.intersect_slot(self.slot(i), r, t_min, t_max)
    }

    /// The nearest `t` in `(t_min, t_max)` of the primitive in `slot`; None at once for a
    /// triangle the ray is known to miss ([`RayPre::leaving`]: only triangles of the mesh
    /// are ever skipped, [`Primitives::flat_face`]).
    #[inline(always)]
    pub fn intersect_slot(&self, slot: Slot, r: &RayPre, t_min: Real, t_max: Real) -> Option<Real> {
        let k = (slot & !KIND) as usize;
        match slot & KIND {
            TRIANGLE => {
                let t = &self.mesh.triangles[k];
                if r.skips(t.prim) {
                    return None;
                }
                intersect_triangle(r, &self.mesh.corners(t), t_min, t_max)
            }
            SPHERE => {
                let s = &self.spheres[k];
                intersect_sphere(&r.ray, s.centre, s.radius, t_min, t_max)
            }
            _ => self.others[k].intersect(r, t_min, t_max),
        }
    }

    /// Puts the static triangles and spheres in the order their primitives first appear in
    /// `order` (an accelerator's leaf order; those not in it go last), and the mesh's corners
    /// in order of first use, so that a leaf's items lie side by side in memory. Done once:
    /// later calls change nothing and return false, so the slots an accelerator keeps stay
    /// valid.
    pub fn adopt_order(&mut self, order: &[u32]) -> bool {
        if self.ordered {
            return false;
        }
        self.ordered = true;
        let rank = |slots: &[Slot], kind: u32, n: usize| {
            // New position of each entry of a table: by first appearance in `order`.
            let mut new = vec![u32::MAX; n];
            let mut next = 0u32;
            for &i in order {
                let slot = slots[i as usize];
                if slot & KIND == kind && new[(slot & !KIND) as usize] == u32::MAX {
                    new[(slot & !KIND) as usize] = next;
                    next += 1;
                }
            }
            for p in new.iter_mut().filter(|p| **p == u32::MAX) {
                *p = next;
                next += 1;
            }
            new
        };
        let new = rank(&self.slots, TRIANGLE, self.mesh.triangles.len());
        self.mesh.permute(&new);
        let new = rank(&self.slots, SPHERE, self.spheres.len());
        permute(&mut self.spheres, &new);
        self.index_slots();
        true
    }

    /// Points every triangle's and sphere's slot at where it is.
    fn index_slots(&mut self) {
        let mut slots = self.slots.edit();
        for (k, t) in self.mesh.triangles.iter().enumerate() {
            slots[t.prim as usize] = TRIANGLE | k as u32;
        }
        for (k, s) in self.spheres.iter().enumerate() {
            slots[s.prim as usize] = SPHERE | k as u32;
        }
    }

    /// Primitive `i` as a plain [`Primitive`] (for what is not on the hot path: bounds,
    /// box overlaps while building an accelerator).
    pub fn get(&self, i: u32) -> Primitive {
        let slot = self.slot(i);
        let k = (slot & !KIND) as usize;
        match slot & KIND {
            TRIANGLE => {
                let t = &self.mesh.triangles[k];
                Primitive {
                    kind: PrimitiveKind::Triangle {
                        v: self.mesh.corners(t),
                        normal: self.mesh.normal(t),
                        solid: Mesh::is_solid(t),
                    },
                    object: 0,
                    surface: t.surface,
                    motion: Vec3::ZERO,
                }
            }
            SPHERE => {
                let s = &self.spheres[k];
                Primitive {
                    kind: PrimitiveKind::Sphere {
                        centre: s.centre,
                        radius: s.radius,
                    },
                    object: 0,
                    surface: s.surface,
                    motion: Vec3::ZERO,
                }
            }
            _ => self.others[k].clone(),
        }
    }

    /// Primitive `i`'s world-space bounds over the shutter interval, or None if unbounded.
    pub fn bounds(&self, i: u32) -> Option<Aabb> {
        let slot = self.slot(i);
        let k = (slot & !KIND) as usize;
        match slot & KIND {
            TRIANGLE => {
                Some(Aabb::from_points(&self.mesh.corners(&self.mesh.triangles[k])).padded())
            }
            SPHERE => {
                let s = &self.spheres[k];
                let r = Vec3::splat(s.radius);
                Some(Aabb::new(s.centre - r, s.centre + r).padded())
            }
            _ => self.other_bounds[k],
        }
    }

    /// The corners of primitive `i` when it is a triangle of the static mesh, else None.
    pub fn mesh_triangle(&self, i: u32) -> Option<[Vec3; 3]> {
        let slot = self.slot(i);
        (slot & KIND == TRIANGLE).then(|| {
            self.mesh
                .corners(&self.mesh.triangles[(slot & !KIND) as usize])
        })
    }

    /// The centre and radius of primitive `i` when it is a sphere of the sphere table (a
    /// static sphere), else None.
    pub fn table_sphere(&self, i: u32) -> Option<(Vec3, Real)> {
        let slot = self.slot(i);
        (slot & KIND == SPHERE).then(|| {
            let s = &self.spheres[(slot & !KIND) as usize];
            (s.centre, s.radius)
        })
    }

    /// The cost of primitive `i`'s intersection test relative to a triangle's, for the
    /// BVH's surface area heuristic: 3 for a clipped quadric (a quadratic in general form,
    /// then its clipping planes and box), 1 for the rest. With 3, tree11 (cones) renders 7%
    /// faster than with 1; 5 was no better (bench/ab.sh).
    pub fn test_cost(&self, i: u32) -> f32 {
        let slot = self.slot(i);
        match slot & KIND {
            TRIANGLE | SPHERE => 1.0,
            _ => match self.others[(slot & !KIND) as usize].kind {
                PrimitiveKind::Quadric(_) => 3.0,
                _ => 1.0,
            },
        }
    }

    /// Whether primitive `i` may touch box `b` ([`Primitive::overlaps_box`], without
    /// making the plain primitive).
    pub fn overlaps_box(&self, i: u32, b: &Aabb) -> bool {
        let slot = self.slot(i);
        let k = (slot & !KIND) as usize;
        match slot & KIND {
            TRIANGLE => {
                let v = self.mesh.corners(&self.mesh.triangles[k]);
                super::primitive::triangle_overlaps(&v, &b.padded())
            }
            SPHERE => {
                let s = &self.spheres[k];
                super::primitive::sphere_overlaps(s.centre, s.radius, &b.padded())
            }
            _ => self.others[k].overlaps_box_with(b, || self.other_bounds[k]),
        }
    }

    /// The primitives with no bounds (quadrics without a bounding clip), in order. Only the
    /// plain primitives can be unbounded, so the mesh and the sphere table are not looked at.
    pub fn unbounded(&self) -> Vec<u32> {
        self.other_bounds
            .iter()
            .zip(&self.other_prims)
            .filter(|(b, _)| b.is_none())
            .map(|(_, &i)| i)
            .collect()
    }

    /// How many primitives have no bounds.
    pub fn unbounded_count(&self) -> usize {
        self.other_bounds.iter().filter(|b| b.is_none()).count()
    }

    /// The geometric unit normal of primitive `i` at world point `p` reached at shutter time
    /// `time` ([`Primitive::normal`]).
    #[inline]
    pub fn normal(&self, i: u32, p: Vec3, time: Real) -> Vec3 {
        let slot = self.slot(i);
        let k = (slot & !KIND) as usize;
        match slot & KIND {
            TRIANGLE => self.mesh.normal(&self.mesh.triangles[k]),
            SPHERE => {
                let s = &self.spheres[k];
                (p - Vec3::ZERO * time - s.centre) / s.radius
            }
            _ => self.others[k].normal(p, time),
        }
    }

    /// The hit at world point `p` (shutter time `time`) on primitive `i` if it is a smooth
    /// triangle: its corners and their normals, turned to the side of [`Primitives::normal`];
    /// `None` for every other primitive (at once when no triangle is smooth).
    #[inline]
    pub fn smooth_hit(&self, i: u32, p: Vec3, time: Real) -> Option<SmoothHit> {
        if self.smooth.is_empty() {
            return None;
        }
        let normals = self.smooth.get(i)?;
        let slot = self.slot(i);
        let k = (slot & !KIND) as usize;
        match slot & KIND {
            TRIANGLE => {
                let t = &self.mesh.triangles[k];
                let s = if Mesh::is_flipped(t) { -1.0 } else { 1.0 };
                Some(SmoothHit::new(
                    self.mesh.corners(t),
                    normals.map(|n| n * s),
                    p,
                ))
            }
            OTHER => match &self.others[k].kind {
                PrimitiveKind::Triangle { v, .. } => Some(SmoothHit::new(
                    *v,
                    normals,
                    p - self.others[k].motion * time,
                )),
                _ => None,
            },
            _ => None,
        }
    }

    /// Smooth triangles, and the distinct corner normals they use.
    pub fn smooth_counts(&self) -> (usize, usize) {
        self.smooth.counts()
    }

    /// Whether primitive `i` is flat ([`Primitive::is_planar`]: a triangle of the mesh or a
    /// moving one), so a line meets it at most once (a shadow ray through glass looks for no
    /// second crossing of it).
    #[inline]
    pub fn is_planar(&self, i: u32) -> bool {
        let slot = self.slot(i);
        match slot & KIND {
            TRIANGLE => true,
            SPHERE => false,
            _ => self.others[(slot & !KIND) as usize].is_planar(),
        }
    }

    /// Whether primitive `i` encloses a volume ([`Primitive::is_closed`]).
    #[inline]
    pub fn is_closed(&self, i: u32) -> bool {
        let slot = self.slot(i);
        let k = (slot & !KIND) as usize;
        match slot & KIND {
            TRIANGLE => Mesh::is_solid(&self.mesh.triangles[k]),
            SPHERE => true,
            _ => self.others[k].is_closed(),
        }
    }

    /// Primitive `i`'s surface (an index into the world's surfaces).
    #[inline]
    pub fn surface(&self, i: u32) -> u32 {
        let slot = self.slot(i);
        let k = (slot & !KIND) as usize;
        match slot & KIND {
            TRIANGLE => self.mesh.triangles[k].surface,
            SPHERE => self.spheres[k].surface,
            _ => self.others[k].surface,
        }
    }

    /// Primitive `i`'s displacement over the shutter interval (zero when static).
    #[inline]
    pub fn motion(&self, i: u32) -> Vec3 {
        let slot = self.slot(i);
        match slot & KIND {
            OTHER => self.others[(slot & !KIND) as usize].motion,
            _ => Vec3::ZERO,
        }
    }

    /// Static triangles in the mesh, and its distinct corners.
    pub fn mesh_counts(&self) -> (usize, usize) {
        (self.mesh.triangles.len(), self.mesh.vertices.len())
    }

    /// Bytes the tables hold.
    pub fn bytes(&self) -> usize {
        self.slots.owned_bytes()
            + self.mesh.bytes()
            + self.smooth.bytes()
            + self.spheres.capacity() * std::mem::size_of::<StaticSphere>()
            + self.other_prims.capacity() * 4
            + self.others.capacity() * std::mem::size_of::<Primitive>()
            + self.other_bounds.capacity() * std::mem::size_of::<Option<Aabb>>()
            + self.flat_polygons.capacity() * 8
    }
}

#[cfg(test)]
mod tests;
