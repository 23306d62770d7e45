//! The intersection buffer ("mailbox", thesis 4.2.1): per ray, the result of each primitive
//! already tested, so a primitive that straddles several voxels is tested once per ray.

use crate::geometry::Real;

/// One stored result per primitive, stamped with the ray it belongs to; a disabled mailbox stores
/// nothing.
#[derive(Clone, Debug)]
pub struct Mailbox {
    enabled: bool,
    ray: u32,
    /// (ray stamp, t or +inf for a miss) per primitive.
    slots: Vec<(u32, Real)>,
}

impl Mailbox {
    /// A mailbox for `prims` primitives; when not `enabled`, no memory and every look-up misses.
    pub fn new(prims: usize, enabled: bool) -> Mailbox {
        let slots = if enabled {
            vec![(0, 0.0); prims]
        } else {
            Vec::new()
        };
        Mailbox {
            enabled,
            ray: 0,
            slots,
        }
    }

    /// Whether results are stored at all (`--mailbox`).
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Starts a new ray: all slots become stale.
    pub fn next_ray(&mut self) {
        if !self.enabled {
            return;
        }
        self.ray = self.ray.wrapping_add(1);
        if self.ray == 0 {
            self.slots.iter_mut().for_each(|s| s.0 = 0);
            self.ray = 1;
        }
    }

    /// The stored result for `prim` on this ray, if any: `Some(None)` = known miss.
    #[inline]
    pub fn get(&self, prim: u32) -> Option<Option<Real>> {
        let (stamp, t) = *self.slots.get(prim as usize)?;
        (stamp == self.ray && self.enabled).then_some(if t.is_finite() { Some(t) } else { None })
    }

    /// Stores the result for `prim` on this ray (`None` = a miss).
    #[inline]
    pub fn put(&mut self, prim: u32, t: Option<Real>) {
        if let Some(s) = self.slots.get_mut(prim as usize) {
            *s = (self.ray, t.unwrap_or(Real::INFINITY));
        }
    }
}
