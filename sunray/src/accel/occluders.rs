//! The occluder cache (POV-Ray's shadow cache; Haines and Greenberg's "last object" test): per
//! light, the opaque primitive that blocked the last shadow ray towards it. Shadow rays from
//! neighbouring points to one light tend to be blocked by the same thing, so the next one
//! tests that primitive first and, if it is still in the way, needs no walk of the tree.
//!
//! Any opaque occluder blocks the light completely, so which one answers never changes a
//! pixel; only the work counted does. The render loop empties the cache at the start of each
//! scanline, so a line's counts do not depend on what its thread rendered before.
//!
//! A shadow ray that reaches its light makes the light forget its occluder: the next ray is
//! tested against the cache only when the one before it was blocked. Kept across lit rays,
//! the old occluder was tested, and missed, by every ray of a lit region: teapot6 spent 2.2%
//! of its render's instructions and tree11 3.4% on it, while balls4 and rings7 (long runs of
//! shadowed points) took 4.5% and 6.8% more without the cache (`bench/results/limit.md`,
//! session 40).

/// The last opaque occluder of each light (lights are numbered in the world's order).
#[derive(Clone, Debug, Default)]
pub struct Occluders {
    last: Vec<Option<u32>>,
}

impl Occluders {
    /// The primitive that last blocked light `light`, if any.
    #[inline]
    pub fn get(&self, light: usize) -> Option<u32> {
        self.last.get(light).copied().flatten()
    }

    /// Remembers `prim` (opaque) as the occluder of light `light`.
    pub fn set(&mut self, light: usize, prim: u32) {
        if self.last.len() <= light {
            self.last.resize(light + 1, None);
        }
        self.last[light] = Some(prim);
    }

    /// Forgets light `light`'s occluder (a shadow ray reached it).
    #[inline]
    pub fn forget(&mut self, light: usize) {
        if let Some(o) = self.last.get_mut(light) {
            *o = None;
        }
    }

    /// Forgets every occluder.
    pub fn clear(&mut self) {
        self.last.iter_mut().for_each(|o| *o = None);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remembers_per_light_and_forgets() {
        let mut o = Occluders::default();
        assert_eq!(o.get(3), None);
        o.set(3, 17);
        o.set(0, 4);
        assert_eq!((o.get(0), o.get(1), o.get(3)), (Some(4), None, Some(17)));
        o.set(3, 9);
        assert_eq!(o.get(3), Some(9));
        o.forget(3);
        o.forget(99);
        assert_eq!((o.get(0), o.get(3)), (Some(4), None));
        o.set(3, 9);
        o.clear();
        assert_eq!((o.get(0), o.get(3), o.get(99)), (None, None, None));
    }
}
