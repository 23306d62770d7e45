//! The cut through the tree that the render's footprint projects
//! ([`crate::accel::Accel::outer_boxes`]): boxes with every leaf under one of them, so a ray
//! that meets none of them reaches no primitive.

use super::{wide, Bvh};
use crate::geometry::Aabb;
use wide::WIDTH;

impl Bvh {
    /// The boxes of a cut through the tree, at most `most` of them unless the root's children
    /// are more: the root's children, then, level by level, each inner node's box replaced
    /// by its children's while the count stays within `most`. Every leaf lies under one of
    /// them, so a ray that meets none of them reaches no primitive. Empty for an empty tree.
    pub fn cut_boxes(&self, most: usize) -> Vec<Aabb> {
        let Some(root) = self.nodes.first() else {
            return Vec::new();
        };
        let slots = |n: &wide::Node| (0..WIDTH).filter(|&k| n.used(k)).collect::<Vec<_>>();
        let mut cut: Vec<(&wide::Node, usize)> =
            slots(root).into_iter().map(|k| (root, k)).collect();
        loop {
            let mut next = Vec::with_capacity(cut.len() * WIDTH);
            let mut grew = false;
            for (i, &(node, k)) in cut.iter().enumerate() {
                let child = node.children[k];
                let inner = (!child.is_leaf()).then(|| &self.nodes[child.index as usize]);
                let below = inner.map(|n| (n, slots(n)));
                match below {
                    // Replaced by its children when the cut, so far and to come, stays within
                    // `most`.
                    Some((n, ks)) if next.len() + ks.len() + (cut.len() - i - 1) <= most => {
                        next.extend(ks.into_iter().map(|k| (n, k)));
                        grew = true;
                    }
                    _ => next.push((node, k)),
                }
            }
            cut = next;
            if !grew {
                break;
            }
        }
        cut.into_iter().map(|(n, k)| n.child_box(k)).collect()
    }
}
