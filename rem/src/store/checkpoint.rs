//! Checkpoints: opaque blobs keyed by user and job id (`DIR/USER/JOB.ckpt`), kept in files
//! written atomically (temporary file, fsync, rename). The newest version wins. Replication to
//! other hosts is done by the daemon (`PutCheckpoint` stores here and on one more live host).
//! Each user has a namespace of its own: nobody reads, overwrites or shadows another user's
//! checkpoint of the same job id.
//!
//! Every checkpoint is sealed by the daemon that wrote it (an HMAC under the daemon key), and
//! one is believed, from a peer or from this host's disk, only with a good seal and a version
//! not ahead of this host's clock by more than [`MAX_SKEW`]: a version "from the future" would
//! shadow the owner's later checkpoints for ever. Sizes are bounded per job
//! (`checkpoint_bytes`) and in all (`checkpoint_quota`).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{SystemTime, UNIX_EPOCH};

use prost::Message;

use crate::auth::peer_auth::{DaemonKey, MAX_SKEW};
use crate::error::{Error, Result};
use crate::wire::proto::Checkpoint;

/// The checkpoints kept on this host.
#[derive(Clone, Debug)]
pub struct CheckpointStore {
    dir: PathBuf,
    lock: Arc<tokio::sync::Mutex<()>>,
    clock: Arc<AtomicU64>,
    key: DaemonKey,
    max_bytes: usize,
    quota: u64,
}

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

impl CheckpointStore {
    /// A store in `dir`, sealing with `key`, taking checkpoints of up to `max_bytes` and
    /// `quota` bytes of them in all.
    pub fn open(dir: &Path, key: DaemonKey, max_bytes: usize, quota: u64) -> Result<Self> {
        std::fs::create_dir_all(dir)?;
        Ok(CheckpointStore {
            dir: dir.to_path_buf(),
            lock: Arc::default(),
            clock: Arc::default(),
            key,
            max_bytes,
            quota,
        })
    }

    fn seal_of(&self, cp: &Checkpoint) -> [u8; 32] {
        let data = crate::auth::peer_auth::digest_bytes(&cp.data);
        self.key.seal(&[
            "checkpoint",
            &cp.user,
            &cp.job,
            &cp.version.to_string(),
            &cp.written_by,
            &data,
            &cp.epoch.to_string(),
        ])
    }

    /// Seals a checkpoint this daemon writes.
    pub fn seal(&self, cp: &mut Checkpoint) {
        cp.mac = self.seal_of(cp).to_vec();
    }

    /// True when `cp` is `user`'s checkpoint of `job` sealed by a daemon of this cluster, and
    /// its version is not from the future.
    pub fn believe(&self, cp: &Checkpoint, user: &str, job: &str) -> bool {
        use subtle::ConstantTimeEq;
        cp.job == job
            && cp.user == user
            && cp.version <= now_ns().saturating_add(MAX_SKEW.as_nanos() as u64)
            && bool::from(self.seal_of(cp).as_slice().ct_eq(&cp.mac))
    }

    /// Refuses what no daemon should store: too large, unsealed, or from the future.
    fn admit(&self, cp: &Checkpoint) -> Result<()> {
        if cp.data.len() > self.max_bytes {
            return Err(Error::TooLarge {
                size: cp.data.len(),
                limit: self.max_bytes,
            });
        }
        if cp.version > now_ns().saturating_add(MAX_SKEW.as_nanos() as u64) {
            return Err(Error::Invalid(format!(
                "checkpoint version {} is from the future",
                cp.version
            )));
        }
        if !self.believe(cp, &cp.user, &cp.job) {
            return Err(Error::Refused(
                "the checkpoint is not sealed by a daemon of this cluster".into(),
            ));
        }
        Ok(())
    }

    /// Bytes of checkpoints on disk now (every user's), besides `except`'s file.
    fn used(&self, except: &Path) -> u64 {
        let files = |dir: &Path| {
            std::fs::read_dir(dir)
                .into_iter()
                .flatten()
                .filter_map(|e| e.ok())
                .collect::<Vec<_>>()
        };
        files(&self.dir)
            .into_iter()
            .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
            .flat_map(|user| files(&user.path()))
            .filter(|e| e.path() != except)
            .filter_map(|e| e.metadata().ok())
            .map(|m| m.len())
            .sum()
    }

    /// True when `bytes` more of checkpoints fit under the quota now.
    pub fn fits(&self, bytes: u64) -> bool {
        self.used(Path::new("")).saturating_add(bytes) <= self.quota
    }

    /// A version newer than any this store has handed out (nanoseconds since the epoch).
    pub fn next_version(&self) -> u64 {
        let now = now_ns();
        let prev = self.clock.fetch_max(now, Ordering::SeqCst);
        if prev >= now {
            self.clock.fetch_add(1, Ordering::SeqCst) + 1
        } else {
            now
        }
    }

    fn path(&self, user: &str, job: &str) -> Result<PathBuf> {
        if !crate::wire::ids::is_valid_name(job) {
            return Err(Error::Invalid(format!(
                "bad job id {}",
                crate::wire::ids::shown(job)
            )));
        }
        if !crate::auth::identity::is_valid_user(user) || user.starts_with('.') {
            return Err(Error::Invalid(format!(
                "bad user name {}",
                crate::wire::ids::shown(user)
            )));
        }
        Ok(self.dir.join(user).join(format!("{job}.ckpt")))
    }

    /// Stores `cp` unless a newer version is already here; refuses one that is too large,
    /// unsealed, from the future, or over the quota.
    pub async fn put(&self, cp: &Checkpoint) -> Result<()> {
        self.put_checked(cp, |_| Ok(())).await
    }

    /// As [`put`](Self::put), after `check` accepted what is kept now (called under the
    /// store's lock, so nothing changes between the check and the write).
    pub async fn put_checked(
        &self,
        cp: &Checkpoint,
        check: impl FnOnce(Option<&Checkpoint>) -> Result<()>,
    ) -> Result<()> {
        let path = self.path(&cp.user, &cp.job)?;
        self.admit(cp)?;
        let _guard = self.lock.lock().await;
        let old = self.read(&path).await?;
        check(old.as_ref())?;
        if let Some(old) = old.as_ref().filter(|old| old.epoch > cp.epoch) {
            return Err(Error::Fenced(format!(
                "checkpoint {} was written by a newer controller (epoch {} > {})",
                cp.job, old.epoch, cp.epoch
            )));
        }
        if old.is_some_and(|old| (old.epoch, old.version) >= (cp.epoch, cp.version)) {
            return Ok(());
        }
        let size = cp.encoded_len() as u64;
        let used = self.used(&path);
        if used.saturating_add(size) > self.quota {
            return Err(Error::Limit(format!(
                "checkpoint quota: {used} bytes are kept, {size} more would pass {}",
                self.quota
            )));
        }
        let user_dir = self.dir.join(&cp.user);
        tokio::fs::create_dir_all(&user_dir).await?;
        let tmp = user_dir.join(format!(".{}.tmp", cp.job));
        let bytes = cp.encode_to_vec();
        let tmp2 = tmp.clone();
        let written = tokio::task::spawn_blocking(move || -> std::io::Result<()> {
            use std::io::Write;
            let mut f = std::fs::File::create(&tmp2)?;
            f.write_all(&bytes)?;
            f.sync_all()?;
            Ok(())
        })
        .await
        .map_err(std::io::Error::other)
        .and_then(|r| r);
        if let Err(e) = written {
            // A full disk: the part written is removed (it is never read: only `*.ckpt` is),
            // so it does not hold the space the next write needs.
            let _ = tokio::fs::remove_file(&tmp).await;
            return Err(Error::Io(e));
        }
        tokio::fs::rename(&tmp, &path).await?;
        Ok(())
    }

    /// `user`'s checkpoint of `job` kept here, if it is one to believe.
    pub async fn get(&self, user: &str, job: &str) -> Result<Option<Checkpoint>> {
        let path = self.path(user, job)?;
        Ok(self.read(&path).await?.filter(|cp| {
            let good = self.believe(cp, user, job);
            if !good {
                tracing::warn!(%job, "ignoring a checkpoint file whose seal is wrong");
            }
            good
        }))
    }

    /// Every believable entry kept here, of `user` (or of every user when `None`).
    pub async fn list(&self, user: Option<&str>) -> Result<Vec<Checkpoint>> {
        let users: Vec<String> = match user {
            Some(u) => vec![u.to_string()],
            None => self.users(),
        };
        let mut out = Vec::new();
        for user in users {
            let Ok(dir) = std::fs::read_dir(self.dir.join(&user)) else {
                continue;
            };
            for entry in dir.filter_map(|e| e.ok()) {
                let name = entry.file_name().to_string_lossy().into_owned();
                let Some(job) = name.strip_suffix(".ckpt") else {
                    continue;
                };
                if let Ok(Some(cp)) = self.get(&user, job).await {
                    out.push(cp);
                }
            }
        }
        Ok(out)
    }

    /// The users with a folder here.
    fn users(&self) -> Vec<String> {
        std::fs::read_dir(&self.dir)
            .into_iter()
            .flatten()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|u| crate::auth::identity::is_valid_user(u))
            .collect()
    }

    /// Removes `user`'s entries for which `doomed(key, last written)` holds; returns how
    /// many went.
    pub async fn remove_where(
        &self,
        user: &str,
        doomed: impl Fn(&str, SystemTime) -> bool,
    ) -> Result<usize> {
        let _guard = self.lock.lock().await;
        let Ok(dir) = std::fs::read_dir(self.dir.join(user)) else {
            return Ok(0);
        };
        let mut removed = 0;
        for entry in dir.filter_map(|e| e.ok()) {
            let name = entry.file_name().to_string_lossy().into_owned();
            let Some(key) = name.strip_suffix(".ckpt") else {
                continue;
            };
            let written = entry
                .metadata()
                .and_then(|m| m.modified())
                .unwrap_or(SystemTime::now());
            if doomed(key, written) {
                tokio::fs::remove_file(entry.path()).await?;
                removed += 1;
            }
        }
        Ok(removed)
    }

    /// Removes every entry (of every user) not written since `cutoff`; returns how many.
    pub async fn remove_older_than(&self, cutoff: SystemTime) -> Result<usize> {
        let mut removed = 0;
        for user in self.users() {
            removed += self.remove_where(&user, |_, t| t < cutoff).await?;
        }
        Ok(removed)
    }

    async fn read(&self, path: &Path) -> Result<Option<Checkpoint>> {
        match tokio::fs::read(path).await {
            Ok(bytes) => Checkpoint::decode(bytes.as_slice())
                .map(Some)
                .map_err(|e| Error::Io(std::io::Error::new(std::io::ErrorKind::InvalidData, e))),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(e.into()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::limits::Limits;

    fn store(dir: &Path, limits: &Limits) -> CheckpointStore {
        let key = DaemonKey::new(&crate::Secret::new("s").unwrap(), "a").unwrap();
        CheckpointStore::open(dir, key, limits.checkpoint_bytes, limits.checkpoint_quota).unwrap()
    }

    fn sealed(store: &CheckpointStore, data: &[u8], version: u64) -> Checkpoint {
        let mut cp = Checkpoint {
            job: "j1".into(),
            data: data.to_vec(),
            version,
            written_by: "a".into(),
            mac: Vec::new(),
            user: "alice".into(),
            epoch: 0,
        };
        store.seal(&mut cp);
        cp
    }

    #[tokio::test]
    async fn forged_future_oversized_and_over_quota_checkpoints_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let limits = Limits {
            checkpoint_bytes: 100,
            checkpoint_quota: 350,
            ..Limits::default()
        };
        let store = store(dir.path(), &limits);
        let v = store.next_version();
        let mut forged = sealed(&store, b"x", v);
        forged.data = b"y".to_vec();
        assert_eq!(
            store.put(&forged).await.unwrap_err().code(),
            tonic::Code::PermissionDenied
        );
        let future = sealed(&store, b"x", u64::MAX);
        assert_eq!(
            store.put(&future).await.unwrap_err().code(),
            tonic::Code::InvalidArgument
        );
        assert!(!store.believe(&future, "alice", "j1"));
        let big = sealed(&store, &[0; 101], v);
        assert_eq!(
            store.put(&big).await.unwrap_err().code(),
            tonic::Code::ResourceExhausted
        );
        for (i, job) in ["a", "b"].iter().enumerate() {
            let mut cp = sealed(&store, &[i as u8; 100], v);
            cp.job = job.to_string();
            store.seal(&mut cp);
            store.put(&cp).await.unwrap();
        }
        let mut third = sealed(&store, &[0; 100], v);
        third.job = "c".into();
        store.seal(&mut third);
        assert_eq!(
            store.put(&third).await.unwrap_err().code(),
            tonic::Code::ResourceExhausted
        );
        // Replacing a job's own checkpoint does not count its old file.
        let mut again = sealed(&store, &[9; 100], store.next_version());
        again.job = "a".into();
        store.seal(&mut again);
        store.put(&again).await.unwrap();
        assert!(store.get("alice", "c").await.unwrap().is_none());
    }

    #[tokio::test]
    async fn newest_version_wins_and_survives_reopen() {
        let dir = tempfile::tempdir().unwrap();
        let store = store(dir.path(), &Limits::default());
        let v1 = store.next_version();
        let v2 = store.next_version();
        assert!(v2 > v1);
        let cp = |data: &[u8], version| sealed(&store, data, version);
        store.put(&cp(b"two", v2)).await.unwrap();
        store.put(&cp(b"one", v1)).await.unwrap();
        let again = self::store(dir.path(), &Limits::default());
        assert_eq!(
            again.get("alice", "j1").await.unwrap().unwrap().data,
            b"two"
        );
        assert!(again.get("alice", "nothing").await.unwrap().is_none());
        assert!(store.get("alice", "../etc").await.is_err());
        assert!(store.get("..", "etc").await.is_err());
        // No temporary file is left behind.
        let names: Vec<_> = std::fs::read_dir(dir.path().join("alice"))
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1);
    }

    #[tokio::test]
    async fn each_user_has_a_namespace_of_its_own() {
        let dir = tempfile::tempdir().unwrap();
        let store = store(dir.path(), &Limits::default());
        let alice = sealed(&store, b"alice's", store.next_version());
        store.put(&alice).await.unwrap();
        // Mallory's checkpoint of the same job, newer, lands in Mallory's namespace only.
        let mut mallory = sealed(&store, b"mallory's", store.next_version());
        mallory.user = "mallory".into();
        store.seal(&mut mallory);
        store.put(&mallory).await.unwrap();
        assert_eq!(
            store.get("alice", "j1").await.unwrap().unwrap().data,
            b"alice's"
        );
        assert_eq!(
            store.get("mallory", "j1").await.unwrap().unwrap().data,
            b"mallory's"
        );
        // Alice's seal does not cover a copy relabelled as Mallory's.
        let mut relabelled = alice.clone();
        relabelled.user = "mallory".into();
        assert!(!store.believe(&relabelled, "mallory", "j1"));
        assert!(!store.believe(&alice, "mallory", "j1"));
    }
}
