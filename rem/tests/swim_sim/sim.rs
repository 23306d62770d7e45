//! The simulator: members ([`SwimNode`]s), a simulated clock and network, slow CPUs, and
//! the record of who saw whom come up and go down.

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::net::{Ipv4Addr, SocketAddr};
use std::time::Duration;

use rem::membership::swim::{Change, MemberId, SwimConfig, SwimNode, SwimTimer};
use rem::wire::proto::Load;

use super::Params;

/// Simulated time in microseconds since the start of the run.
pub(crate) type Micros = u64;

/// The simulated wall clock at time 0 (unix ms), the same for every node.
pub(crate) const EPOCH_MS: u64 = 1_700_000_000_000;
pub(crate) const SECRET: &[u8] = b"the simulated cluster's secret";
pub(crate) const PORT: u16 = 7077;

pub(crate) const fn ms(n: u64) -> Micros {
    n * 1000
}

pub(crate) const fn secs(n: u64) -> Micros {
    n * 1_000_000
}

pub(crate) fn as_ms(t: Micros) -> f64 {
    t as f64 / 1000.0
}

/// splitmix64: small, fast, and good enough for a simulation.
#[derive(Clone)]
pub(crate) struct Rng(u64);

pub(crate) fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Rng {
    pub(crate) fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        mix(self.0)
    }

    /// Uniform in lo..=hi.
    pub(crate) fn between(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.next() % (hi - lo + 1)
    }

    pub(crate) fn chance(&mut self, p: f64) -> bool {
        ((self.next() >> 11) as f64 / (1u64 << 53) as f64) < p
    }
}

pub(crate) fn addr_of(i: usize) -> SocketAddr {
    let k = i as u32 + 1;
    let ip = Ipv4Addr::new(10, (k >> 16) as u8, (k >> 8) as u8, k as u8);
    SocketAddr::new(ip.into(), PORT)
}

pub(crate) fn index_of(addr: SocketAddr) -> Option<usize> {
    match addr {
        SocketAddr::V4(a) => {
            let [_, x, y, z] = a.ip().octets();
            let k = (u32::from(x) << 16) | (u32::from(y) << 8) | u32::from(z);
            (k as usize).checked_sub(1)
        }
        SocketAddr::V6(_) => None,
    }
}

/// The phases of the scenario, for counting false accusations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Phase {
    WarmUp,
    Steady,
    Kill,
    Partition,
    Heal,
    Slow,
}

pub(crate) const PHASES: [Phase; 6] = [
    Phase::WarmUp,
    Phase::Steady,
    Phase::Kill,
    Phase::Partition,
    Phase::Heal,
    Phase::Slow,
];

impl Phase {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Phase::WarmUp => "warm-up",
            Phase::Steady => "steady",
            Phase::Kill => "kill",
            Phase::Partition => "partition",
            Phase::Heal => "heal",
            Phase::Slow => "slow",
        }
    }
}

pub(crate) enum Kind {
    Datagram { from: usize, bytes: Vec<u8> },
    Timer { timer: SwimTimer, due: Micros },
    Report,
    Join,
}

pub(crate) struct Event {
    pub(crate) at: Micros,
    pub(crate) seq: u64,
    pub(crate) node: usize,
    pub(crate) kind: Kind,
}

impl PartialEq for Event {
    fn eq(&self, other: &Self) -> bool {
        (self.at, self.seq) == (other.at, other.seq)
    }
}

impl Eq for Event {}

impl PartialOrd for Event {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Event {
    /// Reversed: the heap's greatest is the earliest.
    fn cmp(&self, other: &Self) -> Ordering {
        (other.at, other.seq).cmp(&(self.at, self.seq))
    }
}

pub(crate) struct Sim {
    pub(crate) p: Params,
    pub(crate) nodes: Vec<SwimNode>,
    pub(crate) names: Vec<String>,
    pub(crate) addrs: Vec<SocketAddr>,
    pub(crate) queue: BinaryHeap<Event>,
    pub(crate) seq: u64,
    pub(crate) now: Micros,
    pub(crate) rng: Rng,
    pub(crate) killed: Vec<bool>,
    pub(crate) partitioned: Vec<bool>,
    /// Each node's identity stamps while it was partitioned.
    pub(crate) isolated_stamps: Vec<Vec<u64>>,
    /// A window in which every node's CPU is mostly taken.
    pub(crate) slow: Option<(Micros, Micros)>,
    /// Each node's current (or last) time off the CPU in the slow window: [start, end).
    pub(crate) descheduled: Vec<(Micros, Micros)>,
    pub(crate) join_pending: Vec<bool>,
    /// `up[obs * n + m]`: node obs sees node m up.
    pub(crate) up: Vec<bool>,
    pub(crate) up_count: Vec<usize>,
    /// Every (time, observer, accused) of a `Change::Down`.
    pub(crate) downs: Vec<(Micros, usize, usize)>,
    pub(crate) phase: Phase,
    /// Every (phase, observer, accused) of a false accusation.
    pub(crate) false_accusations: Vec<(Phase, usize, usize)>,
    pub(crate) isolated_downs: u64,
    pub(crate) lost: u64,
}

impl Sim {
    pub(crate) fn new(p: &Params) -> Sim {
        let n = p.n;
        let mut rng = Rng(p.seed);
        let addrs: Vec<SocketAddr> = (0..n).map(addr_of).collect();
        let names: Vec<String> = (0..n).map(|i| format!("node-{i}")).collect();
        let nodes = (0..n)
            .map(|i| {
                let me = MemberId {
                    name: names[i].clone(),
                    addr: addrs[i],
                    grpc: format!("{}:{PORT}", addrs[i].ip()),
                    stamp: EPOCH_MS,
                };
                let seed = mix(p.seed ^ mix(i as u64));
                SwimNode::new(me, SECRET, SwimConfig::default(), seed)
            })
            .collect();
        let mut sim = Sim {
            p: p.clone(),
            nodes,
            names,
            addrs,
            queue: BinaryHeap::new(),
            seq: 0,
            now: 0,
            rng: Rng(mix(rng.next())),
            killed: vec![false; n],
            partitioned: vec![false; n],
            isolated_stamps: vec![Vec::new(); n],
            slow: None,
            descheduled: vec![(0, 0); n],
            join_pending: vec![false; n],
            up: vec![false; n * n],
            up_count: vec![0; n],
            downs: Vec::new(),
            phase: Phase::WarmUp,
            false_accusations: Vec::new(),
            isolated_downs: 0,
            lost: 0,
        };
        let ids: Vec<MemberId> = (0..n).map(|i| sim.nodes[i].identity().clone()).collect();
        for i in 0..n {
            sim.push(rng.between(0, secs(1)), i, Kind::Report);
            if p.assembled {
                let others = ids.iter().enumerate().filter(|&(j, _)| j != i);
                sim.nodes[i].assume_alive(others.map(|(_, id)| id.clone()), EPOCH_MS);
                sim.flush(i);
            } else if i > 0 {
                sim.join_pending[i] = true;
                sim.push(ms(i as u64) + rng.between(0, ms(1)), i, Kind::Join);
            }
        }
        sim
    }

    pub(crate) fn push(&mut self, at: Micros, node: usize, kind: Kind) {
        self.seq += 1;
        self.queue.push(Event {
            at,
            seq: self.seq,
            node,
            kind,
        });
    }

    /// In the slow window, until when node is off the CPU at `at` (None: it runs).
    pub(crate) fn off_cpu_until(&mut self, node: usize, at: Micros) -> Option<Micros> {
        let (from, to) = self.slow?;
        if !(from..to).contains(&at) {
            return None;
        }
        let (mut start, mut end) = self.descheduled[node];
        if end < from {
            (start, end) = (from, from);
        }
        while end <= at {
            start = end + self.rng.between(ms(2), ms(10));
            end = start + self.rng.between(ms(10), ms(150));
        }
        self.descheduled[node] = (start, end);
        (start <= at).then_some(end)
    }

    /// Latency of the link between a and b (symmetric, fixed for a run): 0.2-2 ms.
    pub(crate) fn link(&self, a: usize, b: usize) -> Micros {
        let (lo, hi) = (a.min(b) as u64, a.max(b) as u64);
        200 + mix(self.p.seed ^ mix((lo << 32) | hi)) % 1801
    }

    pub(crate) fn cut_off(&self, i: usize) -> bool {
        self.killed[i] || self.partitioned[i]
    }

    pub(crate) fn run_until(&mut self, t: Micros) {
        while self.queue.peek().is_some_and(|e| e.at <= t) {
            let e = self.queue.pop().unwrap();
            self.handle(e);
        }
        self.now = t;
    }

    pub(crate) fn run_for(&mut self, d: Micros) {
        self.run_until(self.now + d);
    }

    pub(crate) fn handle(&mut self, e: Event) {
        let Event { at, node, kind, .. } = e;
        self.now = at;
        if self.killed[node] {
            return;
        }
        let late_able = matches!(kind, Kind::Datagram { .. } | Kind::Timer { .. });
        if late_able {
            if let Some(runs_at) = self.off_cpu_until(node, at) {
                // Waits its turn: pushed in arrival order, so handled in that order.
                self.push(runs_at, node, kind);
                return;
            }
        }
        let now_ms = EPOCH_MS + at / 1000;
        match kind {
            Kind::Datagram { from, bytes } => {
                if self.cut_off(node) || self.cut_off(from) {
                    self.lost += 1;
                    return;
                }
                // A datagram not believed is counted in the node's traffic.
                let _ = self.nodes[node].datagram(&bytes, now_ms);
            }
            Kind::Timer { timer, due } => {
                let late = Duration::from_micros(at - due);
                self.nodes[node].timer(timer, late, now_ms);
            }
            Kind::Report => {
                let load = self.load();
                self.nodes[node].report_load(true, &load, now_ms);
                self.push(at + secs(1), node, Kind::Report);
            }
            Kind::Join => {
                self.join_pending[node] = false;
                if self.nodes[node].active_members() == 0 {
                    let to = if node == 0 { 1 } else { 0 };
                    self.nodes[node].announce(self.addrs[to], now_ms);
                    self.join_pending[node] = true;
                    self.push(at + secs(1), node, Kind::Join);
                }
            }
        }
        self.flush(node);
    }

    pub(crate) fn load(&mut self) -> Load {
        let cores = 1 << self.rng.between(1, 6);
        let busy = self.rng.between(0, 1000) as f64 / 1000.0;
        let procs = self.rng.between(0, 2 * u64::from(cores)) as u32;
        Load {
            cores,
            load_avg_1m: busy * f64::from(cores),
            cpu_busy: busy,
            mem_free_bytes: self.rng.between(1 << 30, 64 << 30),
            mem_total_bytes: 64 << 30,
            rem_processes: procs,
            load_per_core: busy + f64::from(procs) / f64::from(cores),
            capacity: f64::from(cores),
            protocol: rem::wire::protocol::PROTOCOL,
            slots: cores,
            slots_used: procs.min(cores),
        }
    }

    /// Sends, sets and records what node i's last step produced.
    pub(crate) fn flush(&mut self, i: usize) {
        let out = self.nodes[i].drain();
        for (addr, bytes) in out.datagrams {
            let Some(to) = index_of(addr).filter(|&t| t < self.p.n) else {
                self.lost += 1;
                continue;
            };
            if self.cut_off(i) || self.cut_off(to) || self.rng.chance(self.p.loss) {
                self.lost += 1;
                continue;
            }
            let at = self.now + self.link(i, to) + self.rng.between(0, 500);
            self.push(at, to, Kind::Datagram { from: i, bytes });
        }
        for (after, timer) in out.timers {
            let due = self.now + after.as_micros() as u64;
            self.push(due, i, Kind::Timer { timer, due });
        }
        for change in out.changes {
            self.change(i, change);
        }
    }

    pub(crate) fn change(&mut self, obs: usize, change: Change) {
        let n = self.p.n;
        match change {
            Change::Up(id) => {
                let m = index_of(id.addr).unwrap();
                if !self.up[obs * n + m] {
                    self.up[obs * n + m] = true;
                    self.up_count[obs] += 1;
                }
            }
            Change::Down(id) => {
                let m = index_of(id.addr).unwrap();
                if self.up[obs * n + m] {
                    self.up[obs * n + m] = false;
                    self.up_count[obs] -= 1;
                }
                self.downs.push((self.now, obs, m));
                // An observer cut off (or not yet back under a new identity) cannot tell.
                let observer_isolated = self.partitioned[obs]
                    || self.isolated_stamps[obs].contains(&self.nodes[obs].identity().stamp);
                // The identity it had while cut off is rightly down, even after the heal.
                let true_down = self.cut_off(m) || self.isolated_stamps[m].contains(&id.stamp);
                if observer_isolated {
                    self.isolated_downs += 1;
                } else if !true_down {
                    self.false_accusations.push((self.phase, obs, m));
                }
            }
            Change::Renamed(_) => {}
            Change::Idle => {
                if !self.join_pending[obs] {
                    self.join_pending[obs] = true;
                    self.push(self.now + ms(100), obs, Kind::Join);
                }
            }
        }
    }

    pub(crate) fn live(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.p.n).filter(|&i| !self.killed[i])
    }

    pub(crate) fn sees(&self, obs: usize, m: usize) -> bool {
        self.up[obs * self.p.n + m]
    }

    /// Whether node obs sees every live member up.
    pub(crate) fn sees_all(&self, obs: usize) -> bool {
        self.live().all(|m| m == obs || self.sees(obs, m))
    }

    pub(crate) fn converged(&self) -> bool {
        self.live().all(|i| self.sees_all(i))
    }

    /// The live members other than m that see m up.
    pub(crate) fn seeing(&self, m: usize) -> Vec<usize> {
        self.live().filter(|&o| o != m && self.sees(o, m)).collect()
    }

    /// The first member from `from` on (not 0, not killed) that every live member sees up.
    pub(crate) fn widely_seen(&self, from: usize) -> usize {
        let n = self.p.n;
        (0..n)
            .map(|k| 1 + (from - 1 + k) % (n - 1))
            .find(|&m| !self.killed[m] && self.seeing(m).len() == self.live().count() - 1)
            .unwrap_or(from)
    }

    /// For each member in `observers`, the time from `since` to its first Down for `m`
    /// before `until`.
    pub(crate) fn detections(
        &self,
        m: usize,
        since: Micros,
        until: Micros,
        observers: &[usize],
    ) -> Vec<Micros> {
        let mut first = vec![None; self.p.n];
        for &(at, obs, accused) in &self.downs {
            if accused == m && (since..until).contains(&at) && first[obs].is_none() {
                first[obs] = Some(at - since);
            }
        }
        observers.iter().filter_map(|&o| first[o]).collect()
    }

    pub(crate) fn traffic(&self) -> (u64, u64) {
        self.live().fold((0, 0), |(d, b), i| {
            let t = self.nodes[i].traffic();
            (d + t.sent, b + t.sent_bytes)
        })
    }

    /// Ages (ms) of the newest load reports a sample of members has of the others, and how
    /// many pairs have none.
    pub(crate) fn report_ages(&self) -> (Vec<u64>, usize) {
        let now_ms = EPOCH_MS + self.now / 1000;
        let step = (self.p.n / 100).max(1);
        let (mut ages, mut missing) = (Vec::new(), 0);
        for obs in self.live().step_by(step) {
            for m in self.live().filter(|&m| m != obs) {
                match self.nodes[obs].report(&self.names[m]) {
                    Some(r) => ages.push(now_ms.saturating_sub(r.sent_ms)),
                    None => missing += 1,
                }
            }
        }
        ages.sort_unstable();
        (ages, missing)
    }
}
