//! The grant table: which scanline is with which node under which grant number, and what is
//! left to hand out. Plain logic (no I/O, time passed in), so every rule is unit-tested.
//!
//! Rules (DESIGN.md section 3, invariant 2):
//! - A line is handed out under a fresh grant number; a node's credit is how many more lines
//!   it asked for.
//! - The first completion of a line wins; a later one (from a duplicate or a revoked grant)
//!   is reported [`Completion::Duplicate`] and dropped. A completion from a revoked grant of a
//!   line that is not in yet is accepted: the pixels are the same wherever they were rendered.
//! - A node that is gone gives its outstanding lines back at once (to the front of the
//!   queue), and a static node's unrendered set becomes anyone's.
//! - A node whose oldest grant is older than the timeout is marked silent: its lines go back
//!   too, and it gets no more work until it is heard from again.
//! - When nothing is left to hand out, a node with room may duplicate the oldest outstanding
//!   line of another node (at most two copies of a line).

use super::strategy::{LineQueue, Strategy};
use std::collections::BTreeSet;
use std::time::{Duration, Instant};

/// A grant number (1, 2, ...; never reused within a job).
pub type GrantId = u64;

/// One line handed to one node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Assignment {
    pub node: usize,
    pub line: u32,
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
    credit: u32,
    live: BTreeSet<GrantId>,
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
}

#[derive(Clone, Debug)]
pub struct GrantTable {
    lines: Vec<LineState>,
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
            lines,
            grants: Vec::new(),
            nodes: vec![
                Node {
                    state: NodeState::Active,
                    credit: 0,
                    live: BTreeSet::new(),
                };
                nodes
            ],
            queue: LineQueue::new(strategy, height, nodes, is_done),
            done,
            counts: GrantCounts::default(),
        }
    }

    pub fn height(&self) -> u32 {
        self.lines.len() as u32
    }

    pub fn done(&self) -> u32 {
        self.done
    }

    pub fn is_finished(&self) -> bool {
        self.done as usize == self.lines.len()
    }

    pub fn is_line_done(&self, line: u32) -> bool {
        self.lines.get(line as usize) == Some(&LineState::Done)
    }

    pub fn counts(&self) -> GrantCounts {
        self.counts
    }

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

    /// `node` asks for `lines` more lines (it is heard from: a silent node is active again).
    pub fn request(&mut self, node: usize, lines: u32) {
        let Some(n) = self.nodes.get_mut(node) else {
            return;
        };
        if n.state == NodeState::Gone {
            return;
        }
        n.state = NodeState::Active;
        n.credit = n.credit.saturating_add(lines);
    }

    /// Hands out queued lines to active nodes with credit, one per node per round.
    pub fn assign(&mut self, now: Instant) -> Vec<Assignment> {
        let mut out = Vec::new();
        loop {
            let mut progress = false;
            for node in 0..self.nodes.len() {
                if self.nodes[node].state != NodeState::Active || self.nodes[node].credit == 0 {
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
        self.grants.push(Grant {
            line,
            node,
            issued: now,
            live: true,
        });
        let grant = self.grants.len() as GrantId;
        match &mut self.lines[line as usize] {
            LineState::Out(gs) => gs.push(grant),
            state => *state = LineState::Out(vec![grant]),
        }
        let n = &mut self.nodes[node];
        n.credit -= 1;
        n.live.insert(grant);
        if duplicate {
            self.counts.duplicated += 1;
        }
        Assignment {
            node,
            line,
            grant,
            duplicate,
        }
    }

    /// `node` reports `line` finished under `grant`.
    pub fn complete(&mut self, node: usize, grant: GrantId, line: u32) -> Completion {
        let Some(g) = grant
            .checked_sub(1)
            .and_then(|i| self.grants.get(i as usize))
        else {
            return Completion::Unknown;
        };
        if g.line != line || g.node != node {
            return Completion::Unknown;
        }
        if self.nodes[node].state == NodeState::Silent {
            self.nodes[node].state = NodeState::Active;
        }
        if g.live {
            self.retire(grant);
        }
        match &mut self.lines[line as usize] {
            LineState::Done => {
                self.counts.dropped += 1;
                Completion::Duplicate
            }
            state => {
                let others = match std::mem::replace(state, LineState::Done) {
                    LineState::Out(gs) => gs,
                    _ => Vec::new(),
                };
                for other in others {
                    self.retire(other);
                }
                self.done += 1;
                Completion::Accepted
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
        self.nodes[node].credit = 0;
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
                self.nodes[node].state = NodeState::Silent;
                out.push((node, self.revoke_all(node)));
            }
        }
        out
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
                && self.nodes[node].credit > 0
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

#[cfg(test)]
mod tests {
    use super::*;

    fn t(ms: u64) -> Instant {
        thread_local!(static T0: Instant = Instant::now());
        T0.with(|t0| *t0 + Duration::from_millis(ms))
    }

    fn lines(a: &[Assignment]) -> Vec<u32> {
        a.iter().map(|a| a.line).collect()
    }

    #[test]
    fn assigns_round_robin_within_credit() {
        let mut g = GrantTable::new(Strategy::Dynamic, 6, 2, &[]);
        g.request(0, 2);
        g.request(1, 1);
        let a = g.assign(t(0));
        assert_eq!(lines(&a), vec![0, 1, 2]);
        assert_eq!(a.iter().map(|a| a.node).collect::<Vec<_>>(), vec![0, 1, 0]);
        assert_eq!(
            a.iter().map(|a| a.grant).collect::<Vec<_>>(),
            vec![1, 2, 3],
            "grant numbers are fresh"
        );
        assert!(g.assign(t(0)).is_empty(), "no credit left");
        assert_eq!((g.outstanding(0), g.outstanding(1)), (2, 1));
    }

    #[test]
    fn completes_every_line_once() {
        let mut g = GrantTable::new(Strategy::Dynamic, 3, 1, &[]);
        g.request(0, 1);
        let mut seen = Vec::new();
        while !g.is_finished() {
            let a = g.assign(t(0));
            assert_eq!(a.len(), 1);
            assert_eq!(g.complete(0, a[0].grant, a[0].line), Completion::Accepted);
            seen.push(a[0].line);
            g.request(0, 1);
        }
        assert_eq!(seen, vec![0, 1, 2]);
        assert_eq!(g.done(), 3);
    }

    #[test]
    fn first_completion_wins() {
        let mut g = GrantTable::new(Strategy::Dynamic, 1, 2, &[]);
        g.request(0, 1);
        let a = g.assign(t(0))[0];
        g.request(1, 1);
        let d = g.duplicate_stragglers(t(1000), Duration::from_millis(500));
        assert_eq!(d.len(), 1);
        assert!(d[0].duplicate && d[0].line == a.line && d[0].node == 1);
        assert_eq!(g.complete(1, d[0].grant, 0), Completion::Accepted);
        assert_eq!(g.complete(0, a.grant, 0), Completion::Duplicate);
        assert_eq!(g.complete(0, a.grant, 0), Completion::Duplicate);
        assert_eq!(g.done(), 1);
        assert_eq!(g.counts().dropped, 2);
        assert_eq!(
            g.outstanding(0),
            0,
            "the slow copy is no longer outstanding"
        );
    }

    #[test]
    fn unknown_grants_are_ignored() {
        let mut g = GrantTable::new(Strategy::Dynamic, 2, 2, &[]);
        g.request(0, 1);
        let a = g.assign(t(0))[0];
        assert_eq!(g.complete(0, 0, 0), Completion::Unknown);
        assert_eq!(g.complete(0, 99, 0), Completion::Unknown);
        assert_eq!(g.complete(0, a.grant, 1), Completion::Unknown, "wrong line");
        assert_eq!(g.complete(1, a.grant, 0), Completion::Unknown, "wrong node");
        assert_eq!(g.done(), 0);
    }

    #[test]
    fn a_gone_node_gives_its_lines_back_first() {
        let mut g = GrantTable::new(Strategy::Dynamic, 6, 2, &[]);
        g.request(0, 2);
        g.request(1, 2);
        let a = g.assign(t(0));
        assert_eq!(lines(&a), vec![0, 1, 2, 3]);
        assert_eq!(g.node_gone(1), 2);
        assert_eq!(g.node_gone(1), 0, "only once");
        assert_eq!(g.counts().requeued, 2);
        assert_eq!(g.live_nodes(), 1);
        g.request(1, 5);
        assert!(
            g.assign(t(0)).is_empty(),
            "a gone node gets nothing and node 0 has no credit"
        );
        g.complete(0, a[0].grant, 0);
        g.request(0, 3);
        let b = g.assign(t(1));
        assert_eq!(lines(&b), vec![3, 1, 4], "lost lines come first");
        // A late completion from the gone node is still good pixels.
        assert_eq!(g.complete(1, a[1].grant, 1), Completion::Accepted);
        assert_eq!(g.complete(0, b[1].grant, 1), Completion::Duplicate);
    }

    #[test]
    fn silent_nodes_time_out_and_come_back() {
        let mut g = GrantTable::new(Strategy::Dynamic, 4, 2, &[]);
        g.request(0, 1);
        g.request(1, 1);
        let a = g.assign(t(0));
        g.complete(0, a[0].grant, 0);
        g.request(0, 1);
        let b = g.assign(t(900));
        assert_eq!(lines(&b), vec![2]);
        let timeout = Duration::from_millis(1000);
        assert!(g.expire(t(1000), timeout).is_empty());
        assert_eq!(g.expire(t(1001), timeout), vec![(1, 1)]);
        assert_eq!(g.node_state(1), Some(NodeState::Silent));
        assert_eq!(g.active_nodes(), 1);
        assert_eq!(g.live_nodes(), 2);
        g.request(1, 1);
        assert_eq!(g.node_state(1), Some(NodeState::Active), "heard from again");
        let c = g.assign(t(1002));
        assert_eq!(lines(&c), vec![1], "the timed-out line is handed out again");
        // The silent node's own late completion of line 1 is still accepted first.
        assert_eq!(g.complete(1, a[1].grant, 1), Completion::Accepted);
        assert_eq!(g.complete(1, c[0].grant, 1), Completion::Duplicate);
    }

    #[test]
    fn a_line_finished_by_a_revoked_grant_is_not_handed_out_again() {
        let mut g = GrantTable::new(Strategy::Dynamic, 2, 1, &[]);
        g.request(0, 1);
        let a = g.assign(t(0))[0];
        assert_eq!(g.expire(t(10), Duration::from_millis(5)), vec![(0, 1)]);
        assert_eq!(g.complete(0, a.grant, 0), Completion::Accepted);
        g.request(0, 2);
        assert_eq!(lines(&g.assign(t(11))), vec![1]);
    }

    #[test]
    fn stragglers_are_duplicated_oldest_first_and_only_once() {
        let mut g = GrantTable::new(Strategy::Dynamic, 4, 3, &[]);
        g.request(0, 2);
        let a = g.assign(t(0));
        g.request(1, 2);
        let b = g.assign(t(100));
        assert_eq!((lines(&a), lines(&b)), (vec![0, 1], vec![2, 3]));
        g.request(2, 3);
        let min_age = Duration::from_millis(50);
        assert!(
            g.duplicate_stragglers(t(10), min_age).is_empty(),
            "too young"
        );
        let d = g.duplicate_stragglers(t(200), min_age);
        assert_eq!(lines(&d), vec![0, 1, 2], "oldest first, limited by credit");
        assert!(d.iter().all(|x| x.node == 2 && x.duplicate));
        g.request(1, 5);
        let e = g.duplicate_stragglers(t(300), min_age);
        assert_eq!(lines(&e), Vec::<u32>::new(), "line 3 is node 1's own");
        g.request(0, 1);
        let f = g.duplicate_stragglers(t(300), min_age);
        assert_eq!(lines(&f), vec![3]);
        assert!(g.duplicate_stragglers(t(400), min_age).is_empty());
        assert_eq!(g.counts().duplicated, 4);
    }

    #[test]
    fn no_duplicates_while_lines_are_queued() {
        let mut g = GrantTable::new(Strategy::Dynamic, 3, 2, &[]);
        g.request(0, 1);
        g.assign(t(0));
        g.request(1, 1);
        // Node 1 has credit but line 1 is still queued for it: assign, not duplicate.
        assert!(g.duplicate_stragglers(t(1000), Duration::ZERO).is_empty());
    }

    #[test]
    fn static_strategies_keep_their_order_and_survive_a_lost_node() {
        let mut g = GrantTable::new(Strategy::Blocks, 6, 2, &[]);
        g.request(0, 1);
        g.request(1, 1);
        assert_eq!(lines(&g.assign(t(0))), vec![0, 3]);
        g.node_gone(1);
        g.request(0, 10);
        assert_eq!(lines(&g.assign(t(1))), vec![1, 2, 3, 4, 5]);

        let mut g = GrantTable::new(Strategy::Interleaved, 6, 3, &[]);
        for n in 0..3 {
            g.request(n, 2);
        }
        assert_eq!(lines(&g.assign(t(0))), vec![0, 1, 2, 3, 4, 5]);
    }

    #[test]
    fn static_nodes_do_not_take_queued_lines_of_a_slow_node() {
        let mut g = GrantTable::new(Strategy::Blocks, 4, 2, &[]);
        g.request(0, 2);
        g.request(1, 1);
        let a = g.assign(t(0));
        assert_eq!(lines(&a), vec![0, 2, 1]);
        g.complete(0, a[0].grant, 0);
        g.complete(0, a[2].grant, 1);
        g.request(0, 2);
        // Node 1 still owns line 3 (queued): node 0 only duplicates what is outstanding.
        assert!(g.assign(t(1)).is_empty());
        let d = g.duplicate_stragglers(t(1000), Duration::ZERO);
        assert_eq!(lines(&d), vec![2]);
    }

    #[test]
    fn resume_skips_finished_lines() {
        let finished = [true, false, true, false];
        let mut g = GrantTable::new(Strategy::Dynamic, 4, 1, &finished);
        assert_eq!(g.done(), 2);
        g.request(0, 4);
        let a = g.assign(t(0));
        assert_eq!(lines(&a), vec![1, 3]);
        for x in &a {
            assert_eq!(g.complete(0, x.grant, x.line), Completion::Accepted);
        }
        assert!(g.is_finished());
        let all = GrantTable::new(Strategy::Interleaved, 2, 2, &[true, true]);
        assert!(all.is_finished());
    }
}
