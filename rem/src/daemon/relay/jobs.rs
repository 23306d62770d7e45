//! The jobs placed by this daemon: who owns them and where their processes run, so that when
//! a host is lost its processes can be reported `LOST` to their owner.
//!
//! `STARTED` is sent by the placing daemon after a start succeeds, `EXITED` by the daemon that
//! ran the process, `LOST` by the placing daemon when the process's host is marked lost.

use std::collections::HashMap;

use tokio::sync::{broadcast, mpsc};

use crate::daemon::relay::router::Router;
use crate::membership::driver::MemberEvent;
use crate::wire::proto::{job_event, JobEvent, Placement};

struct Proc {
    host: String,
    /// Who receives its events (a successor may adopt it).
    owner: String,
    done: bool,
}

struct Job {
    procs: HashMap<String, Proc>,
}

/// Cloneable handle to the job table.
#[derive(Clone)]
pub struct Jobs {
    tx: mpsc::Sender<(String, String, Vec<Placement>)>,
}

impl Jobs {
    /// Starts the actor. `observed` carries every job event delivered on this host.
    pub fn start(
        router: Router,
        observed: mpsc::UnboundedReceiver<JobEvent>,
        members: broadcast::Receiver<MemberEvent>,
    ) -> Self {
        let (tx, rx) = mpsc::channel(64);
        tokio::spawn(run(router, rx, observed, members));
        Jobs { tx }
    }

    /// Records processes started for `job` (owned by `owner`), or adopted by `owner`.
    pub async fn record(&self, job: &str, owner: &str, placed: &[Placement]) {
        let _ = self
            .tx
            .send((job.to_string(), owner.to_string(), placed.to_vec()))
            .await;
    }
}

async fn run(
    router: Router,
    mut records: mpsc::Receiver<(String, String, Vec<Placement>)>,
    mut observed: mpsc::UnboundedReceiver<JobEvent>,
    mut members: broadcast::Receiver<MemberEvent>,
) {
    let mut jobs: HashMap<String, Job> = HashMap::new();
    loop {
        tokio::select! {
            rec = records.recv() => {
                let Some((job, owner, placed)) = rec else { break };
                let entry = jobs.entry(job).or_insert_with(|| Job { procs: HashMap::new() });
                for p in placed {
                    entry.procs.insert(p.proc_id, Proc { host: p.host, owner: owner.clone(), done: false });
                }
            }
            ev = observed.recv() => {
                let Some(ev) = ev else { break };
                let done = ev.kind == job_event::Kind::Exited as i32 || ev.kind == job_event::Kind::Lost as i32;
                if let (true, Some(job)) = (done, jobs.get_mut(&ev.job)) {
                    if let Some(p) = job.procs.get_mut(&ev.proc_id) {
                        p.done = true;
                    }
                    if job.procs.values().all(|p| p.done) {
                        jobs.remove(&ev.job);
                    }
                }
            }
            ev = members.recv() => match ev {
                Ok(MemberEvent::Lost(host)) => {
                    for (job_id, job) in jobs.iter_mut() {
                        for (proc_id, p) in job.procs.iter_mut().filter(|(_, p)| p.host == host && !p.done) {
                            p.done = true;
                            let event = JobEvent {
                                job: job_id.clone(),
                                proc_id: proc_id.clone(),
                                host: host.clone(),
                                kind: job_event::Kind::Lost as i32,
                                exit_code: None,
                                signal: None,
                                message: format!("host {host} stopped answering"),
                                owner: p.owner.clone(),
                            };
                            let router = router.clone();
                            tokio::spawn(async move {
                                let _ = router.route_event(event).await;
                            });
                        }
                    }
                }
                Ok(MemberEvent::Back(_)) => {}
                Err(broadcast::error::RecvError::Lagged(_)) => {}
                Err(broadcast::error::RecvError::Closed) => break,
            },
        }
    }
}
