//! The grant table: which scanline is with which node under which grant number, and what is
//! left to hand out. Plain logic (no I/O, time passed in), so every rule is unit-tested.
//!
//! Rules (DESIGN.md section 3, invariant 2):
//! - A line is handed out under a fresh grant number; a node's window is how many lines it
//!   asked to hold, and its credit is its window less the lines it holds: those handed to it
//!   and not yet reported by it (a line another node finished meanwhile is still in its
//!   queue: it renders it all the same).
//! - The first completion of a line wins; a later one (from a duplicate or a revoked grant)
//!   is reported [`Completion::Duplicate`] and dropped. A completion from a revoked grant of a
//!   line that is not in yet is accepted: the pixels are the same wherever they were rendered.
//! - A node that is gone gives its outstanding lines back at once (to the front of the
//!   queue), and a static node's unrendered set becomes anyone's.
//! - A node may hand back lines it has not started (its window shrank): they go to the front
//!   of the queue, or of its own set under a static strategy.
//! - A node whose oldest grant is older than the timeout is marked silent: its lines go back
//!   too, and it gets no more work until it is heard from again.
//! - When nothing is left to hand out, a node with room may duplicate the oldest outstanding
//!   line of another node (at most two copies of a line).
//! - With a target error a line is rendered in passes: each grant is for the line's current
//!   pass, and a completion counts only for that pass (a late one of an earlier pass is a
//!   duplicate). A line whose pass is in and that needs another ([`GrantTable::another_pass`])
//!   goes to the back of the shared queue, behind the lines still on earlier passes, so the
//!   whole image is refined pass by pass; or, while the lines between passes hold more than
//!   the controller allows them, to the front, so a large image is finished band by band.

use super::strategy::{LineQueue, Strategy};
use std::collections::BTreeSet;
use std::time::Duration;
use tokio::time::Instant;

/// A grant number (1, 2, ...; never reused within a job).
pub type GrantId = u64;

/// One line handed to one node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Assignment {
    /// The node's index (0-based, in spawn order).
    pub node: usize,
    /// The scanline, 0 at the top.
    pub line: u32,
    /// The line's pass (0 without a target error).
    pub pass: u32,
    /// The fresh grant number the completion must quote.
    pub grant: GrantId,
    /// A second copy of a line still outstanding elsewhere.
    pub duplicate: bool,
}

/// What became of a reported completion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Completion {
    /// The first completion of the line: keep its pixels.
    Accepted,
    /// The line was already in: drop this one.
    Duplicate,
    /// No such grant for this line and node: ignore it.
    Unknown,
}

/// A node as the table sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeState {
    /// Answering; gets work while it has credit.
    Active,
    /// Timed out; gets no work until it is heard from.
    Silent,
    /// Exited or lost; never gets work again.
    Gone,
}

#[derive(Clone, Debug)]
struct Grant {
    line: u32,
    pass: u32,
    node: usize,
    issued: Instant,
    live: bool,
}

#[derive(Clone, Debug, PartialEq)]
enum LineState {
    Queued,
    /// Live grants for the line.
    Out(Vec<GrantId>),
    Done,
}

#[derive(Clone, Debug)]
struct Node {
    state: NodeState,
    /// Lines the node wants to hold.
    window: u32,
    live: BTreeSet<GrantId>,
    /// Grants handed to it that it has not reported, live or not.
    unreported: BTreeSet<GrantId>,
    /// Retiring: it gets no more lines, whatever window it says.
    closed: bool,
}

impl Node {
    /// Lines it may be given now.
    fn credit(&self) -> usize {
        (self.window as usize).saturating_sub(self.unreported.len())
    }
}

/// Counts of the table's fault handling.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GrantCounts {
    /// Lines given back to the queue (lost, timed out).
    pub requeued: u64,
    /// Duplicate grants issued for stragglers.
    pub duplicated: u64,
    /// Completions dropped because the line was already in.
    pub dropped: u64,
    /// Lines handed back unstarted by nodes whose window shrank.
    pub released: u64,
}

/// The grant table of one job: lines, grants, nodes and the queue of lines to hand out.
#[derive(Clone, Debug)]
pub struct GrantTable {
    lines: Vec<LineState>,
    /// Each line's current pass.
    passes: Vec<u32>,
    /// Grant `g` is `grants[g - 1]`.
    grants: Vec<Grant>,
    nodes: Vec<Node>,
    queue: LineQueue,
    done: u32,
    counts: GrantCounts,
}

impl GrantTable {
    /// A table for `height` lines and `nodes` nodes; lines with `finished[y]` already done.
    pub fn new(strategy: Strategy, height: u32, nodes: usize, finished: &[bool]) -> GrantTable {
        let is_done = |y: u32| finished.get(y as usize).copied().unwrap_or(false);
        let lines: Vec<LineState> = (0..height)
            .map(|y| {
                if is_done(y) {
                    LineState::Done
                } else {
                    LineState::Queued
                }
            })
            .collect();
        let done = lines.iter().filter(|s| **s == LineState::Done).count() as u32;
        GrantTable {
            passes: vec![0; lines.len()],
            lines,
            grants: Vec::new(),
            nodes: vec![
                Node {
                    state: NodeState::Active,
                    window: 0,
                    live: BTreeSet::new(),
                    unreported: BTreeSet::new(),
                    closed: false,
                };
                nodes
            ],
            queue: LineQueue::new(strategy, height, nodes, is_done),
            done,
            counts: GrantCounts::default(),
        }
    }

    /// Lines in the image.
    pub fn height(&self) -> u32 {
        self.lines.len() as u32
    }

    /// Lines whose first completion is in (resumed lines included).
    pub fn done(&self) -> u32 {
        self.done
    }

    /// True when every line is in.
    pub fn is_finished(&self) -> bool {
        self.done as usize == self.lines.len()
    }

    /// True when `line` is in (false for a line outside the image).
    pub fn is_line_done(&self, line: u32) -> bool {
        self.lines.get(line as usize) == Some(&LineState::Done)
    }

    /// The table's fault handling counts so far.
    pub fn counts(&self) -> GrantCounts {
        self.counts
    }

    /// The state of `node`; `None` for an index the table does not know.
    pub fn node_state(&self, node: usize) -> Option<NodeState> {
        self.nodes.get(node).map(|n| n.state)
    }

    /// Nodes not gone (active or silent).
    pub fn live_nodes(&self) -> usize {
        self.nodes
            .iter()
            .filter(|n| n.state != NodeState::Gone)
            .count()
    }

    /// Nodes that are answering and may get work.
    pub fn active_nodes(&self) -> usize {
        self.nodes
            .iter()
            .filter(|n| n.state == NodeState::Active)
            .count()
    }

    /// Lines `node` holds under live grants.
    pub fn outstanding(&self, node: usize) -> usize {
        self.nodes.get(node).map_or(0, |n| n.live.len())
    }

    /// `node` wants to hold `window` lines (it is heard from: a silent node is active again).
    /// The window is absolute: asking again for the same window adds nothing.
    pub fn set_window(&mut self, node: usize, window: u32) {
        let Some(n) = self.nodes.get_mut(node) else {
            return;
        };
        if n.state == NodeState::Gone {
            return;
        }
        n.state = NodeState::Active;
        n.window = if n.closed { 0 } else { window };
    }

    /// Hands out queued lines to active nodes with credit, one per node per round.
    pub fn assign(&mut self, now: Instant) -> Vec<Assignment> {
        let mut out = Vec::new();
        loop {
            let mut progress = false;
            for node in 0..self.nodes.len() {
                if self.nodes[node].state != NodeState::Active || self.nodes[node].credit() == 0 {
                    continue;
                }
                while let Some(line) = self.queue.next_for(node) {
                    if self.lines[line as usize] == LineState::Queued {
                        out.push(self.issue(node, line, now, false));
                        progress = true;
                        break;
                    }
                    // Finished meanwhile by a revoked grant: skip it.
                }
            }
            if !progress {
                return out;
            }
        }
    }

    fn issue(&mut self, node: usize, line: u32, now: Instant, duplicate: bool) -> Assignment {
        let pass = self.passes[line as usize];
        self.grants.push(Grant {
            line,
            pass,
            node,
            issued: now,
            live: true,
        });
        let grant = self.grants.len() as GrantId;
        match &mut self.lines[line as usize] {
            LineState::Out(gs) => gs.push(grant),
            state => *state = LineState::Out(vec![grant]),
        }
        self.nodes[node].live.insert(grant);
        self.nodes[node].unreported.insert(grant);
        if duplicate {
            self.counts.duplicated += 1;
        }
        Assignment {
            node,
            line,
            pass,
            grant,
            duplicate,
        }
    }

    /// `node` reports pass `pass` of `line` finished under `grant`.
    pub fn complete(&mut self, node: usize, grant: GrantId, line: u32, pass: u32) -> Completion {
        let Some(g) = grant
            .checked_sub(1)
            .and_then(|i| self.grants.get(i as usize))
        else {
            return Completion::Unknown;
        };
        if g.line != line || g.node != node || g.pass != pass {
            return Completion::Unknown;
        }
        let n = &mut self.nodes[node];
        n.unreported.remove(&grant);
        if n.state == NodeState::Silent {
            n.state = NodeState::Active;
        }
        if g.live {
            self.retire(grant);
        }
        self.finish(line, pass)
    }

    /// `node` reports pass `pass` of `line` finished under a grant of the job's previous
    /// controller (grant 0: a worker this controller took over). Kept like any first
    /// completion of the line's current pass.
    pub fn complete_inherited(&mut self, node: usize, line: u32, pass: u32) -> Completion {
        if line as usize >= self.lines.len() || node >= self.nodes.len() {
            return Completion::Unknown;
        }
        if self.nodes[node].state == NodeState::Silent {
            self.nodes[node].state = NodeState::Active;
        }
        self.finish(line, pass)
    }

    /// The line's pass is in: the first completion is kept, its other copies retired.
    fn finish(&mut self, line: u32, pass: u32) -> Completion {
        // The rule the controller reads before decoding a pass's answer (`awaits`).
        if !self.awaits(line, pass) {
            self.counts.dropped += 1;
            return Completion::Duplicate;
        }
        let others = match std::mem::replace(&mut self.lines[line as usize], LineState::Done) {
            LineState::Out(gs) => gs,
            _ => Vec::new(),
        };
        for other in others {
            self.retire(other);
        }
        self.done += 1;
        Completion::Accepted
    }

    /// `node` hands back lines it did not start (given in the order it held them): they go
    /// back to the queue, ahead of the rest and in the same order; a static node keeps
    /// them. Grants that are not `node`'s or no longer live are skipped.
    pub fn release(&mut self, node: usize, grants: &[GrantId]) {
        for &grant in grants.iter().rev() {
            let Some(g) = grant
                .checked_sub(1)
                .and_then(|i| self.grants.get(i as usize))
            else {
                continue;
            };
            if g.node != node {
                continue;
            }
            let (line, live) = (g.line, g.live);
            self.nodes[node].unreported.remove(&grant);
            if !live {
                continue;
            }
            self.retire(grant);
            let state = &mut self.lines[line as usize];
            if matches!(state, LineState::Out(gs) if gs.is_empty()) {
                *state = LineState::Queued;
                self.queue.return_line(node, line);
                self.counts.released += 1;
            }
        }
    }

    /// Marks a grant dead and takes it off its node and line (the line's state is left to
    /// the caller).
    fn retire(&mut self, grant: GrantId) {
        let g = &mut self.grants[grant as usize - 1];
        g.live = false;
        let (line, node) = (g.line, g.node);
        self.nodes[node].live.remove(&grant);
        if let LineState::Out(gs) = &mut self.lines[line as usize] {
            gs.retain(|&x| x != grant);
        }
    }

    /// Takes a live grant back; its line returns to the queue if no other copy is out.
    fn revoke(&mut self, grant: GrantId) {
        self.retire(grant);
        let line = self.grants[grant as usize - 1].line;
        let state = &mut self.lines[line as usize];
        if matches!(state, LineState::Out(gs) if gs.is_empty()) {
            *state = LineState::Queued;
            self.queue.give_back(line);
            self.counts.requeued += 1;
        }
    }

    fn revoke_all(&mut self, node: usize) -> usize {
        let live: Vec<GrantId> = self.nodes[node].live.iter().copied().collect();
        for g in &live {
            self.revoke(*g);
        }
        // Its next message says again how many lines it wants, and it starts afresh.
        self.nodes[node].window = 0;
        self.nodes[node].unreported.clear();
        self.queue.release_node(node);
        live.len()
    }

    /// `node` exited or its host was lost: its lines go back. Returns how many it held.
    pub fn node_gone(&mut self, node: usize) -> usize {
        if self
            .nodes
            .get(node)
            .is_none_or(|n| n.state == NodeState::Gone)
        {
            return 0;
        }
        self.nodes[node].state = NodeState::Gone;
        self.revoke_all(node)
    }

    /// Active nodes holding a grant older than `timeout` become silent and give their lines
    /// back. Returns those nodes with how many lines each gave back.
    pub fn expire(&mut self, now: Instant, timeout: Duration) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for node in 0..self.nodes.len() {
            let n = &self.nodes[node];
            if n.state != NodeState::Active {
                continue;
            }
            let late = n.live.iter().any(|&g| {
                now.saturating_duration_since(self.grants[g as usize - 1].issued) > timeout
            });
            if late {
                out.push((node, self.silence(node)));
            }
        }
        out
    }

    /// Marks an active `node` silent (it gets no work until heard from again) and gives its
    /// lines back to the queue; returns how many.
    pub fn silence(&mut self, node: usize) -> usize {
        match self.nodes.get_mut(node) {
            Some(n) if n.state == NodeState::Active => n.state = NodeState::Silent,
            _ => return 0,
        }
        self.revoke_all(node)
    }

    /// With nothing left to hand out, gives each active node with credit a copy of the oldest
    /// line outstanding on another node for at least `min_age` (one extra copy per line).
    pub fn duplicate_stragglers(&mut self, now: Instant, min_age: Duration) -> Vec<Assignment> {
        let mut candidates: Vec<(Instant, u32, usize)> = self
            .lines
            .iter()
            .enumerate()
            .filter_map(|(y, s)| match s {
                LineState::Out(gs) if gs.len() == 1 => {
                    let g = &self.grants[gs[0] as usize - 1];
                    (now.saturating_duration_since(g.issued) >= min_age)
                        .then_some((g.issued, y as u32, g.node))
                }
                _ => None,
            })
            .collect();
        candidates.sort();
        let mut out = Vec::new();
        for node in 0..self.nodes.len() {
            while self.nodes[node].state == NodeState::Active
                && self.nodes[node].credit() > 0
                && self.queue.is_empty_for(node)
            {
                let Some(i) = candidates.iter().position(|c| c.2 != node) else {
                    break;
                };
                let (_, line, _) = candidates.remove(i);
                out.push(self.issue(node, line, now, true));
            }
        }
        out
    }
}

mod joining;
mod passes;
#[cfg(test)]
mod tests;
