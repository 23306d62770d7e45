//! Nodes joining a running job (workers the farm's share keeper started) and retiring from it
//! (their slots go to another job): a joining node takes from the shared queue; a retiring
//! one gets no more lines, and keeps those it holds until it reports them, hands them back or
//! is gone.

use super::{GrantTable, Node, NodeState};
use std::collections::BTreeSet;

impl GrantTable {
    /// A node joins the job (a worker started while it runs); returns its index.
    pub fn add_node(&mut self) -> usize {
        self.nodes.push(Node {
            state: NodeState::Active,
            window: 0,
            live: BTreeSet::new(),
            unreported: BTreeSet::new(),
            closed: false,
        });
        self.queue.add_node();
        self.nodes.len() - 1
    }

    /// `node` retires: it gets no more lines; those it holds stay with it until it reports
    /// them, hands them back or is gone.
    pub fn close(&mut self, node: usize) {
        if let Some(n) = self.nodes.get_mut(node) {
            n.closed = true;
            n.window = 0;
        }
    }
}
