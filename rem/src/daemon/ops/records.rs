//! Checkpoints and job records: each stored here and on one more live host, read back as
//! the newest that this or any live host holds.

use std::collections::BTreeMap;

use prost::Message;

use super::{Daemon, Fence};
use crate::auth::identity::Identity;
use crate::auth::peer_auth::method;
use crate::error::{Error, Result};
use crate::store::job_store;
use crate::wire::ids::{is_valid_name, shown};
use crate::wire::proto::{Checkpoint, FetchReplicaRequest, JobRecord, ListJobsLocalRequest};

impl Daemon {
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
        let here = kept_here(self.keep_checkpoint(&cp).await, &cp.job)?;
        let stored = self
            .replicate(
                &cp,
                method::STORE,
                |mut c, r| async move { c.store_replica(r).await },
                here,
            )
            .await?;
        Ok((cp.version, stored))
    }

    /// Stores `cp` on this host; over the checkpoint quota, once more after ended jobs'
    /// checkpoints made room ([`job_store::JobStore::make_room`]).
    pub async fn keep_checkpoint(&self, cp: &Checkpoint) -> Result<()> {
        match self.checkpoints.put(cp).await {
            Err(Error::Limit(why)) => {
                if self.job_store.make_room(cp.encoded_len() as u64).await? == 0 {
                    return Err(Error::Limit(why));
                }
                self.checkpoints.put(cp).await
            }
            r => r,
        }
    }

    /// Sends `cp` to live peers in the key's rendezvous order until two hosts hold it: one
    /// peer when it is stored `here` already, two when this host's disk could not take it
    /// (a full disk: [`kept_here`]); the hosts that hold it. An error when two hosts could
    /// hold it and fewer do, or when none does.
    async fn replicate<F, Fut>(
        &self,
        cp: &Checkpoint,
        method: &'static str,
        call: F,
        here: bool,
    ) -> Result<Vec<String>>
    where
        F: FnOnce(crate::membership::peers::PeerRpc, tonic::Request<Checkpoint>) -> Fut
            + Clone
            + Send
            + 'static,
        Fut: std::future::Future<
                Output = std::result::Result<
                    tonic::Response<crate::wire::proto::StoreReplicaReply>,
                    tonic::Status,
                >,
            > + Send,
    {
        let mut stored = if here {
            vec![self.name.clone()]
        } else {
            Vec::new()
        };
        let mut others: Vec<_> = self.live_peers().collect();
        // The same peer for the same key every time (see `replicas`).
        others.sort_by(|a, b| {
            let (wa, wb) = (
                crate::store::replicas::weight(&cp.job, &a.name),
                crate::store::replicas::weight(&cp.job, &b.name),
            );
            wb.cmp(&wa).then_with(|| a.name.cmp(&b.name))
        });
        let could_hold = (usize::from(here) + others.len()).min(2);
        for h in others {
            if stored.len() >= 2 {
                break;
            }
            let stored_there = self
                .while_live(
                    &h.name,
                    self.peers
                        .call(&h.name, &h.addr, method, cp.clone(), call.clone()),
                )
                .await;
            match stored_there {
                Ok(_) => stored.push(h.name),
                // A newer epoch is kept there: the writer has been superseded.
                Err(e) if e.code() == tonic::Code::Aborted => return Err(e),
                Err(_) => {}
            }
        }
        if stored.len() < could_hold.max(1) {
            let reason = match (here, stored.len()) {
                (true, _) => "stored only on this host: no live peer took a replica",
                (false, 0) => "this host's state directory cannot take it and no live peer did",
                (false, _) => "this host's state directory cannot take it and one peer only did",
            };
            return Err(Error::Unreachable {
                host: "any peer".into(),
                reason: reason.into(),
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
        if record.priority > job_store::MAX_PRIORITY {
            return Err(Error::Invalid(format!(
                "job priority {} is outside 0..={}",
                record.priority,
                job_store::MAX_PRIORITY
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
        let here = kept_here(self.job_store.put(&cp).await, &cp.job)?;
        // A job submitted or changed here shows in this daemon's next queue at once.
        self.queue_memo.forget();
        self.replicate(
            &cp,
            method::STORE_JOB,
            |mut c, r| async move { c.store_job(r).await },
            here,
        )
        .await
    }

    /// The newest record of each of `who`'s jobs (every user's for an admin) on this and the
    /// live hosts.
    pub async fn list_jobs(&self, who: &Identity) -> Result<Vec<JobRecord>> {
        self.job_records((!who.admin).then(|| who.user.clone()))
            .await
    }

    /// The newest record of each of `user`'s jobs (every user's for `None`) on this and the
    /// live hosts.
    pub(crate) async fn job_records(&self, user: Option<String>) -> Result<Vec<JobRecord>> {
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

/// What storing key `key` on this host came to: `Ok(true)` kept; `Ok(false)` this host's disk
/// could not take it (an I/O error: a full or failing state directory), so two peers keep it
/// instead, with a warning; any other error (a quota, a newer epoch) is the write's.
fn kept_here(stored: Result<()>, key: &str) -> Result<bool> {
    match stored {
        Ok(()) => Ok(true),
        Err(Error::Io(e)) => {
            tracing::warn!(%key, "cannot keep it here ({e}); two peers keep it instead");
            Ok(false)
        }
        Err(e) => Err(e),
    }
}
