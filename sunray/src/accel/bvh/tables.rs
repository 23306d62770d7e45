//! A BVH as two flat tables, its 4-wide nodes and its leaf items (slots of the scene's
//! compact tables, in leaf order), for a prepared scene file ([`crate::prepared`]): written
//! as they are in memory and, read back, used as views into the file's mapping.
//!
//! A file is checked in full once, when it is written ([`Bvh::check`]: the checks of
//! [`super::file`]); read back, its tables get the checks that keep every query within
//! them and finite: every interior child comes after its node and exists, every leaf lies
//! within the items, every item is the slot of a bounded primitive.

use super::file::{self, BvhFileError};
use super::items::LeafItems;
use super::wide::Node;
use super::Bvh;
use crate::geometry::primitives::Slot;
use crate::geometry::Primitives;
use crate::store::Store;

impl Bvh {
    /// The nodes and the leaf items' slots.
    pub fn tables(&self) -> (&[Node], &[Slot]) {
        (&self.nodes, self.items.slots())
    }

    /// Whether the tables are views into a mapped file.
    pub fn is_mapped(&self) -> bool {
        self.nodes.is_mapped() && self.items.is_mapped()
    }

    /// The BVH of `prims` made of `nodes` and `items` (as [`Bvh::tables`] gave them, `prims`
    /// in the order it had then), with the checks of the module's text.
    pub fn from_tables(
        prims: &Primitives,
        nodes: Store<Node>,
        items: Store<Slot>,
    ) -> Result<Bvh, BvhFileError> {
        let count = items.len();
        let Some(items) = LeafItems::of_slots(prims, items) else {
            return file::bad("an item is no bounded primitive's slot");
        };
        if nodes.is_empty() && count > 0 {
            return file::bad("items but no nodes");
        }
        for (at, node) in nodes.iter().enumerate() {
            for (k, c) in node.children.iter().enumerate() {
                let fits = if c.is_leaf() {
                    (c.index as usize)
                        .checked_add(c.count as usize)
                        .is_some_and(|end| end <= count)
                } else {
                    (c.index == 0 && !node.used(k))
                        || (c.index as usize > at && (c.index as usize) < nodes.len())
                };
                if !fits {
                    return file::bad("a child past the tables or out of order");
                }
            }
        }
        let leaves4 = super::leaf4::Leaves4::new(&nodes, &items, prims);
        Ok(Bvh {
            nodes,
            items,
            leaves4,
        })
    }

    /// The full check of a tree read back ([`super::file`]'s): every box contains what is
    /// below it, every bounded primitive is in exactly one leaf.
    pub fn check(&self, prims: &Primitives) -> Result<(), BvhFileError> {
        let order: Vec<u32> = (0..self.items.len())
            .map(|k| self.items.prim(prims, k))
            .collect();
        file::check(&self.nodes, &order, prims)
    }
}

#[cfg(test)]
mod tests {
    use super::super::wide::WIDTH;
    use super::*;

    fn built() -> (Primitives, Bvh) {
        let w = crate::bench::spd_world(yari::spd::Database::Mount, 2).unwrap();
        let mut p = crate::scene::Scene::new(w).prims;
        let bvh = Bvh::build(&mut p);
        (p, bvh)
    }

    #[test]
    fn tables_put_back_are_the_tree_and_pass_the_full_check() {
        let (p, bvh) = built();
        let (n, i) = bvh.tables();
        let back = Bvh::from_tables(&p, n.to_vec().into(), i.to_vec().into()).unwrap();
        assert_eq!(back.to_bytes(&p), bvh.to_bytes(&p));
        assert!(back.check(&p).is_ok());
    }

    #[test]
    fn tables_leading_outside_or_backwards_are_refused() {
        let (p, bvh) = built();
        let (n, i) = bvh.tables();
        let mut nodes: Store<Node> = n.to_vec().into();
        let k = (0..WIDTH)
            .find(|&k| !n[0].children[k].is_leaf() && n[0].used(k))
            .unwrap();
        nodes.edit()[0].children[k].index = 0;
        assert!(Bvh::from_tables(&p, nodes, i.to_vec().into()).is_err());
        let mut items: Store<Slot> = i.to_vec().into();
        items.edit().pop();
        assert!(Bvh::from_tables(&p, n.to_vec().into(), items).is_err());
        let mut items: Store<Slot> = i.to_vec().into();
        items.edit()[0] = u32::MAX;
        assert!(Bvh::from_tables(&p, n.to_vec().into(), items).is_err());
    }
}
