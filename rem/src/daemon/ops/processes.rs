//! Processes: spawning them on the least-loaded hosts, starting them here, and killing,
//! adopting, listing them and reading their output wherever they run.

use std::collections::{BTreeMap, HashSet};
use std::sync::atomic::Ordering;

use tokio::task::JoinSet;

use super::{Daemon, JobTag};
use crate::auth::identity::Identity;
use crate::auth::peer_auth::method;
use crate::daemon::placement::{self, Candidate};
use crate::daemon::process::table::StartSpec;
use crate::error::{Error, Result};
use crate::membership::peers::PeerPool;
use crate::wire::ids::{is_valid_name, shown, ProcId};
use crate::wire::proto::{
    job_event, AdoptLocalRequest, JobEvent, KillLocalRequest, LogsLocalRequest, LogsReply,
    Placement, ProcessInfo, PsRequest, SpawnReply, SpawnRequest, StartLocalRequest,
};
use crate::wire::MAX_AVOID_HOSTS;

impl Daemon {
    /// Places and starts `req.count` processes for `who`, who owns them.
    pub async fn spawn(&self, who: &Identity, req: SpawnRequest) -> Result<SpawnReply> {
        self.spawn_tagged(who, req, &JobTag::default()).await
    }

    /// [`spawn`](Self::spawn), telling the processes (job controllers) which job record and
    /// epoch they run.
    pub(crate) async fn spawn_tagged(
        &self,
        who: &Identity,
        req: SpawnRequest,
        tag: &JobTag,
    ) -> Result<SpawnReply> {
        let job = self.check_spawn(who, &req)?;
        let candidates = self.candidates(&req)?;
        let ask = slot_ask(&req);
        let (tried, first) = self
            .place_and_start(who, (&req, &job, tag), &candidates, req.count)
            .await;
        let as_many_as_fit = ask.min > 0 && ask.up_to;
        let (mut placed, mut refused) = match first {
            Ok(p) => (p, None),
            Err(e) if as_many_as_fit => (Vec::new(), Some(e)),
            Err(e) => return Err(e),
        };
        if as_many_as_fit && (placed.len() as u32) < req.count {
            let left = req.count - placed.len() as u32;
            let spawn = (&req, job.as_str(), tag);
            let more = self
                .start_on_hosts_reported_full(who, spawn, &candidates, &tried, left)
                .await;
            match more {
                Ok(more) => placed.extend(more),
                Err(e) => refused = refused.or(Some(e)),
            }
        }
        if placed.is_empty() {
            return Err(refused.unwrap_or_else(|| {
                Error::Limit(format!(
                    "no live host has {} render slots free (the farm's slots are held)",
                    req.slots_min
                ))
            }));
        }
        placed.sort_by(|a, b| a.proc_id.cmp(&b.proc_id));
        if !req.owner.is_empty() {
            self.announce_started(&job, &req.owner, &placed).await;
        }
        Ok(SpawnReply {
            job,
            processes: placed,
        })
    }

    /// Places `count` processes of `req` on `candidates` and starts them: the hosts chosen,
    /// and what started (or why nothing did).
    async fn place_and_start(
        &self,
        who: &Identity,
        (req, job, tag): (&SpawnRequest, &str, &JobTag),
        candidates: &[Candidate],
        count: u32,
    ) -> (Vec<String>, Result<Vec<Placement>>) {
        let chosen = match placement::place_with_slots(
            candidates,
            count,
            req.allow_same_host,
            slot_ask(req),
            self.limits.spawn_count,
        ) {
            Ok(c) => c,
            Err(e) => return (Vec::new(), Err(e)),
        };
        let mut per_host: BTreeMap<String, u32> = BTreeMap::new();
        for h in &chosen {
            *per_host.entry(h.clone()).or_default() += 1;
        }
        (
            chosen,
            self.start_placed(who, req, job, tag, per_host).await,
        )
    }

    /// For a spawn of as many as fit: the load reports are up to a second old, so a host
    /// they say is full may have freed its slots since (a job just ended there). The hosts
    /// not `tried` yet that lend enough are asked as if free; each decides by its own count
    /// and refuses what it cannot give.
    async fn start_on_hosts_reported_full(
        &self,
        who: &Identity,
        spawn: (&SpawnRequest, &str, &JobTag),
        candidates: &[Candidate],
        tried: &[String],
        count: u32,
    ) -> Result<Vec<Placement>> {
        let min = spawn.0.slots_min;
        let rest: Vec<Candidate> = candidates
            .iter()
            .filter(|c| !tried.contains(&c.name) && c.lent_slots >= min)
            .map(|c| Candidate {
                free_slots: c.lent_slots,
                ..c.clone()
            })
            .collect();
        if rest.is_empty() {
            return Ok(Vec::new());
        }
        self.place_and_start(who, spawn, &rest, count).await.1
    }

    /// Checks a spawn request against this daemon's state, limits and policy; the job id it
    /// runs under (a new one when the request names none).
    fn check_spawn(&self, who: &Identity, req: &SpawnRequest) -> Result<String> {
        self.check_accepting()?;
        self.check_count(req.count)?;
        self.policy
            .check(&self.name, &req.program, &req.args, &req.env)?;
        if let Some(n) = req.nice {
            if !(-20..=19).contains(&n) {
                return Err(Error::Invalid(format!("nice {n} is outside -20..19")));
            }
        }
        if !req.owner.is_empty() {
            self.check_owner(who, &req.owner)?;
        }
        if req.job.is_empty() {
            Ok(format!(
                "{}-{}",
                self.name,
                self.seq.fetch_add(1, Ordering::Relaxed)
            ))
        } else if is_valid_name(&req.job) {
            Ok(req.job.clone())
        } else {
            Err(Error::Invalid(format!("bad job id {}", shown(&req.job))))
        }
    }

    /// The hosts a spawn may go to: alive, accepting, the one it names (if any), none it
    /// avoids.
    fn candidates(&self, req: &SpawnRequest) -> Result<Vec<Candidate>> {
        if req.avoid_hosts.len() > MAX_AVOID_HOSTS {
            return Err(Error::Invalid(format!(
                "{} hosts to avoid; at most {MAX_AVOID_HOSTS}",
                req.avoid_hosts.len()
            )));
        }
        let avoid: HashSet<&str> = req.avoid_hosts.iter().map(String::as_str).collect();
        Ok(self
            .membership
            .hosts()
            .into_iter()
            .filter(|h| h.alive && h.accepting)
            .filter(|h| req.host.is_empty() || h.name == req.host)
            .filter(|h| !avoid.contains(h.name.as_str()))
            .map(|h| {
                let load = h.load.unwrap_or_default();
                Candidate {
                    name: h.name,
                    load_per_core: load.load_per_core,
                    cores: load.cores,
                    capacity: load.capacity,
                    free_slots: load.slots.saturating_sub(load.slots_used),
                    lent_slots: load.slots,
                }
            })
            .collect())
    }

    /// Starts the processes of `job` on their hosts (`per_host`: how many on each), here
    /// and on peers at once; if any host fails, kills those started and returns its error.
    async fn start_placed(
        &self,
        who: &Identity,
        req: &SpawnRequest,
        job: &str,
        tag: &JobTag,
        per_host: BTreeMap<String, u32>,
    ) -> Result<Vec<Placement>> {
        let mut tasks = JoinSet::new();
        for (host, count) in per_host {
            let spec = StartSpec {
                job: job.to_string(),
                owner: req.owner.clone(),
                user: who.user.clone(),
                program: req.program.clone(),
                args: req.args.clone(),
                env: req.env.clone().into_iter().collect(),
                nice: req.nice,
                count,
                job_record: tag.record.clone(),
                job_epoch: tag.epoch,
                slots_min: req.slots_min,
                slots_max: req.slots_max,
            };
            let processes = self.processes.clone();
            let remote = (host != self.name).then(|| self.membership.live_addr(&host));
            let peers = self.peers.clone();
            tasks.spawn(async move {
                match remote {
                    None => processes.start_local(spec).await,
                    Some(None) => Err(Error::Unreachable {
                        host,
                        reason: "lost".into(),
                    }),
                    Some(Some(addr)) => start_remote(&peers, &host, &addr, spec).await,
                }
            });
        }
        let mut placed = Vec::new();
        let mut failure = None;
        while let Some(r) = tasks.join_next().await {
            match r {
                Ok(Ok(p)) => placed.extend(p),
                Ok(Err(e)) => failure = failure.or(Some(e)),
                Err(e) => failure = failure.or(Some(Error::Io(std::io::Error::other(e)))),
            }
        }
        // A spawn of as many as fit keeps what started (a host whose slots went meanwhile
        // refused its share).
        let keep = req.up_to && !placed.is_empty();
        if let Some(e) = failure.filter(|_| !keep) {
            for p in &placed {
                if let Some(id) = ProcId::parse(&p.proc_id) {
                    let _ = self.kill(who, id).await;
                }
            }
            return Err(e);
        }
        Ok(placed)
    }

    /// Notes the job's owner and sends it a `Started` event for every placed process.
    async fn announce_started(&self, job: &str, owner: &str, placed: &[Placement]) {
        self.jobs.record(job, owner, placed).await;
        for p in placed {
            let event = JobEvent {
                job: job.to_string(),
                proc_id: p.proc_id.clone(),
                host: p.host.clone(),
                kind: job_event::Kind::Started as i32,
                owner: owner.to_string(),
                ..JobEvent::default()
            };
            let _ = self.router.route_event(event).await;
        }
    }

    /// A spawn's owner (who receives the job's events) must be a relay process attached here
    /// by the same user: nobody sends events to another user's process.
    fn check_owner(&self, who: &Identity, owner: &str) -> Result<()> {
        let id = ProcId::parse(owner)
            .ok_or_else(|| Error::Invalid(format!("bad owner id {}", shown(owner))))?;
        match self.router.user_of(id.as_str()) {
            Some(user) if user == who.user => Ok(()),
            Some(_) => Err(Error::Refused(format!(
                "owner {id} belongs to another user (you are {})",
                who.user
            ))),
            None => Err(Error::Invalid(format!(
                "owner {id} is not attached to host {} (attach and spawn through the same remd)",
                self.name
            ))),
        }
    }

    /// A spawn's count: at least 1, at most the `spawn_count` limit.
    fn check_count(&self, count: u32) -> Result<()> {
        let max = self.limits.spawn_count;
        if count == 0 || count > max {
            return Err(Error::Invalid(format!(
                "count {count} is outside 1..={max} (the spawn_count limit of host {})",
                self.name
            )));
        }
        Ok(())
    }

    pub async fn start_local(&self, req: StartLocalRequest) -> Result<Vec<Placement>> {
        self.check_accepting()?;
        self.check_count(req.count)?;
        self.policy
            .check(&self.name, &req.program, &req.args, &req.env)?;
        if !crate::auth::identity::is_valid_user(&req.user) {
            return Err(Error::Invalid(format!(
                "bad user name {}",
                shown(&req.user)
            )));
        }
        self.processes
            .start_local(StartSpec {
                job: req.job,
                owner: req.owner,
                user: req.user,
                program: req.program,
                args: req.args,
                env: req.env,
                nice: req.nice,
                count: req.count,
                job_record: req.job_record,
                job_epoch: req.job_epoch,
                slots_min: req.slots_min,
                slots_max: req.slots_max,
            })
            .await
    }

    fn peer_for(&self, id: &ProcId) -> Result<Option<String>> {
        if id.host() == self.name {
            return Ok(None);
        }
        self.membership
            .live_addr(id.host())
            .map(Some)
            .ok_or_else(|| Error::Unreachable {
                host: id.host().to_string(),
                reason: "unknown or lost".into(),
            })
    }

    /// Ends process `id` for `who` (checked where it runs).
    pub async fn kill(&self, who: &Identity, id: ProcId) -> Result<()> {
        match self.peer_for(&id)? {
            None => self.processes.kill(id, who.clone()).await,
            Some(addr) => {
                let req = KillLocalRequest {
                    proc_id: id.to_string(),
                    acting: Some(who.acting()),
                };
                self.peers
                    .call(id.host(), &addr, method::KILL, req, |mut c, r| async move {
                        c.kill_local(r).await
                    })
                    .await
                    .map(|_| ())
            }
        }
    }

    /// Sends the events of running process `id` to `owner` (attached here by `who`, who
    /// must be the process's user) from now on: its host's table changes owner, and this
    /// daemon reports it `LOST` to `owner` if its host is lost.
    pub async fn adopt(&self, who: &Identity, id: ProcId, owner: &str) -> Result<ProcessInfo> {
        self.check_owner(who, owner)?;
        let info = match self.peer_for(&id)? {
            None => {
                self.processes
                    .adopt(id, owner.to_string(), who.clone())
                    .await?
            }
            Some(addr) => {
                let req = AdoptLocalRequest {
                    proc_id: id.to_string(),
                    owner: owner.to_string(),
                    acting: Some(who.acting()),
                };
                self.peers
                    .call(
                        id.host(),
                        &addr,
                        method::ADOPT,
                        req,
                        |mut c, r| async move { c.adopt_local(r).await },
                    )
                    .await?
                    .process
                    .ok_or_else(|| Error::Unreachable {
                        host: id.host().to_string(),
                        reason: "it answered no process".into(),
                    })?
            }
        };
        let placed = Placement {
            proc_id: info.proc_id.clone(),
            host: info.host.clone(),
            pid: info.pid,
            slots: info.slots,
        };
        self.jobs.record(&info.job, owner, &[placed]).await;
        Ok(info)
    }

    /// The kept output of process `id` from the offsets `from` (stdout, stderr) on, for
    /// `who` (checked where it runs).
    pub async fn logs(&self, who: &Identity, id: ProcId, from: (u64, u64)) -> Result<LogsReply> {
        match self.peer_for(&id)? {
            None => self.processes.logs(id, who.clone(), from).await,
            Some(addr) => {
                let req = LogsLocalRequest {
                    proc_id: id.to_string(),
                    acting: Some(who.acting()),
                    stdout_from: from.0,
                    stderr_from: from.1,
                };
                self.peers
                    .call(id.host(), &addr, method::LOGS, req, |mut c, r| async move {
                        c.logs_local(r).await
                    })
                    .await
            }
        }
    }

    /// The processes of every live host (hosts that do not answer are skipped).
    pub async fn ps(&self) -> Result<Vec<ProcessInfo>> {
        let mut out = self.processes.list().await?;
        let replies = self
            .ask_live_peers(method::PS, PsRequest {}, |mut c, r| async move {
                c.ps_local(r).await
            })
            .await;
        out.extend(replies.into_iter().flat_map(|r| r.processes));
        out.sort_by(|a, b| (&a.host, &a.proc_id).cmp(&(&b.host, &b.proc_id)));
        Ok(out)
    }
}

/// The slots each process of `req` holds.
fn slot_ask(req: &SpawnRequest) -> placement::SlotAsk {
    placement::SlotAsk {
        min: req.slots_min,
        max: req.slots_max,
        up_to: req.up_to,
    }
}

async fn start_remote(
    peers: &PeerPool,
    host: &str,
    addr: &str,
    spec: StartSpec,
) -> Result<Vec<Placement>> {
    let req = StartLocalRequest {
        job: spec.job,
        owner: spec.owner,
        user: spec.user,
        program: spec.program,
        args: spec.args,
        env: spec.env,
        nice: spec.nice,
        count: spec.count,
        job_record: spec.job_record,
        job_epoch: spec.job_epoch,
        slots_min: spec.slots_min,
        slots_max: spec.slots_max,
    };
    let reply = peers
        .call(host, addr, method::START, req, |mut c, r| async move {
            c.start_local(r).await
        })
        .await?;
    Ok(reply.processes)
}
