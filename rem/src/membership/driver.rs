//! Membership: which daemons exist, which are alive, and their load.
//!
//! One [`crate::membership::swim::SwimNode`] per daemon, driven here: its sealed datagrams go over UDP on
//! the port of the daemon's gRPC listener, its timers run on tokio's clock, and every
//! [`SwimConfig::report_every`] it adds this host's load report, which travels piggybacked
//! on the protocol's own datagrams. Each daemon probes one member per probe period, whatever
//! the cluster's size, so its idle cost does not grow with the lab (docs/rem.md has the
//! protocol and its figures).
//!
//! A member counts as alive once the protocol has it up and its first load report is in
//! (so a host is never placed on without figures), and is then `MemberEvent::Back`; declared
//! down, it is `MemberEvent::Lost`, until it (or a restarted daemon of the same name) is
//! alive again. A hung (SIGSTOPped) daemon does not answer
//! probes, so it is detected like a dead one. Until it knows another member, and whenever
//! it knows none alive, the daemon asks its `--join` addresses to let it in, every second.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap, HashMap, HashSet};
use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use tokio::net::UdpSocket;
use tokio::sync::{broadcast, watch};

use crate::membership::load::LoadGauge;
use crate::membership::peers::PeerPool;
use crate::membership::swim::reports::ReportTable;
use crate::membership::swim::seal::Rejected;
use crate::membership::swim::{Change, MemberId, Outbox, SwimConfig, SwimNode, SwimTimer};
use crate::wire::proto::{HostInfo, Load};
use crate::wire::protocol::ProtocolNotices;

/// Senders of newer-sealed datagrams whose notice was logged, at most.
const MAX_NEWER_SENDERS: usize = 256;

/// A change in who is alive.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MemberEvent {
    Lost(String),
    Back(String),
}

/// What this daemon knows about another.
#[derive(Clone, Debug)]
pub struct HostEntry {
    /// Its gRPC address.
    pub addr: String,
    pub alive: bool,
}

/// The membership table (without this daemon itself).
#[derive(Clone, Debug, Default)]
pub struct View {
    pub hosts: BTreeMap<String, HostEntry>,
}

/// This daemon's identity and timing.
#[derive(Clone, Debug)]
pub struct MembershipConfig {
    pub name: String,
    /// Its advertised gRPC address.
    pub addr: String,
    pub join: Vec<String>,
    pub swim: SwimConfig,
    /// The cluster secret (datagrams are sealed with a key derived from it).
    pub secret: Vec<u8>,
    /// The REM protocol announced in this daemon's load reports
    /// ([`crate::wire::protocol::PROTOCOL`]; a newer one only to try a mixed farm).
    pub protocol: u32,
}

/// Cloneable handle to the membership actor.
#[derive(Clone, Debug)]
pub struct Membership {
    view: watch::Receiver<Arc<View>>,
    events: broadcast::Sender<MemberEvent>,
    me: Arc<MembershipConfig>,
    gauge: LoadGauge,
    accepting: Arc<AtomicBool>,
    reports: Arc<Mutex<ReportTable>>,
}

fn unix_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

impl Membership {
    /// Starts the actor on `socket` (UDP, bound where the gRPC listener is); it stops when
    /// `stop` fires.
    pub fn start(
        cfg: MembershipConfig,
        socket: UdpSocket,
        gauge: LoadGauge,
        accepting: Arc<AtomicBool>,
        peers: PeerPool,
        stop: tokio_util::sync::CancellationToken,
    ) -> std::io::Result<Self> {
        let udp = socket.local_addr()?;
        let me = MemberId {
            name: cfg.name.clone(),
            addr: advertised_udp(&cfg.addr, udp),
            grpc: cfg.addr.clone(),
            stamp: unix_ms(),
        };
        let mut seed = [0u8; 8];
        getrandom::getrandom(&mut seed).map_err(|e| std::io::Error::other(e.to_string()))?;
        let node = SwimNode::new(me, &cfg.secret, cfg.swim.clone(), u64::from_le_bytes(seed));
        let reports = node.reports();
        reports.lock().unwrap_or_else(|e| e.into_inner()).notices =
            ProtocolNotices::new(cfg.protocol);
        let (view_tx, view) = watch::channel(Arc::new(View::default()));
        let (events, _) = broadcast::channel(256);
        let handle = Membership {
            view,
            events,
            me: Arc::new(cfg),
            gauge,
            accepting,
            reports,
        };
        let actor = Actor {
            handle: handle.clone(),
            node,
            socket,
            timers: BinaryHeap::new(),
            timer_seq: 0,
            view: View::default(),
            view_tx,
            current: HashMap::new(),
            waiting: HashSet::new(),
            report_now: false,
            peers,
            newer_senders: HashSet::new(),
        };
        tokio::spawn(actor.run(stop));
        Ok(handle)
    }

    pub fn name(&self) -> &str {
        &self.me.name
    }

    /// This host's current load report, with the protocol it announces.
    fn own_load(&self) -> Load {
        Load {
            protocol: self.me.protocol,
            ..self.gauge.current()
        }
    }

    /// This daemon's own entry, with current load.
    pub fn me(&self) -> HostInfo {
        HostInfo {
            name: self.me.name.clone(),
            addr: self.me.addr.clone(),
            load: Some(self.own_load()),
            alive: true,
            last_heard_ms: 0,
            accepting: self.accepting.load(Ordering::Relaxed),
        }
    }

    /// Every host: this one first, then the others by name, each with its newest load
    /// report (`last_heard_ms`: how old it is; `u64::MAX` for none).
    pub fn hosts(&self) -> Vec<HostInfo> {
        let view = self.view.borrow().clone();
        let reports = self.reports.lock().unwrap_or_else(|e| e.into_inner());
        let now = unix_ms();
        let mut out = vec![self.me()];
        for (name, e) in &view.hosts {
            let report = reports.get(name);
            out.push(HostInfo {
                name: name.clone(),
                addr: e.addr.clone(),
                alive: e.alive,
                load: report.map(|r| r.load),
                accepting: report.is_some_and(|r| r.accepting),
                last_heard_ms: report.map_or(u64::MAX, |r| now.saturating_sub(r.sent_ms)),
            });
        }
        out
    }

    /// The current table (cheap: a shared snapshot).
    pub fn view(&self) -> Arc<View> {
        self.view.borrow().clone()
    }

    pub fn subscribe(&self) -> broadcast::Receiver<MemberEvent> {
        self.events.subscribe()
    }

    /// Address of a live member, or `None`.
    pub fn live_addr(&self, name: &str) -> Option<String> {
        self.view
            .borrow()
            .hosts
            .get(name)
            .filter(|e| e.alive)
            .map(|e| e.addr.clone())
    }
}

/// The UDP address others reach this daemon at: the advertised gRPC address's IP (when it
/// is one) with the UDP port, else the bound address.
fn advertised_udp(advertised: &str, bound: SocketAddr) -> SocketAddr {
    match advertised.parse::<SocketAddr>() {
        Ok(a) => SocketAddr::new(a.ip(), bound.port()),
        Err(_) => std::net::ToSocketAddrs::to_socket_addrs(advertised)
            .ok()
            .and_then(|mut a| a.next())
            .map_or(bound, |a| SocketAddr::new(a.ip(), bound.port())),
    }
}

/// A timer due at an instant (ordered by due time, then by when it was set).
type Due = Reverse<(Instant, u64, SwimTimer)>;

struct Actor {
    handle: Membership,
    node: SwimNode,
    socket: UdpSocket,
    timers: BinaryHeap<Due>,
    timer_seq: u64,
    view: View,
    view_tx: watch::Sender<Arc<View>>,
    /// The identity each name is known by now (a restart takes a newer one).
    current: HashMap<String, MemberId>,
    /// Members up whose first load report has not come yet.
    waiting: HashSet<String>,
    /// A member came up: report this host's load again at once, for it.
    report_now: bool,
    peers: PeerPool,
    /// Addresses that sent datagrams of a newer membership protocol (each logged once).
    newer_senders: HashSet<SocketAddr>,
}

impl Actor {
    async fn run(mut self, stop: tokio_util::sync::CancellationToken) {
        let cfg = self.node.config().clone();
        let mut report = tokio::time::interval(cfg.report_every);
        report.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let mut join = tokio::time::interval(Duration::from_secs(1));
        join.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let mut buf = vec![0u8; crate::membership::swim::config::MAX_DATAGRAM + 1];
        loop {
            let next = self.timers.peek().map(|Reverse((at, _, _))| *at);
            let sleep = tokio::time::sleep_until(
                next.unwrap_or_else(|| Instant::now() + Duration::from_secs(3600))
                    .into(),
            );
            tokio::select! {
                _ = stop.cancelled() => break,
                r = self.socket.recv_from(&mut buf) => match r {
                    Ok((n, from)) => {
                        if let Err(e) = self.node.datagram(&buf[..n], unix_ms()) {
                            self.not_believed(from, e);
                        }
                    }
                    Err(e) => tracing::debug!("membership socket: {e}"),
                },
                _ = sleep, if next.is_some() => self.fire_due(),
                _ = report.tick() => self.report_load(),
                _ = join.tick() => {
                    if !self.view.hosts.values().any(|e| e.alive) {
                        self.announce().await;
                    }
                }
            }
            if std::mem::take(&mut self.report_now) {
                self.report_load();
            }
            let out = self.node.drain();
            let mut changed = self.apply(out);
            changed |= self.reports_arrived();
            if changed {
                self.view_tx.send_replace(Arc::new(self.view.clone()));
            }
        }
    }

    /// A datagram from `from` was not believed: said once per sender when it is of a newer
    /// protocol (this daemon is the one to upgrade), else only in the debug log.
    fn not_believed(&mut self, from: SocketAddr, e: Rejected) {
        if matches!(e, Rejected::Newer(_))
            && self.newer_senders.len() < MAX_NEWER_SENDERS
            && self.newer_senders.insert(from)
        {
            tracing::warn!(
                "a membership datagram from {from} is {e}: that host runs a newer remd, and \
                 this daemon cannot count it as a member until it is upgraded too"
            );
        } else {
            tracing::debug!(%from, "membership datagram not believed: {e}");
        }
    }

    fn report_load(&mut self) {
        let load = self.handle.own_load();
        let accepting = self.handle.accepting.load(Ordering::Relaxed);
        self.node.report_load(accepting, &load, unix_ms());
    }

    /// Members waiting for their first report that now have one are alive.
    fn reports_arrived(&mut self) -> bool {
        if self.waiting.is_empty() {
            return false;
        }
        let reports = self.handle.reports.clone();
        let reports = reports.lock().unwrap_or_else(|e| e.into_inner());
        let ready: Vec<String> = self
            .waiting
            .iter()
            .filter(|n| reports.get(n).is_some())
            .cloned()
            .collect();
        drop(reports);
        for name in &ready {
            self.waiting.remove(name);
            if let Some(e) = self.view.hosts.get_mut(name) {
                if !e.alive {
                    e.alive = true;
                    tracing::info!(host = %name, addr = %e.addr, "host alive");
                    let _ = self.handle.events.send(MemberEvent::Back(name.clone()));
                }
            }
        }
        !ready.is_empty()
    }

    /// Asks every `--join` address (resolved now: a name may resolve later) to let us in.
    async fn announce(&mut self) {
        for seed in self.handle.me.join.clone() {
            match tokio::net::lookup_host(seed.as_str()).await {
                Ok(addrs) => {
                    for a in addrs {
                        self.node.announce(a, unix_ms());
                    }
                }
                Err(e) => tracing::debug!(%seed, "join address: {e}"),
            }
        }
    }

    fn fire_due(&mut self) {
        let now = Instant::now();
        while let Some(Reverse((at, _, _))) = self.timers.peek() {
            if *at > now {
                break;
            }
            let Some(Reverse((at, _, timer))) = self.timers.pop() else {
                break;
            };
            self.node.timer(timer, now.duration_since(at), unix_ms());
        }
    }

    /// Sends, sets timers and applies changes; whether the table changed.
    fn apply(&mut self, out: Outbox) -> bool {
        for (to, bytes) in out.datagrams {
            // UDP is lossy anyway: a full socket buffer drops the datagram.
            if let Err(e) = self.socket.try_send_to(&bytes, to) {
                tracing::debug!(%to, "membership send: {e}");
            }
        }
        let now = Instant::now();
        for (after, timer) in out.timers {
            self.timer_seq += 1;
            self.timers
                .push(Reverse((now + after, self.timer_seq, timer)));
        }
        let changed = !out.changes.is_empty();
        for change in out.changes {
            self.change(change);
        }
        changed
    }

    fn change(&mut self, change: Change) {
        match change {
            Change::Up(id) | Change::Renamed(id) if id.is_valid() => {
                let up = self
                    .current
                    .get(&id.name)
                    .is_none_or(|c| c.stamp <= id.stamp);
                if !up {
                    return; // an older identity of a restarted daemon
                }
                let entry = self
                    .view
                    .hosts
                    .entry(id.name.clone())
                    .or_insert_with(|| HostEntry {
                        addr: id.grpc.clone(),
                        alive: false,
                    });
                entry.addr = id.grpc.clone();
                self.current.insert(id.name.clone(), id.clone());
                if !entry.alive && self.node.is_active(&id) {
                    self.waiting.insert(id.name.clone());
                    self.report_now = true;
                }
            }
            Change::Down(id) => {
                if self.current.get(&id.name) != Some(&id) {
                    return; // not the identity the name is known by now
                }
                self.waiting.remove(&id.name);
                self.handle
                    .reports
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .remove(&id.name);
                if let Some(e) = self.view.hosts.get_mut(&id.name) {
                    if e.alive {
                        e.alive = false;
                        tracing::warn!(host = %id.name, "host lost");
                        self.peers.forget(&e.addr);
                        let _ = self.handle.events.send(MemberEvent::Lost(id.name));
                    }
                }
            }
            Change::Idle => tracing::warn!("no other member is alive; asking the join addresses"),
            Change::Up(_) | Change::Renamed(_) => {}
        }
    }
}
