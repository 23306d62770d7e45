//! One member of the membership protocol, without I/O: datagrams, timers and load reports
//! go in with the time, datagrams to send, timers to set and membership changes come out
//! ([`Outbox`]). `membership::driver` drives it with a UDP socket and tokio's clock; the
//! simulation in `rem/tests/swim_sim/` drives a thousand of them with a simulated clock
//! and network.

use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use foca::{Foca, Notification, PostcardCodec, Timer};
use rand::rngs::StdRng;
use rand::SeedableRng;

use super::config::SwimConfig;
use super::health::Health;
use super::member::MemberId;
use super::reports::{LoadReports, Report, ReportTable};
use super::seal::{Rejected, Sealer};
use crate::wire::proto::Load;

/// A timer of a [`SwimNode`], to be given back to it when due. It belongs to one instance
/// of the protocol: a member that rejoined after the cluster declared it down starts a new
/// one, and the old one's timers are then ignored.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct SwimTimer {
    generation: u32,
    /// When it was set (unix ms).
    set_ms: u64,
    timer: Timer<MemberId>,
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
    pub timers: Vec<(Duration, SwimTimer)>,
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

/// How long this member may hear nothing at all, in probe periods, before it takes itself
/// for the one cut off and stops declaring others down.
const DEAF_PERIODS: u32 = 3;

/// How long it goes on not declaring others down while it hears nothing: after that it is
/// alone (every other member is gone) rather than cut off.
const DEAF_MAX: Duration = Duration::from_secs(10);

/// Membership changes waiting to be spread, at least, for load reports to be sent on their
/// own (about what one datagram holds).
const BURST: usize = 16;

/// One member.
pub struct SwimNode {
    foca: Engine,
    sealer: Sealer,
    reports: Arc<Mutex<ReportTable>>,
    health: Health,
    cfg: SwimConfig,
    seed: u64,
    /// Incremented each time the protocol starts anew (after a rejoin).
    generation: u32,
    /// foca's `max_transmissions` now (it follows the cluster's size).
    max_tx: u8,
    report_seq: u64,
    gossip_ticks: u64,
    /// When a datagram was last believed (unix ms).
    last_heard_ms: u64,
    out: Outbox,
    traffic: Traffic,
}

/// foca's runtime for one step: seals what it sends, stretches timeouts by local health.
struct Step<'a> {
    out: &'a mut Outbox,
    sealer: &'a mut Sealer,
    health: &'a mut Health,
    traffic: &'a mut Traffic,
    generation: u32,
    now_ms: u64,
    /// The cluster declared this member down and foca took this new identity.
    rejoined: Option<MemberId>,
}

impl foca::Runtime<MemberId> for Step<'_> {
    fn notify(&mut self, n: Notification<'_, MemberId>) {
        let change = match n {
            Notification::MemberUp(id) => Change::Up(id.clone()),
            Notification::MemberDown(id) => Change::Down(id.clone()),
            Notification::Rename(_, id) => Change::Renamed(id.clone()),
            Notification::Idle => Change::Idle,
            Notification::Rejoin(id) => {
                // Declared down while alive: most likely this member was the slow (or cut
                // off) one.
                self.health.worse();
                self.rejoined = Some(id.clone());
                return;
            }
            Notification::Defunct => {
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
        let timer = SwimTimer {
            generation: self.generation,
            set_ms: self.now_ms,
            timer: event,
        };
        self.out.timers.push((after, timer));
    }
}

/// Updates are sent this many times by each member that learns them: about 3 ln(n + 1) for
/// n members, so that the chance a member never hears of one, about e^-max_tx, stays well
/// under 1/n² (every pair knows of each other after a thousand members join at once).
pub fn max_transmissions(members: usize) -> u8 {
    let n = members as f64 + 1.0;
    (3.0 * n.ln()).ceil().clamp(6.0, 40.0) as u8
}

impl SwimNode {
    /// Member `me` of the cluster with `secret`; `seed` seeds its random choices (and its
    /// datagrams' boot id).
    pub fn new(me: MemberId, secret: &[u8], cfg: SwimConfig, seed: u64) -> SwimNode {
        let handler = LoadReports::default();
        let reports = handler.table.clone();
        let max_tx = max_transmissions(0);
        let foca = Self::engine(me, &cfg, max_tx, seed, handler);
        SwimNode {
            foca,
            sealer: Sealer::new(secret, seed),
            reports,
            health: Health::default(),
            cfg,
            seed,
            generation: 0,
            max_tx,
            report_seq: 0,
            gossip_ticks: 0,
            last_heard_ms: 0,
            out: Outbox::default(),
            traffic: Traffic::default(),
        }
    }

    fn engine(me: MemberId, cfg: &SwimConfig, max_tx: u8, seed: u64, h: LoadReports) -> Engine {
        let config = Self::foca_config(cfg, max_tx);
        Foca::with_custom_broadcast(me, config, StdRng::seed_from_u64(seed), PostcardCodec, h)
    }

    /// foca's configuration for `cfg`, each update sent `max_tx` times.
    fn foca_config(cfg: &SwimConfig, max_tx: u8) -> foca::Config {
        let mut config = cfg.foca();
        if let Some(tx) = std::num::NonZeroU8::new(max_tx) {
            config.max_transmissions = tx;
        }
        config
    }

    fn step<T>(&mut self, now_ms: u64, f: impl FnOnce(&mut Engine, &mut Step<'_>) -> T) -> T {
        let mut step = Step {
            out: &mut self.out,
            sealer: &mut self.sealer,
            health: &mut self.health,
            traffic: &mut self.traffic,
            generation: self.generation,
            now_ms,
            rejoined: None,
        };
        let r = f(&mut self.foca, &mut step);
        if let Some(id) = step.rejoined {
            self.start_anew(id, now_ms);
        }
        self.follow_cluster_size();
        r
    }

    /// After the cluster declared this member down (it was cut off, or stopped): a new
    /// instance of the protocol under the new identity, knowing the members the old one
    /// counted as active, and announced to a few of them. What the old one had still to
    /// spread is dropped: the members it declared down while it was the one cut off must
    /// not be declared down again by it, now that it is back (foca keeps its updates
    /// across a rejoin, and its author suggests a new instance for this).
    fn start_anew(&mut self, id: MemberId, now_ms: u64) {
        let known: Vec<foca::Member<MemberId>> = self
            .foca
            .iter_members()
            .map(|m| foca::Member::alive(m.id().clone()))
            .collect();
        self.generation = self.generation.wrapping_add(1);
        let seed = self.seed ^ u64::from(self.generation).rotate_left(32);
        let handler = LoadReports {
            table: self.reports.clone(),
        };
        self.foca = Self::engine(id, &self.cfg, self.max_tx, seed, handler);
        let askable: Vec<MemberId> = known.iter().take(3).map(|m| m.id().clone()).collect();
        self.step(now_ms, |f, s| {
            if let Err(e) = f.apply_many(known.into_iter(), false, &mut *s) {
                tracing::debug!("membership restart: {e}");
            }
            for m in askable {
                if let Err(e) = f.announce(m, &mut *s) {
                    tracing::debug!("membership restart: announce: {e}");
                }
            }
        });
    }

    /// Keeps `max_transmissions` in step with the number of members.
    fn follow_cluster_size(&mut self) {
        let want = max_transmissions(self.foca.num_members());
        let config = || Self::foca_config(&self.cfg, want);
        if want != self.max_tx && self.foca.set_config(config()).is_ok() {
            self.max_tx = want;
        }
    }

    /// Takes `members` as alive without spreading the news (a member list known from
    /// elsewhere, e.g. a simulation starting from a cluster that already knows itself).
    pub fn assume_alive(&mut self, members: impl Iterator<Item = MemberId>, now_ms: u64) {
        let alive = members.map(foca::Member::alive);
        if let Err(e) = self.step(now_ms, |f, s| f.apply_many(alive, false, s)) {
            tracing::debug!("assumed members: {e}");
        }
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
            Ok(p) => {
                self.last_heard_ms = now_ms;
                p.to_vec()
            }
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
    pub fn timer(&mut self, timer: SwimTimer, late: Duration, now_ms: u64) {
        if timer.generation != self.generation {
            return; // set by the instance before a restart
        }
        let slack = self.cfg.probe_rtt / 2;
        if matches!(timer.timer, Timer::ProbeRandomMember(_)) {
            self.health.probe_round(late, slack);
        } else {
            self.health.timer_fired(late, slack);
        }
        if let Timer::ChangeSuspectToDown {
            ref member_id,
            incarnation,
            ..
        } = timer.timer
        {
            if !self.still_suspect(member_id, incarnation) {
                // Refuted (or already down). foca would still send it "you are down"
                // (`notify_down_members`), and it would rejoin for nothing.
                return;
            }
            if let Some(after) = self.suspicion_left(&timer, now_ms) {
                self.out.timers.push((after, timer));
                return;
            }
        }
        let gossip = matches!(timer.timer, Timer::PeriodicGossip(_));
        let t = timer.timer;
        if let Err(e) = self.step(now_ms, |f, s| f.handle_timer(t, s)) {
            tracing::debug!("membership timer: {e}");
        }
        if gossip {
            self.gossip_ticks = self.gossip_ticks.wrapping_add(1);
        }
        if gossip && self.gossip_ticks.is_multiple_of(2) && self.foca.updates_backlog() >= BURST {
            // Membership changes fill the datagrams first: while they are many (a lab
            // booting), load reports would wait; every other gossip round they go on their
            // own meanwhile.
            if let Err(e) = self.step(now_ms, |f, s| f.broadcast(s)) {
                tracing::debug!("membership broadcast: {e}");
            }
        }
    }

    /// Whether `id` is still suspected at `incarnation` (it has not refuted).
    fn still_suspect(&self, id: &MemberId, incarnation: foca::Incarnation) -> bool {
        self.foca.iter_membership_state().any(|m| {
            m.id() == id && m.incarnation() == incarnation && m.state() == foca::State::Suspect
        })
    }

    /// How much longer a suspicion must last before its member may be declared down, if
    /// it may not be now: a suspicion lasts the suspicion timeout stretched by this member's
    /// health *now* (it may have been set while this member seemed healthy, its first
    /// probes failing because it was the slow one), and nobody is declared down while this
    /// member hears nothing (it is the one cut off: what it declared would spread when it is
    /// back).
    fn suspicion_left(&self, timer: &SwimTimer, now_ms: u64) -> Option<Duration> {
        if self.deaf(now_ms) {
            return Some(self.health.stretch(self.cfg.suspect_after));
        }
        let lasted = Duration::from_millis(now_ms.saturating_sub(timer.set_ms));
        let due = self.health.stretch(self.cfg.suspect_after);
        (lasted + Duration::from_millis(1) < due).then(|| due - lasted)
    }

    /// Whether this member has heard nothing for a while though others should have spoken:
    /// it knows at least two active members (with one, its silence is that member's), and
    /// for at most [`DEAF_MAX`] (after that it is alone, and declares the others down).
    fn deaf(&self, now_ms: u64) -> bool {
        let silent = Duration::from_millis(now_ms.saturating_sub(self.last_heard_ms));
        let window = self.health.stretch(self.cfg.probe_period) * DEAF_PERIODS;
        self.foca.num_members() >= 2 && silent > window && silent < DEAF_MAX
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn updates_are_sent_more_times_as_the_cluster_grows_slowly() {
        assert_eq!(max_transmissions(0), 6, "at least 6");
        assert_eq!(max_transmissions(4), 6);
        assert_eq!(max_transmissions(39), 12);
        assert_eq!(max_transmissions(999), 21);
        assert_eq!(max_transmissions(usize::MAX), 40, "bounded");
    }
}
