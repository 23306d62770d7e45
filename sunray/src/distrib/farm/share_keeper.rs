//! A farm job's share of the farm's render slots (DESIGN section 12). Every [`SHARE_POLL`]
//! the controller reads REM's queue, where every daemon computes the same shares from the
//! replicated job records, and moves its job toward its own share: workers start on hosts
//! with free slots while the job holds fewer than its share (up to its `--hosts`), and the
//! newest retire while it holds more (the last one stays unless the share is none: only a
//! higher priority takes a job's last worker). A retired worker's lines go back to the queue,
//! so the job carries on smaller with the same bytes. The lease writes what the job holds
//! into its record ([`CrewView::slots`]); a job holding none waits as `queued`.

use super::job_workers::start_workers;
use crate::distrib::controller::crew::{Crew, CrewView};
use crate::distrib::controller::{Input, WorkerProc};
use crate::distrib::messages::proto;
use rem::RemClient;
use std::path::PathBuf;
use std::time::Duration;
use tokio::sync::{mpsc, oneshot};

/// How often the controller reads the queue.
pub const SHARE_POLL: Duration = Duration::from_millis(200);

/// What the keeper needs of its job.
pub(super) struct ShareKeeper {
    pub(super) client: RemClient,
    pub(super) worker_program: PathBuf,
    pub(super) spec: proto::JobSpec,
    pub(super) job: String,
    pub(super) epoch: u64,
    /// Whose job it is (the queue lists every user's).
    pub(super) user: String,
    pub(super) crew: Crew,
    pub(super) live: Vec<rem::HostInfo>,
}

/// The most slots a job of `hosts` workers of `threads` threads each (0: a host's slots)
/// could use on `live` hosts.
pub fn slots_wanted(hosts: u32, threads: u32, live: &[rem::HostInfo]) -> u32 {
    let per_worker = match threads {
        0 => live
            .iter()
            .filter_map(|h| h.load.map(|l| l.slots))
            .max()
            .unwrap_or(1),
        t => t,
    };
    hosts.max(1).saturating_mul(per_worker.max(1))
}

impl ShareKeeper {
    /// The job's share now (`None` when the queue cannot be read, or does not list it).
    pub(super) async fn share(&self) -> Option<u32> {
        match self.client.queue().await {
            Ok(q) => q
                .jobs
                .iter()
                .find(|j| j.id == self.job && j.user == self.user)
                .map(|j| j.share),
            Err(e) => {
                tracing::debug!("the queue: {e}");
                None
            }
        }
    }

    /// Starts workers for up to `need` more slots, besides those of `crew` (not on their
    /// hosts unless the job allows it), owned by `me`; none when no host has a free slot.
    pub(super) async fn grow(
        &self,
        me: &rem::ProcId,
        need: u32,
        crew: &CrewView,
    ) -> Vec<WorkerProc> {
        let room = self
            .spec
            .hosts
            .max(1)
            .saturating_sub(crew.live.len() as u32);
        let count = room.min(need);
        if count == 0 {
            return Vec::new();
        }
        let per_worker = match self.spec.threads {
            0 => need,
            t => t.min(need),
        };
        let avoid = crew.avoid(&self.spec.avoid_hosts, self.spec.same_host);
        let what = (
            &self.spec,
            (self.job.as_str(), self.epoch),
            (count, per_worker),
            me,
        );
        match start_workers(&self.client, &self.worker_program, what, &self.live, avoid).await {
            Ok(w) => w,
            // Every slot is held (others will give theirs back), or no host is left: later.
            Err(e) => {
                tracing::debug!("no worker started: {e}");
                Vec::new()
            }
        }
    }

    /// Moves the job toward its share, for ever: the controller's site drops it when the job
    /// ends or stands down.
    pub(super) async fn run(&self, me: &rem::ProcId, feed: mpsc::Sender<Input>) {
        loop {
            tokio::time::sleep(SHARE_POLL).await;
            let Some(share) = self.share().await else {
                continue;
            };
            let crew = self.crew.view();
            let held = crew.slots();
            let (done_tx, done) = oneshot::channel();
            let input = if held > share {
                Input::Retire {
                    slots: held - share,
                    keep_one: share > 0,
                    done: Some(done_tx),
                }
            } else if held < share {
                let workers = self.grow(me, share - held, &crew).await;
                if workers.is_empty() {
                    continue;
                }
                Input::Workers(workers, Some(done_tx))
            } else {
                continue;
            };
            if feed.send(input).await.is_err() {
                return;
            }
            // Once the actor has them, the crew says so: the next look counts them.
            let _ = done.await;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn host(slots: u32) -> rem::HostInfo {
        rem::HostInfo {
            load: Some(rem::wire::proto::Load {
                slots,
                ..Default::default()
            }),
            ..Default::default()
        }
    }

    #[test]
    fn a_job_wants_its_hosts_times_its_threads_or_a_hosts_slots() {
        assert_eq!(slots_wanted(3, 2, &[host(8)]), 6);
        assert_eq!(slots_wanted(3, 0, &[host(2), host(4)]), 12);
        assert_eq!(slots_wanted(0, 0, &[]), 1);
    }
}
