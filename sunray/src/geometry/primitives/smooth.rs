//! The side table of smooth triangles: for each triangle of a polygon with vertex normals,
//! its primitive number and the indices of its three corner normals (16 bytes); the unit
//! normals themselves are stored once each (24 bytes), matched by their exact bits through a
//! table of 4-byte slots while the scene is built. Flat triangles have no entry, so a scene
//! without vertex normals keeps the mesh's 24 bytes a triangle and an empty table.
//!
//! A triangle whose polygon's normals point away from its plane normal keeps them as given
//! and is marked to negate them (the top bit of its first index), so the triangles meeting
//! at a corner share its normal whichever way each is wound.
//!
//! Entries are added in primitive order (the builder numbers primitives as it goes), so the
//! table is sorted by primitive number and a hit finds its entry where a run of consecutive
//! numbers puts it, or else by binary search, only when the table is not empty.

use super::super::Vec3;

/// In an entry's first normal index: the normals are negated.
const NEGATE: u32 = 1 << 31;
/// An empty slot of the normal index.
const EMPTY: u32 = u32::MAX;

/// One smooth triangle: its primitive number and its corners' normals.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
struct Entry {
    prim: u32,
    normals: [u32; 3],
}

/// Corner normals of the smooth triangles (see the module's text).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct SmoothTable {
    entries: Vec<Entry>,
    /// Distinct unit normals.
    normals: Vec<Vec3>,
    /// While the table is built: open addressing (linear probing) over `normals`, each slot
    /// an index into it or [`EMPTY`]; a power of two long, at most half full. Not kept in a
    /// prepared scene (a finished table has none).
    #[serde(skip)]
    slots: Vec<u32>,
}

/// A hash of a normal's bits (a multiply-xorshift mix of its three words).
fn hash(n: Vec3) -> u64 {
    let mut h: u64 = 0x9e37_79b9_7f4a_7c15;
    for w in n.to_array().map(f64::to_bits) {
        h = (h ^ w).wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 32;
    }
    h
}

impl SmoothTable {
    /// True when no triangle is smooth.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// How many triangles are smooth, and how many distinct normals they use.
    pub fn counts(&self) -> (usize, usize) {
        (self.entries.len(), self.normals.len())
    }

    /// Makes primitive `prim` (numbered after every primitive added before) a smooth
    /// triangle with corner normals `normals` (unit, in the corners' order), to be used
    /// negated when `negate`. Returns false, adding nothing, if `prim` is not above the last
    /// one added or the table is full (2^31 distinct normals).
    pub fn add(&mut self, prim: u32, normals: [Vec3; 3], negate: bool) -> bool {
        if self.entries.last().is_some_and(|e| e.prim >= prim)
            || self.normals.len() + 3 >= NEGATE as usize
        {
            return false;
        }
        let mut ids = normals.map(|n| self.normal_id(n));
        if negate {
            ids[0] |= NEGATE;
        }
        self.entries.push(Entry { prim, normals: ids });
        true
    }

    /// The index of normal `n` (by its exact bits), added if new.
    fn normal_id(&mut self, n: Vec3) -> u32 {
        if 2 * (self.normals.len() + 1) > self.slots.len() {
            self.grow();
        }
        let mask = self.slots.len() - 1;
        let bits = n.to_array().map(f64::to_bits);
        let mut k = hash(n) as usize & mask;
        loop {
            match self.slots[k] {
                EMPTY => {
                    let id = self.normals.len() as u32;
                    self.slots[k] = id;
                    self.normals.push(n);
                    return id;
                }
                id if self.normals[id as usize].to_array().map(f64::to_bits) == bits => return id,
                _ => k = (k + 1) & mask,
            }
        }
    }

    /// Doubles the slots (at least 64) and re-inserts every normal.
    fn grow(&mut self) {
        let len = (self.slots.len() * 2).max(64);
        self.slots = vec![EMPTY; len];
        let mask = len - 1;
        for (id, n) in self.normals.iter().enumerate() {
            let mut k = hash(*n) as usize & mask;
            while self.slots[k] != EMPTY {
                k = (k + 1) & mask;
            }
            self.slots[k] = id as u32;
        }
    }

    /// The corner normals of primitive `prim`, if it is a smooth triangle.
    ///
    /// A mesh's smooth triangles are numbered one after another, so the entry sits where
    /// its number's distance from the first entry's says; that guess is checked, and a
    /// binary search is left for the numbers a gap has moved.
    #[inline]
    pub fn get(&self, prim: u32) -> Option<[Vec3; 3]> {
        let first = self.entries.first()?.prim;
        let guess = prim.wrapping_sub(first) as usize;
        let k = match self.entries.get(guess) {
            Some(e) if e.prim == prim => guess,
            _ if prim < first => return None,
            _ => self.entries.binary_search_by_key(&prim, |e| e.prim).ok()?,
        };
        let ids = self.entries[k].normals;
        let sign = if ids[0] & NEGATE != 0 { -1.0 } else { 1.0 };
        Some(ids.map(|i| self.normals[(i & !NEGATE) as usize] * sign))
    }

    /// Ends the building: forgets the normal index.
    pub fn finish(&mut self) {
        self.slots = Vec::new();
        self.entries.shrink_to_fit();
        self.normals.shrink_to_fit();
    }

    /// Bytes held (for the memory figures).
    pub fn bytes(&self) -> usize {
        self.entries.capacity() * std::mem::size_of::<Entry>()
            + self.normals.capacity() * std::mem::size_of::<Vec3>()
            + self.slots.capacity() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_are_found_by_primitive_and_normals_shared() {
        let mut t = SmoothTable::default();
        assert!(t.is_empty() && t.get(0).is_none());
        assert_eq!(t.bytes(), 0, "an empty table costs nothing");
        assert!(t.add(3, [Vec3::X, Vec3::Y, Vec3::Z], false));
        // Negated normals share the entries of the normals as given.
        assert!(t.add(7, [Vec3::Z, Vec3::Y, Vec3::X], true));
        assert!(
            !t.add(7, [Vec3::X; 3], false),
            "primitive numbers only go up"
        );
        t.finish();
        assert_eq!(t.get(3), Some([Vec3::X, Vec3::Y, Vec3::Z]));
        assert_eq!(t.get(7), Some([-Vec3::Z, -Vec3::Y, -Vec3::X]));
        assert_eq!(t.get(4), None);
        assert_eq!(t.counts(), (2, 3));
        assert_eq!(t.bytes(), 2 * 16 + 3 * 24);
        // -0 and +0 are different normals.
        let mut z = SmoothTable::default();
        z.add(
            0,
            [Vec3::new(0.0, 0.0, 1.0), Vec3::new(-0.0, 0.0, 1.0), Vec3::Z],
            false,
        );
        assert_eq!(z.counts(), (1, 2));
    }

    /// Runs of consecutive smooth primitives with gaps between them (flat triangles, other
    /// shapes): every number is found where it is, through the guess or the search, and no
    /// number without an entry finds one, below, inside or past the runs.
    #[test]
    fn runs_with_gaps_are_found_by_guess_or_search() {
        let mut t = SmoothTable::default();
        let n = |i: u32| Vec3::new(1.0, i as f64, 2.0).normalize();
        let smooth = |p: u32| (5..9).contains(&p) || (12..13).contains(&p) || (20..40).contains(&p);
        for prim in (0..50).filter(|&p| smooth(p)) {
            assert!(t.add(prim, [n(prim), n(prim), n(prim + 1)], false));
        }
        t.finish();
        for prim in 0..60 {
            let want = smooth(prim).then(|| [n(prim), n(prim), n(prim + 1)]);
            assert_eq!(t.get(prim), want, "{prim}");
        }
        assert_eq!(t.get(u32::MAX), None);
    }

    #[test]
    fn many_normals_are_stored_once_each_across_growth() {
        let mut t = SmoothTable::default();
        let n = |i: u32| Vec3::new(i as f64, 1.0, (i % 7) as f64).normalize();
        for prim in 0..5000u32 {
            assert!(t.add(prim, [n(prim), n(prim + 1), n(prim / 2)], prim % 3 == 0));
        }
        assert_eq!(t.counts(), (5000, 5001));
        for prim in [0u32, 1, 2, 999, 4999] {
            let s = if prim % 3 == 0 { -1.0 } else { 1.0 };
            assert_eq!(
                t.get(prim),
                Some([n(prim) * s, n(prim + 1) * s, n(prim / 2) * s])
            );
        }
    }
}
