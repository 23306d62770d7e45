//! The job's crew as the controller sees it: which workers are live, on which hosts, holding
//! how many of the farm's slots, and how many failed. The controller actor keeps it; the farm
//! controller's share keeper reads it to grow or shrink the job toward its share of the
//! queue ([`Input::Workers`](super::Input::Workers), [`Input::Retire`](super::Input::Retire)).

use crate::distrib::nodes::NodeStats;
use crate::distrib::timeline::NodeTimeline;
use rem::ProcId;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::{Arc, Mutex, MutexGuard};

/// The live workers (by node index: host and slots) and the faults so far.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CrewView {
    /// Node index to (host, slots held).
    pub live: BTreeMap<usize, (String, u32)>,
    /// Workers that exited early or were lost (not those retired).
    pub faults: u32,
    /// Hosts whose worker renders another image version (refused at its Ready): the site
    /// starts none there again for this job.
    pub refused_hosts: BTreeSet<String>,
}

impl CrewView {
    /// The crew of `workers` (node i is the i-th), before the actor keeps it.
    pub fn of(workers: &[WorkerProc]) -> CrewView {
        CrewView {
            live: workers
                .iter()
                .enumerate()
                .map(|(i, w)| (i, (w.host.clone(), w.slots)))
                .collect(),
            faults: 0,
            refused_hosts: BTreeSet::new(),
        }
    }

    /// Slots the live workers hold.
    pub fn slots(&self) -> u32 {
        self.live.values().map(|(_, s)| *s).sum()
    }

    /// Hosts the live workers run on.
    pub fn hosts(&self) -> Vec<String> {
        self.live.values().map(|(h, _)| h.clone()).collect()
    }

    /// Where the site starts no worker for the job: `asked` (the user's `--avoid-host`), the
    /// refused hosts, and unless the job may share a host, the live workers' hosts; at most
    /// [`rem::wire::MAX_AVOID_HOSTS`], in that order.
    pub fn avoid(&self, asked: &[String], same_host: bool) -> Vec<String> {
        let mut avoid = asked.to_vec();
        avoid.extend(self.refused_hosts.iter().cloned());
        if !same_host {
            avoid.extend(self.hosts());
        }
        avoid.truncate(rem::wire::MAX_AVOID_HOSTS);
        avoid
    }
}

/// A shared [`CrewView`].
#[derive(Clone, Debug, Default)]
pub struct Crew(Arc<Mutex<CrewView>>);

impl Crew {
    /// What it is now.
    pub fn view(&self) -> CrewView {
        self.lock().clone()
    }

    pub(super) fn joined(&self, node: usize, host: &str, slots: u32) {
        self.lock().live.insert(node, (host.to_string(), slots));
    }

    /// Node `node` left; `fault`: it failed rather than being retired or finishing.
    pub(super) fn left(&self, node: usize, fault: bool) {
        let mut v = self.lock();
        if v.live.remove(&node).is_some() && fault {
            v.faults += 1;
        }
    }

    /// The worker on `host` renders another image version: none is started there again.
    pub(super) fn refused(&self, host: &str) {
        self.lock().refused_hosts.insert(host.to_string());
    }

    fn lock(&self) -> MutexGuard<'_, CrewView> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// A spawned worker.
#[derive(Clone, Debug)]
pub struct WorkerProc {
    /// REM's id of the worker process: where its messages come from and go to.
    pub proc_id: ProcId,
    /// The host it runs on, as REM names it (the per-node table's first column).
    pub host: String,
    /// Its process id on that host.
    pub pid: u32,
    /// The host's load per core as REM reported it when the job started (cgroup-aware);
    /// `None` leaves the column to the worker's own load average.
    pub load_at_start: Option<f64>,
    /// Started by the job's previous controller and taken over: it gets Adopt, not Scene.
    pub adopted: bool,
    /// The farm's render slots it holds (0: none, or not known).
    pub slots: u32,
}

impl WorkerProc {
    /// The workers REM placed for `job`, with their hosts' load from `live` (REM's figures
    /// when the job started).
    pub fn placed(job: &rem::Job, live: &[rem::HostInfo]) -> Vec<WorkerProc> {
        job.processes
            .iter()
            .map(|p| WorkerProc {
                proc_id: p.proc_id.clone(),
                host: p.host.clone(),
                pid: p.pid,
                load_at_start: load_per_core(live, &p.host),
                adopted: false,
                slots: p.slots,
            })
            .collect()
    }
}

impl WorkerProc {
    /// Its row of the per-node table, as node `i` (from 0), spawned at `spawned` (seconds
    /// since the job's submit).
    pub(super) fn node_row(&self, i: usize, spawned: Option<f64>) -> NodeStats {
        NodeStats {
            node: i + 1,
            proc_id: self.proc_id.to_string(),
            host: self.host.clone(),
            pid: self.pid,
            load_at_start: self.load_at_start.unwrap_or_default(),
            rem_load: self.load_at_start.is_some(),
            timeline: NodeTimeline {
                spawned,
                ..Default::default()
            },
            ..Default::default()
        }
    }
}

/// REM's load per core of `host` among `live`, if it reported one.
pub fn load_per_core(live: &[rem::HostInfo], host: &str) -> Option<f64> {
    live.iter()
        .find(|h| h.name == host)
        .and_then(|h| h.load.as_ref())
        .map(|l| l.load_per_core)
}

/// Which of the live workers (node index, slots) to retire to give back `excess` slots:
/// the newest first; the last one stays when `keep_one` (the job still has a share).
pub fn to_retire(live: &[(usize, u32)], excess: u32, keep_one: bool) -> Vec<usize> {
    let mut out = Vec::new();
    let mut left = excess;
    let mut remaining = live.len();
    for &(node, slots) in live.iter().rev() {
        if left == 0 || (keep_one && remaining <= 1) {
            break;
        }
        out.push(node);
        left = left.saturating_sub(slots.max(1));
        remaining -= 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_newest_workers_go_first_and_one_stays_while_the_job_has_a_share() {
        let live = [(0, 2), (1, 1), (3, 2)];
        assert_eq!(to_retire(&live, 0, true), Vec::<usize>::new());
        assert_eq!(to_retire(&live, 1, true), [3]);
        assert_eq!(to_retire(&live, 3, true), [3, 1]);
        assert_eq!(to_retire(&live, 5, true), [3, 1], "one stays");
        assert_eq!(to_retire(&live, 5, false), [3, 1, 0]);
        assert_eq!(to_retire(&[], 2, false), Vec::<usize>::new());
    }

    #[test]
    fn the_view_counts_slots_hosts_and_faults() {
        let crew = Crew::default();
        crew.joined(0, "a", 2);
        crew.joined(1, "b", 1);
        assert_eq!(
            (crew.view().slots(), crew.view().hosts()),
            (3, vec!["a".into(), "b".into()])
        );
        crew.left(1, true);
        crew.left(1, true);
        crew.left(0, false);
        assert_eq!((crew.view().slots(), crew.view().faults), (0, 1));
    }

    #[test]
    fn no_worker_is_started_where_asked_not_to_where_one_was_refused_or_where_one_runs() {
        let crew = Crew::default();
        crew.joined(0, "a", 1);
        crew.joined(1, "b", 1);
        crew.refused("c");
        crew.left(1, true);
        let view = crew.view();
        let asked = ["x".to_string()];
        assert_eq!(view.avoid(&asked, false), ["x", "c", "a"]);
        assert_eq!(
            view.avoid(&asked, true),
            ["x", "c"],
            "a job may share its hosts"
        );
        let many = vec!["y".to_string(); rem::wire::MAX_AVOID_HOSTS];
        assert_eq!(view.avoid(&many, false).len(), rem::wire::MAX_AVOID_HOSTS);
    }
}
