//! What a run measured, and how it is printed.

use super::sim::{as_ms, Micros, Phase};

/// Time from an event to each member's `Change::Down` for it.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Detection {
    /// Members that saw it up before, and should see it down.
    pub(crate) observers: usize,
    /// Those that did.
    pub(crate) detected: usize,
    pub(crate) first_ms: f64,
    pub(crate) median_ms: f64,
    pub(crate) p99_ms: f64,
    pub(crate) max_ms: f64,
}

/// The q-quantile of sorted `v` (nearest rank).
pub(crate) fn quantile(v: &[u64], q: f64) -> u64 {
    let k = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len());
    v[k - 1]
}

impl Detection {
    pub(crate) fn of(observers: usize, mut times: Vec<Micros>) -> Detection {
        if times.is_empty() {
            return Detection {
                observers,
                ..Detection::default()
            };
        }
        times.sort_unstable();
        Detection {
            observers,
            detected: times.len(),
            first_ms: as_ms(times[0]),
            median_ms: as_ms(quantile(&times, 0.5)),
            p99_ms: as_ms(quantile(&times, 0.99)),
            max_ms: as_ms(times[times.len() - 1]),
        }
    }

    pub(crate) fn all(&self) -> bool {
        self.observers > 0 && self.detected == self.observers
    }
}

/// What a run measured.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Figures {
    pub(crate) n: usize,
    pub(crate) loss: f64,
    pub(crate) seed: u64,
    /// When every member saw every other up.
    pub(crate) converged_ms: Option<f64>,
    /// At the end of the warm-up: members seeing every other up, and (member, member)
    /// pairs where the first does not see the second.
    pub(crate) converged_members: usize,
    pub(crate) unseen_pairs: usize,
    pub(crate) msgs_per_member_s: f64,
    pub(crate) bytes_per_member_s: f64,
    /// Age of the newest load report a member has of another (median, p90), and the
    /// fraction of pairs with none, at the end of the steady state.
    pub(crate) report_age_median_ms: f64,
    pub(crate) report_age_p90_ms: f64,
    pub(crate) reports_missing: f64,
    /// The same at the end of the run.
    pub(crate) end_report_age_median_ms: f64,
    pub(crate) end_report_age_p90_ms: f64,
    pub(crate) end_reports_missing: f64,
    pub(crate) kill: Detection,
    pub(crate) partition: Detection,
    /// From the heal until every member sees the partitioned one up again.
    pub(crate) rejoin_ms: Option<f64>,
    /// From the heal until the partitioned one sees up again every live member it saw up
    /// before.
    pub(crate) rejoined_sees_all_ms: Option<f64>,
    /// Per phase: false accusations (a member's `Change::Down` for a reachable member),
    /// and how many distinct members were falsely accused.
    pub(crate) false_accusations: Vec<(Phase, u64, usize)>,
    /// Downs the partitioned member saw of others while cut off (expected).
    pub(crate) isolated_downs: u64,
    /// New identities taken (a member told the cluster declared it down rejoins), and by
    /// how many members.
    pub(crate) renewals: u64,
    pub(crate) renewed_members: usize,
    pub(crate) slow_max_health: u32,
    pub(crate) datagrams: u64,
    pub(crate) lost: u64,
    pub(crate) rejected: u64,
    pub(crate) simulated_s: f64,
}

impl Figures {
    pub(crate) fn false_total(&self) -> u64 {
        self.false_accusations.iter().map(|f| f.1).sum()
    }

    pub(crate) fn print(&self) {
        let d = |d: &Detection| {
            format!(
                "first {:.0} ms, median {:.0} ms, p99 {:.0} ms, max {:.0} ms ({}/{} members)",
                d.first_ms, d.median_ms, d.p99_ms, d.max_ms, d.detected, d.observers
            )
        };
        let o = |t: Option<f64>| t.map_or("never".to_string(), |t| format!("{t:.0} ms"));
        let falses: Vec<String> = self
            .false_accusations
            .iter()
            .map(|(p, n, who)| format!("{} {n} ({who})", p.name()))
            .collect();
        let rows = [
            ("members", self.n.to_string()),
            ("datagram loss", format!("{:.1}%", self.loss * 100.0)),
            ("seed", format!("{:#x}", self.seed)),
            ("simulated", format!("{:.1} s", self.simulated_s)),
            ("converged after", o(self.converged_ms)),
            (
                "end of warm-up",
                format!(
                    "{} members see all; {} pairs unseen",
                    self.converged_members, self.unseen_pairs
                ),
            ),
            (
                "datagrams/member/s",
                format!("{:.1} (steady state)", self.msgs_per_member_s),
            ),
            (
                "bytes/member/s",
                format!("{:.0} (steady state)", self.bytes_per_member_s),
            ),
            (
                "load report age",
                format!(
                    "median {:.0} ms, p90 {:.0} ms, {:.1}% of pairs none",
                    self.report_age_median_ms,
                    self.report_age_p90_ms,
                    self.reports_missing * 100.0
                ),
            ),
            (
                "... at the end",
                format!(
                    "median {:.0} ms, p90 {:.0} ms, {:.1}% of pairs none",
                    self.end_report_age_median_ms,
                    self.end_report_age_p90_ms,
                    self.end_reports_missing * 100.0
                ),
            ),
            ("kill detection", d(&self.kill)),
            ("partition detection", d(&self.partition)),
            ("healed: up again after", o(self.rejoin_ms)),
            ("healed: sees all after", o(self.rejoined_sees_all_ms)),
            (
                "false accusations",
                format!("{} in all: {}", self.false_total(), falses.join(", ")),
            ),
            (
                "isolated's own downs",
                format!("{} (of members it could not reach)", self.isolated_downs),
            ),
            (
                "identities renewed",
                format!("{} (by {} members)", self.renewals, self.renewed_members),
            ),
            ("slow: max health", self.slow_max_health.to_string()),
            (
                "datagrams",
                format!(
                    "{} sent, {} lost, {} rejected",
                    self.datagrams, self.lost, self.rejected
                ),
            ),
        ];
        let mut table =
            String::from("\n== SWIM simulation (false accusations: events (members))\n");
        for (k, v) in rows {
            table.push_str(&format!("  {k:<24} {v}\n"));
        }
        eprint!("{table}");
    }
}
