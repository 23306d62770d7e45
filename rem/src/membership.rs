//! Membership: which daemons exist, which are alive, and their load.
//!
//! Every heartbeat interval each daemon sends its own `HostInfo` and the members it knows to
//! every other member (and to each `--join` address not yet identified); the reply carries the
//! same from the other side, so joining through any one member spreads to all. A member not
//! heard from (either direction) for `lost_after` is marked lost, and `MemberEvent::Lost` is
//! broadcast; when it answers again it is alive again (`MemberEvent::Back`). Heartbeat calls
//! time out, so a hung (SIGSTOPped) daemon is detected like a dead one.
//!
//! Heartbeats go through `PeerPool::call_proven`: a reply counts only with a daemon's proof
//! (`peer_auth`), and only its sender's own entry is believed, so whoever answers at a lost
//! member's address can neither revive it nor add members.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use tokio::sync::{broadcast, mpsc, watch};

use crate::load::LoadGauge;
use crate::peer_auth::{method, ANY};
use crate::peers::PeerPool;
use crate::proto::{HeartbeatRequest, HostInfo, Member};

/// A change in who is alive.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MemberEvent {
    Lost(String),
    Back(String),
}

/// What this daemon knows about another.
#[derive(Clone, Debug)]
pub struct HostEntry {
    pub addr: String,
    pub alive: bool,
    pub info: Option<HostInfo>,
    pub last_heard: Option<Instant>,
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
    pub addr: String,
    pub join: Vec<String>,
    pub heartbeat: Duration,
    pub lost_after: Duration,
}

enum Cmd {
    Heard {
        info: HostInfo,
        members: Vec<Member>,
        seed: Option<String>,
    },
}

/// Cloneable handle to the membership actor.
#[derive(Clone, Debug)]
pub struct Membership {
    tx: mpsc::Sender<Cmd>,
    view: watch::Receiver<Arc<View>>,
    events: broadcast::Sender<MemberEvent>,
    me: Arc<MembershipConfig>,
    gauge: LoadGauge,
    accepting: Arc<AtomicBool>,
}

impl Membership {
    /// Starts the actor and its heartbeat loop; it stops when `stop` fires.
    pub fn start(
        cfg: MembershipConfig,
        gauge: LoadGauge,
        accepting: Arc<AtomicBool>,
        peers: PeerPool,
        stop: tokio_util::sync::CancellationToken,
    ) -> Self {
        let (tx, rx) = mpsc::channel(256);
        let (view_tx, view) = watch::channel(Arc::new(View::default()));
        let (events, _) = broadcast::channel(256);
        let handle = Membership {
            tx,
            view,
            events: events.clone(),
            me: Arc::new(cfg),
            gauge,
            accepting,
        };
        let actor = Actor {
            handle: handle.clone(),
            view: View::default(),
            view_tx,
            seeds: handle.me.join.iter().map(|a| (a.clone(), None)).collect(),
            peers,
        };
        tokio::spawn(actor.run(rx, stop));
        handle
    }

    pub fn name(&self) -> &str {
        &self.me.name
    }

    /// This daemon's own entry, with current load.
    pub fn me(&self) -> HostInfo {
        HostInfo {
            name: self.me.name.clone(),
            addr: self.me.addr.clone(),
            load: Some(self.gauge.current()),
            alive: true,
            last_heard_ms: 0,
            accepting: self.accepting.load(Ordering::Relaxed),
        }
    }

    /// Every host: this one first, then the others by name.
    pub fn hosts(&self) -> Vec<HostInfo> {
        let view = self.view.borrow().clone();
        let now = Instant::now();
        let mut out = vec![self.me()];
        for (name, e) in &view.hosts {
            let mut info = e.info.clone().unwrap_or_default();
            info.name = name.clone();
            info.addr = e.addr.clone();
            info.alive = e.alive;
            info.last_heard_ms = e
                .last_heard
                .map_or(u64::MAX, |t| now.duration_since(t).as_millis() as u64);
            out.push(info);
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

    /// Records a heartbeat received from another daemon and returns the reply.
    pub async fn heard(&self, req: HeartbeatRequest) -> (HostInfo, Vec<Member>) {
        if let Some(info) = req.sender {
            let _ = self
                .tx
                .send(Cmd::Heard {
                    info,
                    members: req.members,
                    seed: None,
                })
                .await;
        }
        (self.me(), self.members())
    }

    /// Every member known, this one included.
    pub fn members(&self) -> Vec<Member> {
        let view = self.view.borrow().clone();
        let mut out = vec![Member {
            name: self.me.name.clone(),
            addr: self.me.addr.clone(),
        }];
        out.extend(view.hosts.iter().map(|(n, e)| Member {
            name: n.clone(),
            addr: e.addr.clone(),
        }));
        out
    }
}

struct Actor {
    handle: Membership,
    view: View,
    view_tx: watch::Sender<Arc<View>>,
    /// `--join` addresses and the name that answered there.
    seeds: BTreeMap<String, Option<String>>,
    peers: PeerPool,
}

impl Actor {
    async fn run(mut self, mut rx: mpsc::Receiver<Cmd>, stop: tokio_util::sync::CancellationToken) {
        let mut tick = tokio::time::interval(self.handle.me.heartbeat);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        // Staleness is checked more often than heartbeats are sent, so detection takes
        // `lost_after` plus at most this, not plus a whole heartbeat interval.
        let mut check =
            tokio::time::interval(self.handle.me.heartbeat.min(Duration::from_millis(50)));
        check.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            tokio::select! {
                _ = stop.cancelled() => break,
                _ = check.tick() => self.check_lost(),
                _ = tick.tick() => {
                    self.check_lost();
                    self.send_heartbeats();
                }
                cmd = rx.recv() => match cmd {
                    Some(Cmd::Heard { info, members, seed }) => self.heard(info, members, seed),
                    None => break,
                },
            }
        }
    }

    fn publish(&self) {
        self.view_tx.send_replace(Arc::new(self.view.clone()));
    }

    fn heard(&mut self, info: HostInfo, members: Vec<Member>, seed: Option<String>) {
        let me = &self.handle.me.name;
        if let Some(seed) = seed {
            self.seeds.insert(seed, Some(info.name.clone()));
        }
        if &info.name == me || !crate::ids::is_valid_name(&info.name) {
            return;
        }
        let entry = self
            .view
            .hosts
            .entry(info.name.clone())
            .or_insert_with(|| HostEntry {
                addr: info.addr.clone(),
                alive: false,
                info: None,
                last_heard: None,
            });
        entry.addr = info.addr.clone();
        entry.last_heard = Some(Instant::now());
        let was_alive = entry.alive;
        entry.alive = true;
        entry.info = Some(info.clone());
        if !was_alive {
            tracing::info!(host = %info.name, addr = %info.addr, "host alive");
            let _ = self
                .handle
                .events
                .send(MemberEvent::Back(info.name.clone()));
        }
        for m in members {
            if &m.name == me || !crate::ids::is_valid_name(&m.name) || m.addr.is_empty() {
                continue;
            }
            match self.view.hosts.get_mut(&m.name) {
                Some(e) if !e.alive => e.addr = m.addr,
                Some(_) => {}
                None => {
                    self.view.hosts.insert(
                        m.name,
                        HostEntry {
                            addr: m.addr,
                            alive: false,
                            info: None,
                            last_heard: None,
                        },
                    );
                }
            }
        }
        self.publish();
    }

    fn check_lost(&mut self) {
        let lost_after = self.handle.me.lost_after;
        let mut changed = false;
        for (name, e) in self.view.hosts.iter_mut() {
            let stale = e.last_heard.is_none_or(|t| t.elapsed() > lost_after);
            if e.alive && stale {
                e.alive = false;
                changed = true;
                tracing::warn!(host = %name, "host lost");
                self.peers.forget(&e.addr);
                let _ = self.handle.events.send(MemberEvent::Lost(name.clone()));
            }
        }
        if changed {
            self.publish();
        }
    }

    fn send_heartbeats(&self) {
        let req = HeartbeatRequest {
            sender: Some(self.handle.me()),
            members: self.handle.members(),
        };
        let timeout = (self.handle.me.lost_after / 2).min(Duration::from_secs(1));
        // (address, the join address it is, the name expected there)
        let mut targets: Vec<(String, Option<String>, String)> = self
            .view
            .hosts
            .iter()
            .map(|(name, e)| (e.addr.clone(), None, name.clone()))
            .collect();
        for (seed, name) in &self.seeds {
            let known = name
                .as_ref()
                .is_some_and(|n| self.view.hosts.contains_key(n) || n == &self.handle.me.name);
            if !known && !targets.iter().any(|(a, _, _)| a == seed) {
                targets.push((seed.clone(), Some(seed.clone()), ANY.to_string()));
            }
        }
        for (addr, seed, name) in targets {
            let req = req.clone();
            let tx = self.handle.tx.clone();
            let peers = self.peers.clone();
            tokio::spawn(async move {
                let beat = |mut c: crate::peers::PeerRpc, r| async move { c.heartbeat(r).await };
                let reply = peers
                    .call_proven(&name, &addr, method::HEARTBEAT, timeout, req, beat)
                    .await;
                if let Ok((proven, reply)) = reply {
                    // Only a daemon's own entry is believed from it.
                    if let Some(info) = reply.sender.filter(|s| s.name == proven) {
                        let _ = tx
                            .send(Cmd::Heard {
                                info,
                                members: reply.members,
                                seed,
                            })
                            .await;
                    }
                }
            });
        }
    }
}
