//! One member of the membership protocol, without I/O: datagrams, timers and load reports
//! go in with the time, datagrams to send, timers to set and membership changes come out
//! ([`Outbox`]). `membership.rs` drives it with a UDP socket and tokio's clock; the
//! simulation in `rem/tests/swim_sim.rs` drives a thousand of them with a simulated clock
//! and network.

use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use foca::{Foca, Notification, PostcardCodec, Timer};
use rand::rngs::StdRng;
use rand::SeedableRng;

use super::health::Health;
use super::member::MemberId;
use super::reports::{LoadReports, Report, ReportTable};
use super::seal::{self, Rejected, Sealer};
use crate::proto::Load;

/// Largest datagram sent (fits an Ethernet MTU with IP and UDP headers).
pub const MAX_DATAGRAM: usize = 1400;

/// The protocol's timing.
#[derive(Clone, Debug)]
pub struct SwimConfig {
    /// Each member probes one other member this often.
    pub probe_period: Duration,
    /// A probe not answered in this time is retried through other members.
    pub probe_rtt: Duration,
    /// A suspected member not refuting in this time is declared down.
    pub suspect_after: Duration,
    /// How often news (membership changes, load reports) is gossiped to a few members.
    pub gossip_every: Duration,
    /// How often a member reports its own load.
    pub report_every: Duration,
    /// How often members believed down are asked to rejoin (a partition healing).
    pub announce_down_every: Duration,
}

impl Default for SwimConfig {
    fn default() -> Self {
        SwimConfig {
            probe_period: Duration::from_millis(200),
            probe_rtt: Duration::from_millis(80),
            suspect_after: Duration::from_millis(400),
            gossip_every: Duration::from_millis(100),
            report_every: Duration::from_secs(1),
            announce_down_every: Duration::from_secs(2),
        }
    }
}

impl SwimConfig {
    /// Sets the probe period, with the probe timeout at two fifths of it.
    pub fn set_probe_period(&mut self, period: Duration) {
        self.probe_period = period;
        self.probe_rtt = period * 2 / 5;
    }

    /// foca's configuration for this timing.
    fn foca(&self) -> foca::Config {
        let mut c = foca::Config::simple();
        c.probe_period = self.probe_period;
        c.probe_rtt = self.probe_rtt.min(self.probe_period / 2);
        c.num_indirect_probes = std::num::NonZeroUsize::MIN.saturating_add(2);
        c.suspect_to_down_after = self.suspect_after;
        c.max_packet_size =
            std::num::NonZeroUsize::new(MAX_DATAGRAM - seal::OVERHEAD).unwrap_or(c.max_packet_size);
        c.notify_down_members = true;
        c.remove_down_after = Duration::from_secs(3600);
        let every = |frequency, n| {
            Some(foca::PeriodicParams {
                frequency,
                num_members: std::num::NonZeroUsize::new(n).unwrap_or(std::num::NonZeroUsize::MIN),
            })
        };
        c.periodic_gossip = every(self.gossip_every, 3);
        c.periodic_announce_to_down_members = every(self.announce_down_every, 2);
        c.periodic_announce = every(Duration::from_secs(30), 1);
        c
    }
}

/// A change of who is alive, as this member sees it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Change {
    /// A member is alive (new, or back).
    Up(MemberId),
    /// A member was declared down.
    Down(MemberId),
    /// A member took a newer identity with no change of liveness.
    Renamed(MemberId),
    /// Every member this one knew is down: ask the `--join` addresses again.
    Idle,
}

/// What a step produced.
#[derive(Debug, Default)]
pub struct Outbox {
    /// Sealed datagrams and where they go.
    pub datagrams: Vec<(SocketAddr, Vec<u8>)>,
    /// Timers to set: each is given back to [`SwimNode::timer`] after its delay.
    pub timers: Vec<(Duration, Timer<MemberId>)>,
    /// Who came up or went down.
    pub changes: Vec<Change>,
}

/// Counts of this member's traffic.
#[derive(Clone, Debug, Default)]
pub struct Traffic {
    /// Datagrams sent.
    pub sent: u64,
    /// Their bytes.
    pub sent_bytes: u64,
    /// Datagrams received.
    pub received: u64,
    /// Datagrams not believed (no or wrong seal, replay, clock) or foca refused.
    pub rejected: u64,
}

type Engine = Foca<MemberId, PostcardCodec, StdRng, LoadReports>;

/// One member.
pub struct SwimNode {
    foca: Engine,
    sealer: Sealer,
    reports: Arc<Mutex<ReportTable>>,
    health: Health,
    cfg: SwimConfig,
    report_seq: u64,
    out: Outbox,
    traffic: Traffic,
}

/// foca's runtime for one step: seals what it sends, stretches timeouts by local health.
struct Step<'a> {
    out: &'a mut Outbox,
    sealer: &'a mut Sealer,
    health: &'a mut Health,
    traffic: &'a mut Traffic,
    now_ms: u64,
}

impl foca::Runtime<MemberId> for Step<'_> {
    fn notify(&mut self, n: Notification<'_, MemberId>) {
        let change = match n {
            Notification::MemberUp(id) => Change::Up(id.clone()),
            Notification::MemberDown(id) => Change::Down(id.clone()),
            Notification::Rename(_, id) => Change::Renamed(id.clone()),
            Notification::Idle => Change::Idle,
            Notification::Rejoin(_) | Notification::Defunct => {
                // Declared down while alive: most likely this member was the slow one.
                self.health.worse();
                return;
            }
            Notification::Active => return,
        };
        self.out.changes.push(change);
    }

    fn send_to(&mut self, to: MemberId, data: &[u8]) {
        let sealed = self.sealer.seal(data, self.now_ms);
        self.traffic.sent += 1;
        self.traffic.sent_bytes += sealed.len() as u64;
        self.out.datagrams.push((to.addr, sealed));
    }

    fn submit_after(&mut self, event: Timer<MemberId>, after: Duration) {
        let after = match event {
            Timer::ProbeRandomMember(_)
            | Timer::SendIndirectProbe { .. }
            | Timer::ChangeSuspectToDown { .. } => self.health.stretch(after),
            _ => after,
        };
        self.out.timers.push((after, event));
    }
}

impl SwimNode {
    /// Member `me` of the cluster with `secret`; `seed` seeds its random choices (and its
    /// datagrams' boot id).
    pub fn new(me: MemberId, secret: &[u8], cfg: SwimConfig, seed: u64) -> SwimNode {
        let handler = LoadReports::default();
        let reports = handler.table.clone();
        let foca = Foca::with_custom_broadcast(
            me,
            cfg.foca(),
            StdRng::seed_from_u64(seed),
            PostcardCodec,
            handler,
        );
        SwimNode {
            foca,
            sealer: Sealer::new(secret, seed),
            reports,
            health: Health::default(),
            cfg,
            report_seq: 0,
            out: Outbox::default(),
            traffic: Traffic::default(),
        }
    }

    fn step<T>(&mut self, now_ms: u64, f: impl FnOnce(&mut Engine, &mut Step<'_>) -> T) -> T {
        let mut step = Step {
            out: &mut self.out,
            sealer: &mut self.sealer,
            health: &mut self.health,
            traffic: &mut self.traffic,
            now_ms,
        };
        f(&mut self.foca, &mut step)
    }

    /// Asks the member at `addr` (a `--join` address) to let this one in.
    pub fn announce(&mut self, addr: SocketAddr, now_ms: u64) {
        let r = self.step(now_ms, |f, s| f.announce(MemberId::seed(addr), s));
        if let Err(e) = r {
            tracing::debug!(%addr, "announce: {e}");
        }
    }

    /// A datagram that arrived at `now_ms`.
    pub fn datagram(&mut self, bytes: &[u8], now_ms: u64) -> Result<(), Rejected> {
        self.traffic.received += 1;
        let payload = match self.sealer.open(bytes, now_ms) {
            Ok(p) => p.to_vec(),
            Err(e) => {
                self.traffic.rejected += 1;
                return Err(e);
            }
        };
        if let Err(e) = self.step(now_ms, |f, s| f.handle_data(&payload, s)) {
            self.traffic.rejected += 1;
            tracing::debug!("membership datagram refused: {e}");
        }
        Ok(())
    }

    /// A timer set earlier is due; it fires `late` after it was due.
    pub fn timer(&mut self, timer: Timer<MemberId>, late: Duration, now_ms: u64) {
        if matches!(timer, Timer::ProbeRandomMember(_)) {
            self.health.probe_round(late, self.cfg.probe_rtt / 2);
        }
        if let Err(e) = self.step(now_ms, |f, s| f.handle_timer(timer, s)) {
            tracing::debug!("membership timer: {e}");
        }
    }

    /// Adds this member's load report to what it spreads.
    pub fn report_load(&mut self, accepting: bool, load: &Load, now_ms: u64) {
        // The clock numbers reports, so a restarted daemon's are newer than its old ones.
        self.report_seq = (self.report_seq + 1).max(now_ms);
        let name = self.foca.identity().name.clone();
        let item = LoadReports::encode(&name, self.report_seq, now_ms, accepting, load);
        if let Err(e) = self.foca.add_broadcast(&item) {
            tracing::debug!("load report: {e}");
        }
    }

    /// What the steps since the last call produced.
    pub fn drain(&mut self) -> Outbox {
        std::mem::take(&mut self.out)
    }

    /// This member's identity (renewed when the cluster declared it down).
    pub fn identity(&self) -> &MemberId {
        self.foca.identity()
    }

    /// The newest load report of member `name`.
    pub fn report(&self, name: &str) -> Option<Report> {
        self.reports
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(name)
            .cloned()
    }

    /// The table of load reports (shared: readers lock it briefly).
    pub fn reports(&self) -> Arc<Mutex<ReportTable>> {
        self.reports.clone()
    }

    /// Whether `id` is an active member (alive or suspected) now.
    pub fn is_active(&self, id: &MemberId) -> bool {
        self.foca.iter_members().any(|m| m.id() == id)
    }

    /// The members foca counts as active (alive or suspected), this one excluded.
    pub fn active_members(&self) -> usize {
        self.foca.num_members()
    }

    /// This member's traffic so far.
    pub fn traffic(&self) -> &Traffic {
        &self.traffic
    }

    /// Its local health score (0 = healthy).
    pub fn health_score(&self) -> u32 {
        self.health.score()
    }

    /// Its timing.
    pub fn config(&self) -> &SwimConfig {
        &self.cfg
    }
}
