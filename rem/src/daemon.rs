//! The daemon's operations, in library terms (typed errors): what the gRPC services call.

use std::collections::{BTreeMap, HashSet};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

use tokio::task::JoinSet;
use tokio_util::sync::CancellationToken;

use crate::checkpoint::CheckpointStore;
use crate::error::{Error, Result};
use crate::identity::Identity;
use crate::ids::{is_valid_name, shown, ProcId};
use crate::job_store::{self, JobStore};
use crate::jobs::Jobs;
use crate::limits::Limits;
use crate::membership::Membership;
use crate::peer_auth::method;
use crate::peers::PeerPool;
use crate::placement::{self, Candidate};
use crate::policy::SpawnPolicy;
use crate::process::{ProcessTable, StartSpec};
use crate::proto::{
    job_event, AdoptLocalRequest, Checkpoint, FetchReplicaRequest, JobEvent, JobRecord,
    KillLocalRequest, ListJobsLocalRequest, LogsLocalRequest, LogsReply, Placement, ProcessInfo,
    PsRequest, SpawnReply, SpawnRequest, StartLocalRequest,
};
use crate::relay::Router;
use crate::wire::MAX_AVOID_HOSTS;

/// The job epoch a checkpoint write carries (0: none), and the job record it belongs to
/// (empty: the checkpoint's own key).
#[derive(Clone, Debug, Default)]
pub struct Fence {
    pub epoch: u64,
    pub job: String,
}

/// Which job record and epoch a spawned controller runs (empty for other processes).
#[derive(Clone, Debug, Default)]
pub struct JobTag {
    pub record: String,
    pub epoch: u64,
}

/// Shared state of one running daemon.
pub struct Daemon {
    pub name: String,
    pub max_message: usize,
    pub policy: SpawnPolicy,
    pub limits: Limits,
    pub membership: Membership,
    pub router: Router,
    pub processes: ProcessTable,
    pub jobs: Jobs,
    pub checkpoints: CheckpointStore,
    pub chunks: crate::chunks::ChunkStore,
    pub job_store: JobStore,
    pub peers: PeerPool,
    pub accepting: Arc<AtomicBool>,
    /// Numbers process ids (spawned and attached-only alike).
    pub seq: Arc<AtomicU64>,
    /// Fires when the daemon shuts down (ends relay streams).
    pub stop: CancellationToken,
}

impl Daemon {
    fn check_accepting(&self) -> Result<()> {
        if self.accepting.load(Ordering::Relaxed) {
            Ok(())
        } else {
            Err(Error::ShuttingDown)
        }
    }

    /// The other hosts alive now.
    pub(crate) fn live_peers(&self) -> impl Iterator<Item = crate::proto::HostInfo> {
        self.membership
            .hosts()
            .into_iter()
            .skip(1)
            .filter(|h| h.alive)
    }

    /// Asks every live peer the same thing at once; the replies of those that answered.
    async fn ask_live_peers<T, R, F, Fut>(&self, method: &'static str, msg: T, call: F) -> Vec<R>
    where
        T: prost::Message + Clone + 'static,
        R: prost::Message + 'static,
        F: FnOnce(crate::peers::PeerRpc, tonic::Request<T>) -> Fut + Clone + Send + 'static,
        Fut: std::future::Future<Output = std::result::Result<tonic::Response<R>, tonic::Status>>
            + Send,
    {
        let mut tasks = JoinSet::new();
        for h in self.live_peers() {
            let (peers, msg, call) = (self.peers.clone(), msg.clone(), call.clone());
            tasks.spawn(async move { peers.call(&h.name, &h.addr, method, msg, call).await });
        }
        let mut replies = Vec::new();
        while let Some(r) = tasks.join_next().await {
            if let Ok(Ok(reply)) = r {
                replies.push(reply);
            }
        }
        replies
    }

    /// A fresh process id on this host.
    pub fn new_proc_id(&self) -> ProcId {
        ProcId::new(&self.name, self.seq.fetch_add(1, Ordering::Relaxed))
    }

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
        let job = if req.job.is_empty() {
            format!("{}-{}", self.name, self.seq.fetch_add(1, Ordering::Relaxed))
        } else if is_valid_name(&req.job) {
            req.job.clone()
        } else {
            return Err(Error::Invalid(format!("bad job id {}", shown(&req.job))));
        };
        if req.avoid_hosts.len() > MAX_AVOID_HOSTS {
            return Err(Error::Invalid(format!(
                "{} hosts to avoid; at most {MAX_AVOID_HOSTS}",
                req.avoid_hosts.len()
            )));
        }
        let avoid: HashSet<&str> = req.avoid_hosts.iter().map(String::as_str).collect();
        let candidates: Vec<Candidate> = self
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
                }
            })
            .collect();
        let chosen = placement::place(&candidates, req.count, req.allow_same_host)?;
        let mut per_host: BTreeMap<String, u32> = BTreeMap::new();
        for h in chosen {
            *per_host.entry(h).or_default() += 1;
        }
        let mut tasks = JoinSet::new();
        for (host, count) in per_host {
            let spec = StartSpec {
                job: job.clone(),
                owner: req.owner.clone(),
                user: who.user.clone(),
                program: req.program.clone(),
                args: req.args.clone(),
                env: req.env.clone().into_iter().collect(),
                nice: req.nice,
                count,
                job_record: tag.record.clone(),
                job_epoch: tag.epoch,
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
        if let Some(e) = failure {
            for p in &placed {
                if let Some(id) = ProcId::parse(&p.proc_id) {
                    let _ = self.kill(who, id).await;
                }
            }
            return Err(e);
        }
        placed.sort_by(|a, b| a.proc_id.cmp(&b.proc_id));
        if !req.owner.is_empty() {
            self.jobs.record(&job, &req.owner, &placed).await;
            for p in &placed {
                let event = JobEvent {
                    job: job.clone(),
                    proc_id: p.proc_id.clone(),
                    host: p.host.clone(),
                    kind: job_event::Kind::Started as i32,
                    owner: req.owner.clone(),
                    ..JobEvent::default()
                };
                let _ = self.router.route_event(event).await;
            }
        }
        Ok(SpawnReply {
            job,
            processes: placed,
        })
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
        if !crate::identity::is_valid_user(&req.user) {
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

    /// Stores `who`'s checkpoint of `job` here and on one more live host; returns (version,
    /// hosts). Checkpoints are kept per user: nobody writes over another user's.
    pub async fn put_checkpoint(
        &self,
        who: &Identity,
        job: String,
        data: Vec<u8>,
        fence: Fence,
    ) -> Result<(u64, Vec<String>)> {
        let limit = self.max_message.min(self.limits.checkpoint_bytes);
        if data.len() > limit {
            return Err(Error::TooLarge {
                size: data.len(),
                limit,
            });
        }
        if !is_valid_name(&job) {
            return Err(Error::Invalid(format!("bad job id {}", shown(&job))));
        }
        if fence.epoch > 0 {
            let record = if fence.job.is_empty() {
                &job
            } else {
                &fence.job
            };
            if let Some(kept) = self.job_store.get(&who.user, record).await? {
                if kept.epoch > fence.epoch {
                    return Err(Error::Fenced(format!(
                        "job {record} belongs to a newer controller (epoch {} > {})",
                        kept.epoch, fence.epoch
                    )));
                }
            }
        }
        let mut cp = Checkpoint {
            job,
            data,
            version: self.checkpoints.next_version(),
            written_by: self.name.clone(),
            mac: Vec::new(),
            user: who.user.clone(),
            epoch: fence.epoch,
        };
        self.checkpoints.seal(&mut cp);
        self.checkpoints.put(&cp).await?;
        let stored = self
            .replicate(&cp, method::STORE, |mut c, r| async move {
                c.store_replica(r).await
            })
            .await?;
        Ok((cp.version, stored))
    }

    /// Sends `cp` (stored here already) to one more live host, the first in the key's
    /// rendezvous order that takes it; the hosts that hold it. An error when there are peers and none took it.
    async fn replicate<F, Fut>(
        &self,
        cp: &Checkpoint,
        method: &'static str,
        call: F,
    ) -> Result<Vec<String>>
    where
        F: FnOnce(crate::peers::PeerRpc, tonic::Request<Checkpoint>) -> Fut
            + Clone
            + Send
            + 'static,
        Fut: std::future::Future<
                Output = std::result::Result<
                    tonic::Response<crate::proto::StoreReplicaReply>,
                    tonic::Status,
                >,
            > + Send,
    {
        let mut stored = vec![self.name.clone()];
        let mut others: Vec<_> = self.live_peers().collect();
        // The same peer for the same key every time (see `replicas`).
        others.sort_by(|a, b| {
            let (wa, wb) = (
                crate::replicas::weight(&cp.job, &a.name),
                crate::replicas::weight(&cp.job, &b.name),
            );
            wb.cmp(&wa).then_with(|| a.name.cmp(&b.name))
        });
        let had_peers = !others.is_empty();
        for h in others {
            let stored_there = self
                .peers
                .call(&h.name, &h.addr, method, cp.clone(), call.clone())
                .await;
            match stored_there {
                Ok(_) => {
                    stored.push(h.name);
                    break;
                }
                // A newer epoch is kept there: the writer has been superseded.
                Err(e) if e.code() == tonic::Code::Aborted => return Err(e),
                Err(_) => {}
            }
        }
        if had_peers && stored.len() < 2 {
            return Err(Error::Unreachable {
                host: "any peer".into(),
                reason: "stored only on this host: no live peer took a replica".into(),
            });
        }
        Ok(stored)
    }

    /// Stores `who`'s job record here and on one more live host (REM sets its user and
    /// time); refused if a record of a newer epoch is kept here.
    pub async fn put_job(&self, who: &Identity, mut record: JobRecord) -> Result<Vec<String>> {
        if !is_valid_name(&record.id) {
            return Err(Error::Invalid(format!("bad job id {}", shown(&record.id))));
        }
        if !job_store::STATES.contains(&record.state.as_str()) {
            return Err(Error::Invalid(format!(
                "bad job state {} (one of {})",
                shown(&record.state),
                job_store::STATES.join(", ")
            )));
        }
        if record.title.len() > job_store::MAX_TITLE {
            return Err(Error::Invalid(format!(
                "job title of {} bytes (at most {})",
                record.title.len(),
                job_store::MAX_TITLE
            )));
        }
        let limit = self.max_message.min(self.limits.checkpoint_bytes);
        let size = prost::Message::encoded_len(&record);
        if size > limit {
            return Err(Error::TooLarge { size, limit });
        }
        record.user = who.user.clone();
        record.updated_unix_ms = job_store::unix_ms(std::time::SystemTime::now());
        let cp = self.job_store.seal(&record, &self.name);
        self.job_store.put(&cp).await?;
        self.replicate(&cp, method::STORE_JOB, |mut c, r| async move {
            c.store_job(r).await
        })
        .await
    }

    /// The newest record of each of `who`'s jobs (every user's for an admin) on this and the
    /// live hosts.
    pub async fn list_jobs(&self, who: &Identity) -> Result<Vec<JobRecord>> {
        let user = (!who.admin).then(|| who.user.clone());
        let mut all = self.job_store.list(user.as_deref()).await?;
        let req = ListJobsLocalRequest {
            user: user.clone().unwrap_or_default(),
            all: user.is_none(),
        };
        let replies = self
            .ask_live_peers(method::LIST_JOBS, req, |mut c, r| async move {
                c.list_jobs_local(r).await
            })
            .await;
        all.extend(replies.into_iter().flat_map(|r| r.records));
        type Rank = (u64, bool, u64);
        let mut newest: BTreeMap<(String, String), (Rank, JobRecord)> = BTreeMap::new();
        for cp in all {
            let wanted = user.as_ref().is_none_or(|u| *u == cp.user);
            if !wanted || !self.job_store.believe(&cp) {
                continue;
            }
            let Ok(record) = job_store::decode(&cp) else {
                continue;
            };
            // The highest epoch wins, then an ended record (ended is final at its epoch),
            // then the newest write: a superseded controller's late write on a host that had
            // not heard of its successor does not show.
            let rank = (record.epoch, job_store::is_ended(&record.state), cp.version);
            let key = (cp.user.clone(), cp.job.clone());
            if newest.get(&key).is_none_or(|(best, _)| rank > *best) {
                newest.insert(key, (rank, record));
            }
        }
        Ok(newest.into_values().map(|(_, r)| r).collect())
    }

    /// The newest of `who`'s checkpoints of `job` on this or any live host.
    pub async fn get_checkpoint(&self, who: &Identity, job: String) -> Result<Option<Checkpoint>> {
        let user = who.user.clone();
        let mut best = self.checkpoints.get(&user, &job).await?;
        let req = FetchReplicaRequest {
            job: job.clone(),
            user: user.clone(),
        };
        let replies = self
            .ask_live_peers(method::FETCH, req, |mut c, r| async move {
                c.fetch_replica(r).await
            })
            .await;
        // The highest epoch wins, then the newest write: a superseded controller's late write
        // on a host that had not heard of its successor is not read back.
        for cp in replies.into_iter().filter_map(|r| r.checkpoint) {
            let newer = best
                .as_ref()
                .is_none_or(|b| (cp.epoch, cp.version) > (b.epoch, b.version));
            if newer && self.checkpoints.believe(&cp, &user, &job) {
                best = Some(cp);
            }
        }
        Ok(best)
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
    };
    let reply = peers
        .call(host, addr, method::START, req, |mut c, r| async move {
            c.start_local(r).await
        })
        .await?;
    Ok(reply.processes)
}
