//! Jobs the farm keeps running (DESIGN section 7): `StartJob` stores a new job and starts its
//! controller on the calling daemon's host; from then on no single process or host can stop
//! the job.
//!
//! - A daemon whose local controller process exits while its job has not ended marks the job
//!   `recovering` (the exit is seen where it happens: no lease to wait for).
//! - The **supervisor** is the lowest-named live daemon, so exactly one decides in a settled
//!   cluster; on the minority side of a partition (fewer than half the known hosts live)
//!   nobody does, and nobody acts until its view of the live hosts has been the same for
//!   [`SETTLE`] (a daemon that has just rejoined hears from every host first). Each tick it reads every active job's newest record and restarts the controller
//!   of one that is recovering, whose controller's host is lost, or whose record has not been
//!   written for the lease (a stopped or stuck controller): it starts a new controller on the
//!   least-loaded host with the epoch raised, writes the record (which fences every write of
//!   the old epoch), and ends the old process if its host answers. After `job_restarts`
//!   restarts the job is failed, with the reason.
//! - Two supervisors for a moment (a partition) can only start two controllers of different
//!   epochs: the newer one's writes win everywhere, and the application's results do not
//!   depend on which controller produced them.

use std::time::Duration;

use crate::auth::identity::Identity;
use crate::daemon::ops::{Daemon, JobTag};
use crate::error::{Error, Result};
use crate::store::job_store::{self, is_ended};
use crate::wire::ids::ProcId;
use crate::wire::proto::{JobRecord, ProcessInfo};

/// What the supervisor does with one job now.
#[derive(Clone, Debug, PartialEq)]
pub enum Verdict {
    /// Nothing: it has ended, is not supervised, or its controller is alive.
    Healthy,
    /// Start its controller again, for this reason.
    Restart(String),
    /// Give up: fail the job with this message.
    Fail(String),
}

/// The supervisor's rule for record `r` at `now_ms`, with `alive` saying which hosts are live.
pub fn verdict(
    r: &JobRecord,
    alive: impl Fn(&str) -> bool,
    now_ms: u64,
    lease_ms: u64,
    max_restarts: u64,
) -> Verdict {
    if is_ended(&r.state) || r.controller_spawn.is_none() {
        return Verdict::Healthy;
    }
    let quiet_ms = now_ms.saturating_sub(r.updated_unix_ms);
    let why = if r.state == "recovering" && r.controller.is_empty() {
        "its controller exited".to_string()
    } else if !r.controller_host.is_empty() && !alive(&r.controller_host) {
        format!("its controller's host {} was lost", r.controller_host)
    } else if quiet_ms > lease_ms {
        format!(
            "its controller wrote nothing for {:.1} s",
            quiet_ms as f64 / 1000.0
        )
    } else {
        return Verdict::Healthy;
    };
    if r.epoch > max_restarts {
        Verdict::Fail(format!(
            "{why}, and the controller was restarted {max_restarts} times already"
        ))
    } else {
        Verdict::Restart(why)
    }
}

/// The lowest-named live host: the supervisor, in this daemon's view; nobody when fewer
/// than half the known hosts are live (the minority side of a partition restarts nothing).
pub fn supervisor(hosts: &[crate::wire::proto::HostInfo]) -> Option<&str> {
    let alive = hosts.iter().filter(|h| h.alive).count();
    if alive * 2 < hosts.len() {
        return None;
    }
    hosts
        .iter()
        .filter(|h| h.alive)
        .map(|h| h.name.as_str())
        .min()
}

impl Daemon {
    /// Stores `who`'s new job and starts its controller on `controller_spawn.host`, or else on
    /// the least-loaded live host when `anywhere`, or else on this host. A job id whose job has ended is taken up again at the next epoch (its
    /// checkpoint is where the new controller starts from); one still active is refused.
    pub async fn start_job(
        &self,
        who: &Identity,
        mut record: JobRecord,
        anywhere: bool,
    ) -> Result<JobRecord> {
        let spawn = record
            .controller_spawn
            .as_ref()
            .ok_or_else(|| Error::Invalid("a job to start needs its controller_spawn".into()))?;
        let host = match (spawn.host.is_empty(), anywhere) {
            (false, _) => Some(spawn.host.clone()),
            (true, true) => None,
            (true, false) => Some(self.name.clone()),
        };
        let existing = self
            .list_jobs(&Identity::user(who.user.clone()))
            .await?
            .into_iter()
            .find(|r| r.id == record.id);
        if let Some(r) = &existing {
            if !is_ended(&r.state) {
                return Err(Error::Invalid(format!(
                    "job {} exists and is {}: choose another id",
                    r.id, r.state
                )));
            }
            record.created_unix_ms = r.created_unix_ms;
        }
        // A record's epoch comes from a client: the last one cannot be taken up again.
        record.epoch = match existing {
            None => 1,
            Some(r) => r.epoch.checked_add(1).ok_or_else(|| {
                Error::Invalid(format!(
                    "job {} is at the last epoch: choose another id",
                    r.id
                ))
            })?,
        };
        record.state = "queued".into();
        record.message.clear();
        record.controller.clear();
        record.controller_host.clear();
        if record.created_unix_ms == 0 {
            record.created_unix_ms = job_store::unix_ms(std::time::SystemTime::now());
        }
        self.put_job(who, record.clone()).await?;
        match self.spawn_controller(who, &record, host).await {
            Ok((id, host)) => {
                record.controller = id;
                record.controller_host = host;
                self.put_job(who, record.clone()).await?;
                Ok(record)
            }
            Err(e) => {
                record.state = "failed".into();
                record.message = format!("cannot start the controller: {e}");
                let _ = self.put_job(who, record).await;
                Err(e)
            }
        }
    }

    /// Starts one controller of `record` at its epoch (on `host`, or the least-loaded).
    async fn spawn_controller(
        &self,
        who: &Identity,
        record: &JobRecord,
        host: Option<String>,
    ) -> Result<(String, String)> {
        let mut req = record.controller_spawn.clone().unwrap_or_default();
        req.count = 1;
        req.owner.clear();
        req.allow_same_host = true;
        req.job = format!("{}.c{}", record.id, record.epoch);
        req.host = host.unwrap_or_default();
        // A controller coordinates: it holds no render slots (its workers do).
        (req.slots_min, req.slots_max, req.up_to) = (0, 0, false);
        let tag = JobTag {
            record: record.id.clone(),
            epoch: record.epoch,
        };
        let reply = self.spawn_tagged(who, req, &tag).await?;
        let p = reply
            .processes
            .into_iter()
            .next()
            .ok_or_else(|| Error::Invalid("no controller was placed".into()))?;
        Ok((p.proc_id, p.host))
    }

    /// One supervisor tick: when this daemon is the supervisor and its view of the live hosts
    /// has settled (`view`), acts on every active job.
    pub async fn supervise(&self, view: &mut ViewSettle) -> Result<()> {
        let hosts = self.membership.hosts();
        let settled = view.settled(&hosts, std::time::Instant::now());
        if !settled || supervisor(&hosts) != Some(self.name.as_str()) {
            return Ok(());
        }
        let alive = |name: &str| hosts.iter().any(|h| h.name == name && h.alive);
        let everyone = Identity {
            user: String::new(),
            admin: true,
        };
        let now = job_store::unix_ms(std::time::SystemTime::now());
        for r in self.list_jobs(&everyone).await? {
            let lease = self.limits.job_lease_ms;
            match verdict(&r, alive, now, lease, self.limits.job_restarts) {
                Verdict::Healthy => {}
                Verdict::Restart(why) => self.restart(r, &why).await,
                Verdict::Fail(why) => {
                    tracing::warn!(job = %r.id, user = %r.user, "failing the job: {why}");
                    let mut failed = r;
                    failed.state = "failed".into();
                    failed.message = why;
                    let owner = Identity::user(failed.user.clone());
                    let _ = self.put_job(&owner, failed).await;
                }
            }
        }
        Ok(())
    }

    /// Starts `r`'s controller again at the next epoch, then ends the old one.
    async fn restart(&self, r: JobRecord, why: &str) {
        let owner = Identity::user(r.user.clone());
        let mut next = r.clone();
        let Some(epoch) = r.epoch.checked_add(1) else {
            // An epoch from a client's record that cannot go up: the job cannot move.
            next.state = "failed".into();
            next.message = format!("{why}; and the job is at the last epoch");
            let _ = self.put_job(&owner, next).await;
            return;
        };
        next.epoch = epoch;
        next.message = why.to_string();
        tracing::warn!(job = %r.id, user = %r.user, epoch = next.epoch, "restarting the controller: {why}");
        match self.spawn_controller(&owner, &next, None).await {
            Ok((id, host)) => {
                next.state = "running".into();
                next.controller = id.clone();
                next.controller_host = host;
                if let Err(e) = self.put_job(&owner, next).await {
                    // Another supervisor moved the job first: this controller is not needed.
                    tracing::warn!(job = %r.id, "the restarted controller stands down: {e}");
                    if let Some(id) = ProcId::parse(&id) {
                        let _ = self.kill(&admin_of(&r.user), id).await;
                    }
                    return;
                }
            }
            Err(e) => {
                // Tried again at the next tick (the lease has passed, or it is recovering).
                tracing::warn!(job = %r.id, "cannot restart the controller: {e}");
                return;
            }
        }
        if let Some(old) = ProcId::parse(&r.controller) {
            if self.membership.live_addr(old.host()).is_some() || old.host() == self.name {
                let _ = self.kill(&admin_of(&r.user), old).await;
            }
        }
    }

    /// Marks the jobs of this host's controllers that exited unfinished as `recovering`
    /// (once per process), so the supervisor restarts them at once. `seen` keeps only the
    /// exited controllers the process table still lists, so it stays as small as that.
    pub async fn note_exited_controllers(&self, seen: &mut std::collections::HashSet<String>) {
        let Ok(procs) = self.processes.list().await else {
            return;
        };
        seen.retain(|id| procs.iter().any(|p| p.proc_id == *id));
        let exited: Vec<ProcessInfo> = procs
            .into_iter()
            .filter(|p| !p.job_record.is_empty() && p.state == "exited")
            .filter(|p| !seen.contains(&p.proc_id))
            .collect();
        for p in exited {
            seen.insert(p.proc_id.clone());
            let owner = Identity::user(p.user.clone());
            let Ok(records) = self.list_jobs(&owner).await else {
                continue;
            };
            let Some(mut r) = records.into_iter().find(|r| r.id == p.job_record) else {
                continue;
            };
            if is_ended(&r.state) || r.epoch != p.job_epoch || r.controller != p.proc_id {
                continue;
            }
            tracing::warn!(job = %r.id, proc = %p.proc_id, code = ?p.exit_code, signal = ?p.signal,
                "the job's controller exited unfinished");
            r.state = "recovering".into();
            r.message = match (p.exit_code, p.signal) {
                (Some(c), _) => format!("its controller exited with code {c}"),
                (_, Some(s)) => format!("its controller was killed by signal {s}"),
                _ => "its controller exited".into(),
            };
            r.controller.clear();
            r.controller_host.clear();
            let _ = self.put_job(&owner, r).await;
        }
    }
}

/// An admin acting on `user`'s processes (the daemons' own housekeeping).
fn admin_of(user: &str) -> Identity {
    Identity {
        user: user.to_string(),
        admin: true,
    }
}

/// How long the set of live hosts must stay the same before the supervisor acts: a daemon
/// that has just rejoined, or just become the supervisor, first hears from every host, so it
/// does not restart a job on the word of a stale record.
pub const SETTLE: Duration = Duration::from_millis(1500);

/// Whether this daemon's view of the live hosts has settled.
#[derive(Debug)]
pub struct ViewSettle {
    alive: Vec<String>,
    since: std::time::Instant,
}

impl ViewSettle {
    /// A view first seen at `now`.
    pub fn new(now: std::time::Instant) -> Self {
        ViewSettle {
            alive: Vec::new(),
            since: now,
        }
    }

    /// Notes the view at `now`; true when it has not changed for [`SETTLE`].
    pub fn settled(
        &mut self,
        hosts: &[crate::wire::proto::HostInfo],
        now: std::time::Instant,
    ) -> bool {
        let mut alive: Vec<String> = hosts
            .iter()
            .filter(|h| h.alive)
            .map(|h| h.name.clone())
            .collect();
        alive.sort();
        if alive != self.alive {
            self.alive = alive;
            self.since = now;
        }
        now.duration_since(self.since) >= SETTLE
    }
}

/// How often the supervisor looks at the jobs: a quarter of the lease, at most every 500 ms.
pub fn tick(lease_ms: u64) -> Duration {
    Duration::from_millis((lease_ms / 4).clamp(50, 500))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::proto::{HostInfo, SpawnRequest};

    fn running(controller_host: &str, updated: u64, epoch: u64) -> JobRecord {
        JobRecord {
            id: "j".into(),
            user: "alice".into(),
            state: "running".into(),
            epoch,
            controller: format!("{controller_host}/1"),
            controller_host: controller_host.into(),
            updated_unix_ms: updated,
            controller_spawn: Some(SpawnRequest::default()),
            ..JobRecord::default()
        }
    }

    #[test]
    fn the_supervisor_restarts_exited_lost_and_silent_controllers_and_gives_up_in_the_end() {
        let alive = |h: &str| h != "b";
        let v = |r: &JobRecord| verdict(r, alive, 20_000, 10_000, 3);
        assert_eq!(v(&running("a", 15_000, 1)), Verdict::Healthy);
        assert!(
            matches!(v(&running("b", 15_000, 1)), Verdict::Restart(w) if w.contains("host b was lost"))
        );
        assert!(
            matches!(v(&running("a", 5_000, 1)), Verdict::Restart(w) if w.contains("wrote nothing for 15.0 s"))
        );
        let mut exited = running("", 19_000, 2);
        exited.state = "recovering".into();
        exited.controller.clear();
        assert!(matches!(v(&exited), Verdict::Restart(w) if w.contains("exited")));
        // Recovering with a controller just started: it has its lease.
        let mut started = running("a", 19_000, 2);
        started.state = "recovering".into();
        assert_eq!(v(&started), Verdict::Healthy);
        assert!(
            matches!(v(&running("b", 15_000, 4)), Verdict::Fail(w) if w.contains("restarted 3 times"))
        );
        let mut ended = running("b", 0, 1);
        ended.state = "cancelled".into();
        assert_eq!(v(&ended), Verdict::Healthy);
        let mut unsupervised = running("b", 0, 1);
        unsupervised.controller_spawn = None;
        assert_eq!(v(&unsupervised), Verdict::Healthy);
    }

    #[test]
    fn the_supervisor_is_the_lowest_named_live_host() {
        let host = |name: &str, alive| HostInfo {
            name: name.into(),
            alive,
            ..HostInfo::default()
        };
        let hosts = [host("c", true), host("a", false), host("b", true)];
        assert_eq!(supervisor(&hosts), Some("b"));
        assert_eq!(supervisor(&[]), None);
        // Cut off from most of the cluster: no supervisor (half is enough: two hosts).
        let alone = [host("a", true), host("b", false), host("c", false)];
        assert_eq!(supervisor(&alone), None);
        assert_eq!(supervisor(&alone[..2]), Some("a"));
        assert_eq!(tick(10_000), Duration::from_millis(500));
        // A view acts only once it has stayed the same for SETTLE.
        let t0 = std::time::Instant::now();
        let mut view = ViewSettle::new(t0);
        assert!(!view.settled(&hosts, t0));
        assert!(view.settled(&hosts, t0 + SETTLE));
        let rejoined = [host("c", true), host("a", true), host("b", true)];
        assert!(!view.settled(&rejoined, t0 + SETTLE * 2));
        assert!(view.settled(&rejoined, t0 + SETTLE * 3));
        assert_eq!(tick(400), Duration::from_millis(100));
    }
}
