//! Checkpoints: opaque blobs keyed by job id, kept in files written atomically (temporary
//! file, fsync, rename). The newest version wins. Replication to other hosts is done by the
//! service (`PutCheckpoint` stores here and on one more live host).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{SystemTime, UNIX_EPOCH};

use prost::Message;

use crate::error::{Error, Result};
use crate::proto::Checkpoint;

/// The checkpoints kept on this host.
#[derive(Clone, Debug)]
pub struct CheckpointStore {
    dir: PathBuf,
    lock: Arc<tokio::sync::Mutex<()>>,
    clock: Arc<AtomicU64>,
}

impl CheckpointStore {
    pub fn open(dir: &Path) -> Result<Self> {
        std::fs::create_dir_all(dir)?;
        Ok(CheckpointStore {
            dir: dir.to_path_buf(),
            lock: Arc::default(),
            clock: Arc::default(),
        })
    }

    /// A version newer than any this store has handed out (nanoseconds since the epoch).
    pub fn next_version(&self) -> u64 {
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        let prev = self.clock.fetch_max(now, Ordering::SeqCst);
        if prev >= now {
            self.clock.fetch_add(1, Ordering::SeqCst) + 1
        } else {
            now
        }
    }

    fn path(&self, job: &str) -> Result<PathBuf> {
        if !crate::ids::is_valid_name(job) {
            return Err(Error::Invalid(format!("bad job id {job:?}")));
        }
        Ok(self.dir.join(format!("{job}.ckpt")))
    }

    /// Stores `cp` unless a newer version is already here.
    pub async fn put(&self, cp: &Checkpoint) -> Result<()> {
        let path = self.path(&cp.job)?;
        let _guard = self.lock.lock().await;
        if let Some(old) = self.read(&path).await? {
            if old.version >= cp.version {
                return Ok(());
            }
        }
        let tmp = self.dir.join(format!(".{}.tmp", cp.job));
        let bytes = cp.encode_to_vec();
        let tmp2 = tmp.clone();
        tokio::task::spawn_blocking(move || -> std::io::Result<()> {
            use std::io::Write;
            let mut f = std::fs::File::create(&tmp2)?;
            f.write_all(&bytes)?;
            f.sync_all()?;
            Ok(())
        })
        .await
        .map_err(|e| Error::Io(std::io::Error::other(e)))??;
        tokio::fs::rename(&tmp, &path).await?;
        Ok(())
    }

    pub async fn get(&self, job: &str) -> Result<Option<Checkpoint>> {
        let path = self.path(job)?;
        self.read(&path).await
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

    #[tokio::test]
    async fn newest_version_wins_and_survives_reopen() {
        let dir = tempfile::tempdir().unwrap();
        let store = CheckpointStore::open(dir.path()).unwrap();
        let v1 = store.next_version();
        let v2 = store.next_version();
        assert!(v2 > v1);
        let cp = |data: &[u8], version| Checkpoint {
            job: "j1".into(),
            data: data.to_vec(),
            version,
            written_by: "a".into(),
        };
        store.put(&cp(b"two", v2)).await.unwrap();
        store.put(&cp(b"one", v1)).await.unwrap();
        let again = CheckpointStore::open(dir.path()).unwrap();
        assert_eq!(again.get("j1").await.unwrap().unwrap().data, b"two");
        assert!(again.get("nothing").await.unwrap().is_none());
        assert!(store.get("../etc").await.is_err());
        // No temporary file is left behind.
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1);
    }
}
