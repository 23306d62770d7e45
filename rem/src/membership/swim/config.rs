//! The protocol's timing ([`SwimConfig`]) and foca's configuration made from it.

use std::time::Duration;

use super::seal;

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
    pub(super) fn foca(&self) -> foca::Config {
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
