//! The primitives of the BVH's leaves, in leaf order, as slots of the scene's
//! [`Primitives`]: a leaf's static triangles and spheres are read from the compact tables
//! directly (which keep them in a spatial order, so a leaf's items lie near each other),
//! with no copy of their geometry here. `t` comes from the same function with the same
//! inputs as for the other accelerators, so the hits are exactly theirs.

use crate::geometry::primitives::Slot;
use crate::geometry::{Primitives, RayPre, Real};
use crate::store::Store;

/// The BVH's leaf primitives in leaf order.
#[derive(Clone, Debug)]
pub struct LeafItems {
    slots: Store<Slot>,
}

impl LeafItems {
    /// The items of `order` (primitive numbers in leaf order).
    pub fn new(prims: &Primitives, order: &[u32]) -> LeafItems {
        LeafItems {
            slots: order
                .iter()
                .map(|&i| prims.slot(i))
                .collect::<Vec<_>>()
                .into(),
        }
    }

    /// The items of `slots` (slots of `prims`' tables in leaf order), checked: each is the
    /// slot of a bounded primitive.
    pub fn of_slots(prims: &Primitives, slots: Store<Slot>) -> Option<LeafItems> {
        let good = slots.iter().all(|&s| {
            let i = prims.prim_of_checked(s);
            i.is_some_and(|i| prims.slot(i) == s && prims.bounds(i).is_some())
        });
        good.then_some(LeafItems { slots })
    }

    /// The slots, in leaf order.
    pub fn slots(&self) -> &[Slot] {
        &self.slots
    }

    /// Whether the slots are a view into a mapped file.
    pub fn is_mapped(&self) -> bool {
        self.slots.is_mapped()
    }

    /// Primitive number of item `k`.
    #[inline(always)]
    pub fn prim(&self, prims: &Primitives, k: usize) -> u32 {
        prims.prim_of(self.slots[k])
    }

    /// Item `k`'s nearest `t` in `(0, t_max)`.
    #[inline(always)]
    pub fn intersect(&self, prims: &Primitives, k: usize, r: &RayPre, t_max: Real) -> Option<Real> {
        prims.intersect_slot(self.slots[k], r, 0.0, t_max)
    }

    /// How many items there are.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.slots.owned_bytes()
    }
}
