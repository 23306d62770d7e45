//! Scanline distribution strategies (thesis sections 4.2.2 to 4.2.4) and the queue of lines
//! still to hand out.
//!
//! - [`Strategy::Dynamic`] (SunRay III): one shared queue, top to bottom; whoever asks gets
//!   the next line, so a fast or idle host asks more often and the load balances itself.
//! - [`Strategy::Blocks`] (SunRay I): node `i` owns the `i`-th of `n` contiguous bands.
//! - [`Strategy::Interleaved`] (SunRay II): node `i` owns lines `i, i + n, i + 2n, ...`.
//!
//! All three run through the same actors. A static node draws from its own set first and
//! then from the shared queue, which holds lines given back by failed or silent nodes (and,
//! for a node that is gone, the rest of its set), so every strategy survives faults.

use std::collections::VecDeque;

/// How scanlines are dealt out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Strategy {
    /// SunRay III: each worker asks for the next line when it has room.
    Dynamic,
    /// SunRay I: n contiguous bands of scanlines, one per node.
    Blocks,
    /// SunRay II: node i renders lines i, i+n, i+2n, ...
    Interleaved,
}

impl Strategy {
    /// The command line's and the checkpoint's spelling: `dynamic`, `blocks` or `interleaved`.
    pub fn name(self) -> &'static str {
        match self {
            Strategy::Dynamic => "dynamic",
            Strategy::Blocks => "blocks",
            Strategy::Interleaved => "interleaved",
        }
    }

    /// The strategy spelled `name` ([`Strategy::name`]); `None` for anything else.
    pub fn from_name(name: &str) -> Option<Strategy> {
        [Strategy::Dynamic, Strategy::Blocks, Strategy::Interleaved]
            .into_iter()
            .find(|s| s.name() == name)
    }

    /// The lines node `node` of `nodes` owns under a static strategy, in the order it renders
    /// them; every line for [`Strategy::Dynamic`] (whose single queue is shared).
    pub fn owned_lines(self, height: u32, nodes: usize, node: usize) -> Vec<u32> {
        let n = nodes.max(1) as u32;
        let i = node as u32;
        match self {
            Strategy::Dynamic => (0..height).collect(),
            Strategy::Blocks => {
                // Bands differ in size by at most one line; the first `height % n` get one more.
                let base = height / n;
                let extra = height % n;
                let start = i * base + i.min(extra);
                let len = base + u32::from(i < extra);
                (start..(start + len).min(height)).collect()
            }
            Strategy::Interleaved => (i..height).step_by(n as usize).collect(),
        }
    }
}

impl std::fmt::Display for Strategy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Lines not yet handed out (or handed back).
#[derive(Clone, Debug)]
pub struct LineQueue {
    /// The dynamic queue, and lines given back; the next line is at the front.
    shared: VecDeque<u32>,
    /// Static strategies: each node's own set.
    own: Vec<VecDeque<u32>>,
    /// A static strategy: lines belong to nodes.
    owned: bool,
    /// Lines any node takes before its own set and the shared queue (a render to an error's
    /// next passes, once the lines between passes hold too much).
    first: VecDeque<u32>,
}

impl LineQueue {
    /// The lines of an image of `height` lines for `nodes` nodes, leaving out those for which
    /// `finished` is true (a resumed job).
    pub fn new(
        strategy: Strategy,
        height: u32,
        nodes: usize,
        finished: impl Fn(u32) -> bool,
    ) -> LineQueue {
        let keep = |lines: Vec<u32>| -> VecDeque<u32> {
            lines.into_iter().filter(|&y| !finished(y)).collect()
        };
        match strategy {
            // No node yet (a job waiting in the farm's queue): every line is anyone's.
            Strategy::Dynamic | Strategy::Blocks | Strategy::Interleaved if nodes == 0 => {
                LineQueue {
                    shared: keep(Strategy::Dynamic.owned_lines(height, 1, 0)),
                    own: Vec::new(),
                    owned: false,
                    first: VecDeque::new(),
                }
            }
            Strategy::Dynamic => LineQueue {
                shared: keep(strategy.owned_lines(height, nodes, 0)),
                own: vec![VecDeque::new(); nodes],
                owned: false,
                first: VecDeque::new(),
            },
            Strategy::Blocks | Strategy::Interleaved => LineQueue {
                shared: VecDeque::new(),
                own: (0..nodes)
                    .map(|i| keep(strategy.owned_lines(height, nodes, i)))
                    .collect(),
                owned: true,
                first: VecDeque::new(),
            },
        }
    }

    /// The next line for `node`: one queued first, else from its own set, else from the
    /// shared queue.
    pub fn next_for(&mut self, node: usize) -> Option<u32> {
        if let Some(y) = self.first.pop_front() {
            return Some(y);
        }
        if let Some(y) = self.own.get_mut(node).and_then(|q| q.pop_front()) {
            return Some(y);
        }
        self.shared.pop_front()
    }

    /// Puts a line back at the front of the shared queue (it is re-rendered first).
    pub fn give_back(&mut self, line: u32) {
        self.shared.push_front(line);
    }

    /// Queues a line behind every line waiting (its next pass), in the shared queue.
    pub fn push_back(&mut self, line: u32) {
        self.shared.push_back(line);
    }

    /// Queues a line ahead of every node's own set and the shared queue, behind the lines
    /// queued first before it.
    pub fn push_first(&mut self, line: u32) {
        self.first.push_back(line);
    }

    /// `node` hands back a line it did not start: to the front of its own set under a static
    /// strategy (the node still owns it), else of the shared queue.
    pub fn return_line(&mut self, node: usize, line: u32) {
        match self.own.get_mut(node) {
            Some(own) if self.owned => own.push_front(line),
            _ => self.shared.push_front(line),
        }
    }

    /// A node joins: it has no set of its own and takes from the shared queue (the lines of
    /// nodes gone, under a static strategy).
    pub fn add_node(&mut self) {
        self.own.push(VecDeque::new());
    }

    /// A node is gone: the rest of its own set goes to the shared queue, in order.
    pub fn release_node(&mut self, node: usize) {
        if let Some(q) = self.own.get_mut(node) {
            let rest = std::mem::take(q);
            self.shared.extend(rest);
        }
    }

    /// True when `node` would get no line.
    pub fn is_empty_for(&self, node: usize) -> bool {
        self.first.is_empty()
            && self.shared.is_empty()
            && self.own.get(node).is_none_or(|q| q.is_empty())
    }

    /// Lines waiting, over all sets.
    pub fn len(&self) -> usize {
        self.first.len() + self.shared.len() + self.own.iter().map(|q| q.len()).sum::<usize>()
    }

    /// True when no line waits in any set.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drain(q: &mut LineQueue, node: usize) -> Vec<u32> {
        std::iter::from_fn(|| q.next_for(node)).collect()
    }

    #[test]
    fn blocks_are_contiguous_and_cover_the_image_once() {
        for (height, nodes) in [(10, 3), (8, 8), (5, 7), (512, 6)] {
            let mut all = Vec::new();
            let mut sizes = Vec::new();
            for i in 0..nodes {
                let own = Strategy::Blocks.owned_lines(height, nodes, i);
                assert!(own.windows(2).all(|w| w[1] == w[0] + 1), "{own:?}");
                sizes.push(own.len());
                all.extend(own);
            }
            assert_eq!(all, (0..height).collect::<Vec<_>>());
            let (min, max) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
            assert!(max - min <= 1, "{sizes:?}");
        }
        assert_eq!(Strategy::Blocks.owned_lines(10, 3, 0), vec![0, 1, 2, 3]);
        assert_eq!(Strategy::Blocks.owned_lines(10, 3, 2), vec![7, 8, 9]);
    }

    #[test]
    fn interleaved_is_i_plus_j_n() {
        assert_eq!(Strategy::Interleaved.owned_lines(10, 3, 1), vec![1, 4, 7]);
        let mut all: Vec<u32> = (0..4)
            .flat_map(|i| Strategy::Interleaved.owned_lines(13, 4, i))
            .collect();
        all.sort();
        assert_eq!(all, (0..13).collect::<Vec<_>>());
    }

    #[test]
    fn dynamic_queue_is_shared_top_to_bottom() {
        let mut q = LineQueue::new(Strategy::Dynamic, 5, 2, |_| false);
        assert_eq!(q.next_for(1), Some(0));
        assert_eq!(q.next_for(0), Some(1));
        q.give_back(0);
        assert_eq!(q.next_for(0), Some(0), "a given-back line comes first");
        assert_eq!(drain(&mut q, 1), vec![2, 3, 4]);
        assert!(q.is_empty());
    }

    #[test]
    fn static_nodes_use_their_own_set_then_shared_lines() {
        let mut q = LineQueue::new(Strategy::Interleaved, 6, 2, |_| false);
        assert_eq!(q.next_for(0), Some(0));
        assert_eq!(q.next_for(1), Some(1));
        q.give_back(1);
        assert_eq!(q.next_for(0), Some(2), "own set first");
        // Node 1 is gone: the rest of its set is anyone's.
        q.release_node(1);
        assert_eq!(drain(&mut q, 0), vec![4, 1, 3, 5]);
        assert!(q.is_empty_for(1));
    }

    #[test]
    fn a_returned_line_stays_with_its_static_node() {
        let mut q = LineQueue::new(Strategy::Interleaved, 6, 2, |_| false);
        assert_eq!((q.next_for(1), q.next_for(1)), (Some(1), Some(3)));
        q.return_line(1, 3);
        q.return_line(1, 1);
        assert_eq!(drain(&mut q, 0), vec![0, 2, 4], "node 0 does not get them");
        assert_eq!(drain(&mut q, 1), vec![1, 3, 5]);
        let mut q = LineQueue::new(Strategy::Dynamic, 3, 2, |_| false);
        assert_eq!(q.next_for(1), Some(0));
        q.return_line(1, 0);
        assert_eq!(q.next_for(0), Some(0), "dynamic: anyone's, first");
    }

    #[test]
    fn finished_lines_are_left_out() {
        let q = LineQueue::new(Strategy::Blocks, 8, 2, |y| y % 2 == 0);
        assert_eq!(q.len(), 4);
        let mut q = LineQueue::new(Strategy::Dynamic, 8, 2, |y| y < 6);
        assert_eq!(drain(&mut q, 0), vec![6, 7]);
    }

    #[test]
    fn names_round_trip() {
        for s in [Strategy::Dynamic, Strategy::Blocks, Strategy::Interleaved] {
            assert_eq!(Strategy::from_name(s.name()), Some(s));
        }
        assert_eq!(Strategy::from_name("random"), None);
    }
}
