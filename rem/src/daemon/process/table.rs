//! The processes REM runs on this host: starting them (allow-list, environment, nice value,
//! captured output), ending them, reporting their exit to the job's owner.
//!
//! Each child gets its own process group (so `kill` reaches its children too), the requested
//! nice value through `setpriority` in the child between fork and exec (remd itself keeps
//! its normal priority), and `PR_SET_PDEATHSIG` so it dies if remd dies.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use tokio::sync::{mpsc, oneshot};

use crate::auth::identity::Identity;
use crate::auth::token::Token;
use crate::daemon::process::child;
use crate::daemon::process::logbuf::{self, Output};
use crate::daemon::relay::router::Router;
use crate::error::{Error, Result};
use crate::membership::slots::Slots;
use crate::wire::ids::ProcId;
use crate::wire::proto::{job_event, JobEvent, LogsReply, Placement, ProcessInfo};

pub use crate::daemon::process::child::{ProcessConfig, StartSpec};

/// Records of exited processes kept at most (for `ps` and `logs`).
pub const KEEP_EXITED: usize = 1000;

struct Entry {
    info: ProcessInfo,
    output: Output,
}

enum Cmd {
    Start(StartSpec, oneshot::Sender<Result<Vec<Placement>>>),
    Kill(ProcId, Identity, oneshot::Sender<Result<()>>),
    Adopt(
        ProcId,
        String,
        Identity,
        oneshot::Sender<Result<ProcessInfo>>,
    ),
    Logs(
        ProcId,
        Identity,
        (u64, u64),
        oneshot::Sender<Result<LogsReply>>,
    ),
    List(oneshot::Sender<Vec<ProcessInfo>>),
    Exited {
        id: ProcId,
        code: Option<i32>,
        signal: Option<i32>,
    },
    /// An exit event has been handed to the relay.
    Reported,
    Shutdown(oneshot::Sender<()>),
}

/// Cloneable handle to the process table actor.
#[derive(Clone)]
pub struct ProcessTable {
    tx: mpsc::Sender<Cmd>,
}

impl ProcessTable {
    /// `seq` numbers process ids (shared with relay-only attachments, so ids never clash).
    pub fn start(
        cfg: ProcessConfig,
        router: Router,
        counter: Arc<AtomicU32>,
        slots: Arc<Slots>,
        seq: Arc<AtomicU64>,
    ) -> Self {
        let (tx, rx) = mpsc::channel(256);
        let actor = Actor {
            cfg,
            router,
            counter,
            slots,
            entries: BTreeMap::new(),
            seq,
            self_tx: tx.downgrade(),
            accepting: true,
            drained: Vec::new(),
            reporting: 0,
        };
        tokio::spawn(actor.run(rx));
        ProcessTable { tx }
    }

    async fn ask<T>(&self, make: impl FnOnce(oneshot::Sender<T>) -> Cmd) -> Result<T> {
        let (tx, rx) = oneshot::channel();
        self.tx
            .send(make(tx))
            .await
            .map_err(|_| Error::ShuttingDown)?;
        rx.await.map_err(|_| Error::ShuttingDown)
    }

    /// Starts `spec.count` processes here.
    pub async fn start_local(&self, spec: StartSpec) -> Result<Vec<Placement>> {
        self.ask(|tx| Cmd::Start(spec, tx)).await?
    }

    /// SIGTERM to the process group, SIGKILL after the grace period; only for the process's
    /// user or an admin.
    pub async fn kill(&self, id: ProcId, who: Identity) -> Result<()> {
        self.ask(|tx| Cmd::Kill(id, who, tx)).await?
    }

    /// Sends the events of running process `id` to `owner` from now on; only for its user
    /// or an admin. Answers the process as listed.
    pub async fn adopt(&self, id: ProcId, owner: String, who: Identity) -> Result<ProcessInfo> {
        self.ask(|tx| Cmd::Adopt(id, owner, who, tx)).await?
    }

    /// The kept output of a process from the offsets `from` (stdout, stderr) on; only for
    /// its user or an admin.
    pub async fn logs(&self, id: ProcId, who: Identity, from: (u64, u64)) -> Result<LogsReply> {
        self.ask(|tx| Cmd::Logs(id, who, from, tx)).await?
    }

    pub async fn list(&self) -> Result<Vec<ProcessInfo>> {
        self.ask(Cmd::List).await
    }

    /// Refuses new starts, ends every child (SIGTERM, then SIGKILL after the grace period)
    /// and returns when all have exited (their Exited events sent).
    pub async fn shutdown(&self) -> Result<()> {
        self.ask(Cmd::Shutdown).await
    }
}

struct Actor {
    cfg: ProcessConfig,
    router: Router,
    counter: Arc<AtomicU32>,
    slots: Arc<Slots>,
    entries: BTreeMap<ProcId, Entry>,
    seq: Arc<AtomicU64>,
    self_tx: mpsc::WeakSender<Cmd>,
    accepting: bool,
    drained: Vec<oneshot::Sender<()>>,
    /// Exit events being routed.
    reporting: usize,
}

impl Actor {
    async fn run(mut self, mut rx: mpsc::Receiver<Cmd>) {
        while let Some(cmd) = rx.recv().await {
            match cmd {
                Cmd::Start(spec, reply) => {
                    let _ = reply.send(self.start(spec));
                }
                Cmd::Kill(id, who, reply) => {
                    let r = self
                        .owned(&id, &who)
                        .map(|_| ())
                        .and_then(|()| self.kill(&id));
                    let _ = reply.send(r);
                }
                Cmd::Adopt(id, owner, who, reply) => {
                    let _ = reply.send(self.adopt(&id, owner, &who));
                }
                Cmd::Logs(id, who, from, reply) => {
                    let r = self.owned(&id, &who);
                    let _ = reply.send(r.map(|e| e.output.since(from)));
                }
                Cmd::List(reply) => {
                    let list = self.entries.values().map(|e| {
                        let mut info = e.info.clone();
                        info.attached = self.router.is_attached(&info.proc_id);
                        info
                    });
                    let _ = reply.send(list.collect());
                }
                Cmd::Exited { id, code, signal } => self.exited(id, code, signal),
                Cmd::Reported => {
                    self.reporting -= 1;
                    self.notify_drained();
                }
                Cmd::Shutdown(reply) => self.shutdown(reply),
            }
        }
    }

    fn running(&self) -> impl Iterator<Item = &Entry> {
        self.entries.values().filter(|e| e.info.state == "running")
    }

    fn start(&mut self, spec: StartSpec) -> Result<Vec<Placement>> {
        if !self.accepting {
            return Err(Error::ShuttingDown);
        }
        self.cfg
            .policy
            .check(&self.cfg.host, &spec.program, &spec.args, &spec.env)?;
        let running = self.running().count();
        let max = self.cfg.limits.host_processes;
        if running.saturating_add(spec.count as usize) > max {
            return Err(Error::Limit(format!(
                "host {} runs {running} processes; {} more would pass its host_processes \
                 limit of {max}",
                self.cfg.host, spec.count
            )));
        }
        let mut placed = Vec::new();
        for _ in 0..spec.count.max(1) {
            let slots = if spec.slots_min == 0 {
                0
            } else {
                match self.slots.take(spec.slots_min, spec.slots_max) {
                    Some(n) => n,
                    // As many as the free slots allow.
                    None if !placed.is_empty() => break,
                    None => {
                        return Err(Error::Limit(format!(
                            "host {} lends {} slots and {} are held: none free for {} more",
                            self.cfg.host,
                            self.slots.lent(),
                            self.slots.used(),
                            spec.slots_min
                        )))
                    }
                }
            };
            match self.start_one(&spec, slots) {
                Ok(p) => placed.push(p),
                Err(e) => {
                    self.slots.give_back(slots);
                    for p in &placed {
                        if let Some(id) = ProcId::parse(&p.proc_id) {
                            let _ = self.kill(&id);
                        }
                    }
                    return Err(e);
                }
            }
        }
        Ok(placed)
    }

    /// Starts one process of `spec`, holding `slots` (taken already).
    fn start_one(&mut self, spec: &StartSpec, slots: u32) -> Result<Placement> {
        let id = ProcId::new(&self.cfg.host, self.seq.fetch_add(1, Ordering::Relaxed));
        let token = Token::random()?;
        let mut cmd = child::command(&self.cfg, spec, &id, (&token, slots));
        self.router.register(&id, Some(token), &spec.user);
        let mut child = match cmd.spawn() {
            Ok(c) => c,
            Err(e) => {
                self.router.unregister(&id);
                return Err(Error::Spawn {
                    program: spec.program.clone(),
                    reason: e.to_string(),
                });
            }
        };
        let pid = child.id().unwrap_or(0);
        let output = Output::new(self.cfg.limits.log_bytes);
        let mut collectors = Vec::new();
        if let Some(out) = child.stdout.take() {
            collectors.push(tokio::spawn(logbuf::collect(out, output.stdout.clone())));
        }
        if let Some(err) = child.stderr.take() {
            collectors.push(tokio::spawn(logbuf::collect(err, output.stderr.clone())));
        }
        let tx = self.self_tx.clone();
        let wait_id = id.clone();
        tokio::spawn(async move {
            use std::os::unix::process::ExitStatusExt;
            let (code, signal) = match child.wait().await {
                Ok(st) => (st.code(), st.signal()),
                Err(_) => (None, None),
            };
            // Let the output be read to its end before the exit is reported (bounded: a
            // grandchild may hold the pipes open).
            let _ = tokio::time::timeout(Duration::from_millis(500), async {
                for c in collectors {
                    let _ = c.await;
                }
            })
            .await;
            if let Some(tx) = tx.upgrade() {
                let _ = tx
                    .send(Cmd::Exited {
                        id: wait_id,
                        code,
                        signal,
                    })
                    .await;
            }
        });
        if slots > 0 {
            self.slots.holds(pid);
        }
        // A job's controller coordinates rather than computes: its CPU use shows in the
        // measured load, it is not counted ahead like a worker.
        if spec.job_record.is_empty() {
            self.counter.fetch_add(1, Ordering::Relaxed);
        }
        let info = ProcessInfo {
            proc_id: id.to_string(),
            host: self.cfg.host.clone(),
            job: spec.job.clone(),
            owner: spec.owner.clone(),
            user: spec.user.clone(),
            program: spec.program.clone(),
            args: spec.args.clone(),
            pid,
            nice: spec.nice,
            state: "running".into(),
            exit_code: None,
            signal: None,
            started_unix_ms: SystemTime::now()
                .duration_since(UNIX_EPOCH)
                .map_or(0, |d| d.as_millis() as u64),
            attached: false,
            job_record: spec.job_record.clone(),
            job_epoch: spec.job_epoch,
            slots,
        };
        tracing::info!(proc = %id, pid, program = %spec.program, "started");
        self.entries.insert(id.clone(), Entry { info, output });
        Ok(Placement {
            proc_id: id.to_string(),
            host: self.cfg.host.clone(),
            pid,
            slots,
        })
    }

    fn adopt(&mut self, id: &ProcId, owner: String, who: &Identity) -> Result<ProcessInfo> {
        let owner = ProcId::parse(&owner).ok_or_else(|| {
            Error::Invalid(format!("bad owner id {}", crate::wire::ids::shown(&owner)))
        })?;
        self.owned(id, who)?;
        let Some(e) = self.entries.get_mut(id) else {
            return Err(Error::NotFound(format!("process {id}")));
        };
        if e.info.state != "running" {
            return Err(Error::NotFound(format!(
                "running process {id} (it has exited)"
            )));
        }
        tracing::info!(proc = %id, from = %e.info.owner, to = %owner, "adopted");
        e.info.owner = owner.to_string();
        let mut info = e.info.clone();
        info.attached = self.router.is_attached(&info.proc_id);
        Ok(info)
    }

    /// Process `id`, if `who` may act on it.
    fn owned(&self, id: &ProcId, who: &Identity) -> Result<&Entry> {
        let e = self
            .entries
            .get(id)
            .ok_or_else(|| Error::NotFound(format!("process {id}")))?;
        who.may_act_on(&e.info.user, &format!("process {id}"))?;
        Ok(e)
    }

    fn kill(&mut self, id: &ProcId) -> Result<()> {
        let e = self
            .entries
            .get(id)
            .ok_or_else(|| Error::NotFound(format!("process {id}")))?;
        if e.info.state != "running" {
            return Ok(());
        }
        child::signal_group(e.info.pid, libc::SIGTERM);
        let tx = self.self_tx.clone();
        let (pid, grace, id) = (e.info.pid, self.cfg.kill_grace, id.clone());
        tokio::spawn(async move {
            tokio::time::sleep(grace).await;
            // Only if the table still says running (the pid was not reused).
            if let Some(tx) = tx.upgrade() {
                let (rtx, rrx) = oneshot::channel();
                if tx.send(Cmd::List(rtx)).await.is_ok() {
                    if let Ok(list) = rrx.await {
                        if list
                            .iter()
                            .any(|p| p.proc_id == id.as_str() && p.state == "running")
                        {
                            child::signal_group(pid, libc::SIGKILL);
                        }
                    }
                }
            }
        });
        Ok(())
    }

    fn exited(&mut self, id: ProcId, code: Option<i32>, signal: Option<i32>) {
        let Some(e) = self.entries.get_mut(&id) else {
            return;
        };
        e.info.state = "exited".into();
        e.info.exit_code = code;
        e.info.signal = signal;
        if e.info.job_record.is_empty() {
            self.counter.fetch_sub(1, Ordering::Relaxed);
        }
        self.slots.give_back(e.info.slots);
        self.slots.left(e.info.pid);
        self.router.unregister(&id);
        tracing::info!(proc = %id, ?code, ?signal, "exited");
        if !e.info.owner.is_empty() {
            let event = JobEvent {
                job: e.info.job.clone(),
                proc_id: id.to_string(),
                host: self.cfg.host.clone(),
                kind: job_event::Kind::Exited as i32,
                exit_code: code,
                signal,
                message: String::new(),
                owner: e.info.owner.clone(),
            };
            let router = self.router.clone();
            let tx = self.self_tx.clone();
            self.reporting += 1;
            tokio::spawn(async move {
                if let Err(reason) = router.route_event(event).await {
                    tracing::debug!(%reason, "exit event not delivered");
                }
                if let Some(tx) = tx.upgrade() {
                    let _ = tx.send(Cmd::Reported).await;
                }
            });
        }
        self.forget_old_exits();
        self.notify_drained();
    }

    /// Keeps the records of exited processes bounded: at most [`KEEP_EXITED`] of them, and
    /// their output within the `log_quota` limit (the oldest go first).
    fn forget_old_exits(&mut self) {
        let mut exited: Vec<(u64, ProcId)> = self
            .entries
            .iter()
            .filter(|(_, e)| e.info.state != "running")
            .map(|(k, e)| (e.info.started_unix_ms, k.clone()))
            .collect();
        exited.sort();
        let mut kept: usize = self.entries.values().map(|e| e.output.len()).sum();
        let mut left = exited.len();
        for (_, id) in exited {
            if left <= KEEP_EXITED && kept <= self.cfg.limits.log_quota {
                break;
            }
            if let Some(e) = self.entries.remove(&id) {
                kept = kept.saturating_sub(e.output.len());
            }
            left -= 1;
        }
    }

    fn notify_drained(&mut self) {
        if self.running().next().is_none() && self.reporting == 0 {
            for d in self.drained.drain(..) {
                let _ = d.send(());
            }
        }
    }

    fn shutdown(&mut self, reply: oneshot::Sender<()>) {
        self.accepting = false;
        let ids: Vec<ProcId> = self
            .entries
            .iter()
            .filter(|(_, e)| e.info.state == "running")
            .map(|(k, _)| k.clone())
            .collect();
        for id in ids {
            let _ = self.kill(&id);
        }
        self.drained.push(reply);
        self.notify_drained();
    }
}
