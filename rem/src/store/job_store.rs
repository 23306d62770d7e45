//! Job records kept on this host: what REM knows of a job so that it outlives the process
//! and the host that started it. A record travels and is stored in a sealed envelope, the
//! same as a checkpoint's (`Checkpoint`, its data the encoded [`JobRecord`]), in a store of
//! its own (`STATE/jobs/USER/ID.ckpt`), so it has the same per-user namespaces, seals,
//! versions, atomic files and quota.
//!
//! Two rules are the job store's own:
//! - **Epochs fence.** A record with an older epoch than the kept one is refused: a controller
//!   cut off by a partition cannot overwrite what its successor wrote. A job that ended
//!   (finished, failed, cancelled) keeps its state unless a newer epoch takes it up again
//!   (a resumed job): a late write of the controller cannot undo a cancel. An epoch has one
//!   controller: the first kept here wins.
//! - **Retention.** Records of ended jobs (finished, failed, cancelled) are kept at most
//!   `kept_jobs` per user and `kept_secs` after their last change; one that goes takes its
//!   job's checkpoints on this host with it. Any checkpoint not written for `kept_secs` goes
//!   too, so the state directory stays bounded without anybody's help.
//! - **Room under the quota.** When a checkpoint does not fit under the host's checkpoint
//!   quota, the checkpoints of ended jobs go first, every user's, the least recently
//!   changed first ([`JobStore::make_room`]): a running job's checkpoint is what keeps its
//!   work through a fault, an ended job's only its image for `sunray fetch`. Their records
//!   stay. A running job's checkpoint is never removed to make room.

use std::time::{Duration, SystemTime};

use prost::Message;

use crate::error::{Error, Result};
use crate::store::checkpoint::CheckpointStore;
use crate::wire::proto::{Checkpoint, JobRecord};

/// The states a record may be in.
pub const STATES: [&str; 7] = [
    "queued",
    "running",
    "recovering",
    "finished",
    "failed",
    "cancelled",
    "interrupted",
];

/// Highest job priority (`JobRecord.priority`).
pub const MAX_PRIORITY: u32 = 100;

/// Longest job title (`JobRecord.title`), in bytes.
pub const MAX_TITLE: usize = 200;

/// True for the states of a job that will not run again (an interrupted job, stopped with the
/// command that ran its controller, runs again only when a user resumes it).
pub fn is_ended(state: &str) -> bool {
    matches!(state, "finished" | "failed" | "cancelled" | "interrupted")
}

/// How an ended job is said: "has finished", "has failed", "was cancelled".
fn ended_verb(state: &str) -> String {
    match state {
        "cancelled" => "been cancelled".into(),
        "interrupted" => "been interrupted".into(),
        s => s.to_string(),
    }
}

/// The job records of this host, and its checkpoints (which retention removes with them).
#[derive(Clone, Debug)]
pub struct JobStore {
    records: CheckpointStore,
    checkpoints: CheckpointStore,
}

impl JobStore {
    /// Records in `records`; `checkpoints` is the host's checkpoint store.
    pub fn new(records: CheckpointStore, checkpoints: CheckpointStore) -> Self {
        JobStore {
            records,
            checkpoints,
        }
    }

    /// A sealed envelope of `record` written by this daemon (`writer`).
    pub fn seal(&self, record: &JobRecord, writer: &str) -> Checkpoint {
        let mut cp = Checkpoint {
            job: record.id.clone(),
            data: record.encode_to_vec(),
            version: self.records.next_version(),
            written_by: writer.to_string(),
            mac: Vec::new(),
            user: record.user.clone(),
            epoch: record.epoch,
        };
        self.records.seal(&mut cp);
        cp
    }

    /// Keeps `cp` (a sealed record) unless the kept one has a newer epoch.
    pub async fn put(&self, cp: &Checkpoint) -> Result<()> {
        let record = decode(cp)?;
        if record.user != cp.user || record.id != cp.job {
            return Err(Error::Invalid(
                "a job record's user and id must be its envelope's".into(),
            ));
        }
        self.records
            .put_checked(cp, |kept| match kept.and_then(|k| decode(k).ok()) {
                Some(k) if k.epoch > record.epoch => Err(Error::Fenced(format!(
                    "job {} belongs to a newer controller (epoch {} > {})",
                    record.id, k.epoch, record.epoch
                ))),
                Some(k)
                    if is_ended(&k.state) && k.epoch == record.epoch && k.state != record.state =>
                {
                    Err(Error::Fenced(format!(
                        "job {} has {}",
                        record.id,
                        ended_verb(&k.state)
                    )))
                }
                // Two controllers of one epoch (two supervisors in a partition): the first
                // kept here wins.
                Some(k)
                    if k.epoch == record.epoch
                        && !k.controller.is_empty()
                        && !record.controller.is_empty()
                        && k.controller != record.controller =>
                {
                    Err(Error::Fenced(format!(
                        "job {} has another controller at epoch {} ({})",
                        record.id, k.epoch, k.controller
                    )))
                }
                _ => Ok(()),
            })
            .await
    }

    /// The record of `user`'s job `id` kept here, if any.
    pub async fn get(&self, user: &str, id: &str) -> Result<Option<JobRecord>> {
        match self.records.get(user, id).await? {
            Some(cp) => Ok(decode(&cp).ok()),
            None => Ok(None),
        }
    }

    /// The sealed records kept here, of `user` or (`None`) of every user.
    pub async fn list(&self, user: Option<&str>) -> Result<Vec<Checkpoint>> {
        self.records.list(user).await
    }

    /// True when `cp` is a record sealed by a daemon of this cluster (and not from the
    /// future).
    pub fn believe(&self, cp: &Checkpoint) -> bool {
        self.records.believe(cp, &cp.user, &cp.job)
    }

    /// Applies the retention at `now`: see the module's documentation. Returns (records,
    /// checkpoints) removed.
    pub async fn expire(
        &self,
        now: SystemTime,
        kept_jobs: usize,
        kept_secs: u64,
    ) -> Result<(usize, usize)> {
        let cutoff = now
            .checked_sub(Duration::from_secs(kept_secs))
            .unwrap_or(SystemTime::UNIX_EPOCH);
        let cutoff_ms = unix_ms(cutoff);
        let mut by_user: std::collections::BTreeMap<String, Vec<JobRecord>> = Default::default();
        for r in self.ended().await? {
            by_user.entry(r.user.clone()).or_default().push(r);
        }
        let (mut records, mut checkpoints) = (0, 0);
        for (user, mut ended) in by_user {
            ended.sort_by_key(|r| std::cmp::Reverse(r.updated_unix_ms));
            let doomed: Vec<String> = ended
                .iter()
                .enumerate()
                .filter(|(i, r)| *i >= kept_jobs || r.updated_unix_ms < cutoff_ms)
                .map(|(_, r)| r.id.clone())
                .collect();
            if doomed.is_empty() {
                continue;
            }
            let of_doomed = |key: &str| doomed.iter().any(|id| belongs_to(key, id));
            // Checkpoints first: a record is listed as long as anything of it is left.
            checkpoints += self
                .checkpoints
                .remove_where(&user, |key, _| of_doomed(key))
                .await?;
            records += self
                .records
                .remove_where(&user, |key, _| doomed.iter().any(|id| id == key))
                .await?;
        }
        checkpoints += self.checkpoints.remove_older_than(cutoff).await?;
        Ok((records, checkpoints))
    }
}

impl JobStore {
    /// The records of ended jobs kept here, every user's (those that decode).
    async fn ended(&self) -> Result<Vec<JobRecord>> {
        Ok(self
            .list(None)
            .await?
            .iter()
            .filter_map(|cp| decode(cp).ok())
            .filter(|r| is_ended(&r.state))
            .collect())
    }

    /// Removes the checkpoints of ended jobs, the least recently changed first, until
    /// `bytes` more fit under the quota (or no ended job has any left); how many jobs'
    /// checkpoints went.
    pub async fn make_room(&self, bytes: u64) -> Result<usize> {
        let mut ended = self.ended().await?;
        ended.sort_by_key(|r| (r.updated_unix_ms, r.user.clone(), r.id.clone()));
        let mut jobs = 0;
        for r in ended {
            if self.checkpoints.fits(bytes) {
                break;
            }
            let removed = self
                .checkpoints
                .remove_where(&r.user, |key, _| belongs_to(key, &r.id))
                .await?;
            if removed > 0 {
                tracing::warn!(user = %r.user, job = %r.id, "checkpoint quota: removed an ended job's checkpoints to make room");
                jobs += 1;
            }
        }
        Ok(jobs)
    }
}

/// True when checkpoint `key` is job `id`'s: the id itself or `ID.ANYTHING` (segments).
pub fn belongs_to(key: &str, id: &str) -> bool {
    key == id
        || key
            .strip_prefix(id)
            .is_some_and(|rest| rest.starts_with('.'))
}

/// The record inside an envelope.
pub fn decode(cp: &Checkpoint) -> Result<JobRecord> {
    JobRecord::decode(cp.data.as_slice())
        .map_err(|e| Error::Invalid(format!("a job record does not decode: {e}")))
}

/// Milliseconds since the epoch.
pub fn unix_ms(t: SystemTime) -> u64 {
    t.duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::limits::Limits;

    fn stores(dir: &std::path::Path) -> (JobStore, CheckpointStore) {
        stores_with_quota(dir, Limits::default().checkpoint_quota)
    }

    fn stores_with_quota(dir: &std::path::Path, quota: u64) -> (JobStore, CheckpointStore) {
        let key =
            crate::auth::peer_auth::DaemonKey::new(&crate::Secret::new("s").unwrap(), "a").unwrap();
        let limits = Limits {
            checkpoint_quota: quota,
            ..Limits::default()
        };
        let records = CheckpointStore::open(
            &dir.join("jobs"),
            key.clone(),
            limits.checkpoint_bytes,
            limits.checkpoint_quota,
        )
        .unwrap();
        let checkpoints = CheckpointStore::open(
            &dir.join("checkpoints"),
            key,
            limits.checkpoint_bytes,
            limits.checkpoint_quota,
        )
        .unwrap();
        (JobStore::new(records, checkpoints.clone()), checkpoints)
    }

    fn record(id: &str, state: &str, epoch: u64, updated: u64) -> JobRecord {
        JobRecord {
            id: id.into(),
            user: "alice".into(),
            state: state.into(),
            epoch,
            updated_unix_ms: updated,
            ..JobRecord::default()
        }
    }

    #[tokio::test]
    async fn an_older_epoch_cannot_overwrite_a_newer_one() {
        let dir = tempfile::tempdir().unwrap();
        let (jobs, _) = stores(dir.path());
        jobs.put(&jobs.seal(&record("j", "running", 2, 1), "a"))
            .await
            .unwrap();
        let old = jobs.seal(&record("j", "finished", 1, 2), "a");
        assert_eq!(
            jobs.put(&old).await.unwrap_err().code(),
            tonic::Code::Aborted
        );
        jobs.put(&jobs.seal(&record("j", "finished", 2, 3), "a"))
            .await
            .unwrap();
        let kept = jobs.list(Some("alice")).await.unwrap();
        assert_eq!(decode(&kept[0]).unwrap().state, "finished");
        // Ended is final at its epoch: a late "running" of the same controller is refused,
        // the same state again is not, and a newer epoch takes the job up again.
        let late = jobs.seal(&record("j", "running", 2, 4), "a");
        let err = jobs.put(&late).await.unwrap_err();
        assert_eq!(err.code(), tonic::Code::Aborted, "{err}");
        assert!(err.to_string().contains("has finished"), "{err}");
        jobs.put(&jobs.seal(&record("j", "finished", 2, 5), "a"))
            .await
            .unwrap();
        jobs.put(&jobs.seal(&record("j", "running", 3, 6), "a"))
            .await
            .unwrap();
        // One epoch, one controller: a second one of the same epoch is refused.
        let mut first = record("j", "running", 4, 7);
        first.controller = "a/1".into();
        jobs.put(&jobs.seal(&first, "a")).await.unwrap();
        let mut second = first.clone();
        second.controller = "b/9".into();
        let err = jobs.put(&jobs.seal(&second, "b")).await.unwrap_err();
        assert_eq!(err.code(), tonic::Code::Aborted, "{err}");
        // The envelope's user and id are the record's.
        let mut other = record("k", "running", 1, 1);
        other.user = "bob".into();
        let mut cp = jobs.seal(&other, "a");
        cp.user = "alice".into();
        jobs.records.seal(&mut cp);
        assert!(jobs.put(&cp).await.is_err());
    }

    #[tokio::test]
    async fn ended_jobs_go_by_count_and_age_with_their_checkpoints() {
        let dir = tempfile::tempdir().unwrap();
        let (jobs, checkpoints) = stores(dir.path());
        let now = SystemTime::now();
        let now_ms = unix_ms(now);
        let day = 24 * 3600 * 1000;
        for (id, state, updated) in [
            ("old", "finished", now_ms - 9 * day),
            ("done1", "finished", now_ms - 3),
            ("done2", "failed", now_ms - 2),
            ("done3", "cancelled", now_ms - 1),
            ("live", "running", now_ms - 9 * day),
        ] {
            jobs.put(&jobs.seal(&record(id, state, 1, updated), "a"))
                .await
                .unwrap();
            for key in [id.to_string(), format!("{id}.seg1")] {
                let mut cp = Checkpoint {
                    job: key,
                    data: b"pixels".to_vec(),
                    version: checkpoints.next_version(),
                    written_by: "a".into(),
                    mac: Vec::new(),
                    user: "alice".into(),
                    epoch: 0,
                };
                checkpoints.seal(&mut cp);
                checkpoints.put(&cp).await.unwrap();
            }
        }
        // Keep 2 ended jobs, for a week: "old" (too old) and "done1" (third newest) go.
        let (records, cps) = jobs.expire(now, 2, 7 * 24 * 3600).await.unwrap();
        assert_eq!((records, cps), (2, 4));
        let mut left: Vec<String> = jobs
            .list(Some("alice"))
            .await
            .unwrap()
            .iter()
            .map(|c| c.job.clone())
            .collect();
        left.sort();
        assert_eq!(left, ["done2", "done3", "live"]);
        assert!(checkpoints
            .get("alice", "live.seg1")
            .await
            .unwrap()
            .is_some());
        assert!(checkpoints.get("alice", "done1").await.unwrap().is_none());
        // A checkpoint nobody wrote for longer than the retention goes too.
        let (_, cps) = jobs
            .expire(now + Duration::from_secs(8 * 24 * 3600), 100, 7 * 24 * 3600)
            .await
            .unwrap();
        assert!(cps >= 2, "{cps}");
        assert!(belongs_to("j.seg", "j") && belongs_to("j", "j") && !belongs_to("jj", "j"));
    }

    /// A checkpoint of `user`'s `key`, `bytes` long, sealed for `store`.
    fn blob(store: &CheckpointStore, user: &str, key: &str, bytes: usize) -> Checkpoint {
        let mut cp = Checkpoint {
            job: key.into(),
            data: vec![7; bytes],
            version: store.next_version(),
            written_by: "a".into(),
            mac: Vec::new(),
            user: user.into(),
            epoch: 0,
        };
        store.seal(&mut cp);
        cp
    }

    #[tokio::test]
    async fn ended_jobs_checkpoints_make_room_oldest_first_never_a_running_ones() {
        let dir = tempfile::tempdir().unwrap();
        let (jobs, checkpoints) = stores_with_quota(dir.path(), 10_000);
        for (user, id, state, updated) in [
            ("alice", "newer", "finished", 300),
            ("bob", "older", "failed", 100),
            ("alice", "live", "running", 50),
        ] {
            let mut r = record(id, state, 1, updated);
            r.user = user.into();
            jobs.put(&jobs.seal(&r, "a")).await.unwrap();
            for key in [id.to_string(), format!("{id}.s0")] {
                checkpoints
                    .put(&blob(&checkpoints, user, &key, 1_500))
                    .await
                    .unwrap();
            }
        }
        // About 9,300 bytes kept: 2,000 more need one ended job's checkpoints, the oldest.
        assert!(!checkpoints.fits(2_000));
        assert_eq!(jobs.make_room(2_000).await.unwrap(), 1);
        assert!(checkpoints.fits(2_000));
        assert!(checkpoints.get("bob", "older.s0").await.unwrap().is_none());
        assert!(checkpoints
            .get("alice", "newer.s0")
            .await
            .unwrap()
            .is_some());
        // Records stay; a running job's checkpoints never go, so past the ended ones no
        // room is made.
        assert!(jobs.get("bob", "older").await.unwrap().is_some());
        assert_eq!(jobs.make_room(9_000).await.unwrap(), 1);
        assert_eq!(jobs.make_room(9_000).await.unwrap(), 0);
        assert!(checkpoints.get("alice", "live.s0").await.unwrap().is_some());
        assert!(!checkpoints.fits(9_000));
    }
}
