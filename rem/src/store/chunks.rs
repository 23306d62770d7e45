//! Chunks: content-addressed blobs (a scene's model cut in pieces) named by the SHA-256 of
//! their bytes, cached in `DIR/xx/HASH` files (written atomically: temporary file, fsync,
//! rename). The cache is bounded in bytes (`chunk_cache_bytes`); the least recently used
//! chunks go first. Every read checks the bytes against the name: a corrupt file is removed
//! and reported missing, so it is fetched again and never served. A write that fails (a full
//! disk) leaves no file behind and is reported to the caller, which may still use the bytes
//! it holds.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use tokio::sync::Mutex;

use crate::error::{Error, Result};
use crate::wire::chunk_name::{check_name, is_chunk_name, name_of};

#[derive(Debug, Default)]
struct Index {
    /// Size and last use of each cached chunk.
    sizes: HashMap<String, (u64, u64)>,
    /// Last use -> chunk, oldest first.
    by_use: BTreeMap<u64, String>,
    total: u64,
    clock: u64,
}

impl Index {
    fn touch(&mut self, hash: &str) {
        self.clock += 1;
        let now = self.clock;
        if let Some((_, used)) = self.sizes.get_mut(hash) {
            self.by_use.remove(used);
            *used = now;
            self.by_use.insert(now, hash.to_string());
        }
    }

    fn add(&mut self, hash: &str, size: u64) {
        self.clock += 1;
        if let Some((old, used)) = self.sizes.insert(hash.to_string(), (size, self.clock)) {
            self.by_use.remove(&used);
            self.total -= old;
        }
        self.by_use.insert(self.clock, hash.to_string());
        self.total += size;
    }

    fn remove(&mut self, hash: &str) {
        if let Some((size, used)) = self.sizes.remove(hash) {
            self.by_use.remove(&used);
            self.total -= size;
        }
    }

    fn oldest(&self) -> Option<String> {
        self.by_use.values().next().cloned()
    }
}

/// Locks striping the chunk names, so that one chunk is fetched once at a time per host.
const FETCH_STRIPES: usize = 64;

/// The chunks cached on this host.
#[derive(Clone, Debug)]
pub struct ChunkStore {
    dir: PathBuf,
    capacity: u64,
    index: Arc<Mutex<Index>>,
    fetching: Arc<[Arc<Mutex<()>>]>,
}

impl ChunkStore {
    /// Opens (creating) the cache in `dir`, of at most `capacity` bytes; what is there
    /// already counts, the least recently modified first to go.
    pub fn open(dir: &Path, capacity: u64) -> Result<Self> {
        std::fs::create_dir_all(dir)?;
        let mut found = Vec::new();
        for sub in std::fs::read_dir(dir)?.flatten() {
            let Ok(files) = std::fs::read_dir(sub.path()) else {
                continue;
            };
            for f in files.flatten() {
                let name = f.file_name().to_string_lossy().to_string();
                let Ok(meta) = f.metadata() else { continue };
                if is_chunk_name(&name) && meta.is_file() {
                    found.push((meta.modified().ok(), name, meta.len()));
                } else if name.starts_with(".tmp") {
                    let _ = std::fs::remove_file(f.path()); // a write cut short
                }
            }
        }
        found.sort();
        let mut index = Index::default();
        for (_, name, len) in found {
            index.add(&name, len);
        }
        Ok(ChunkStore {
            dir: dir.to_path_buf(),
            capacity,
            index: Arc::new(Mutex::new(index)),
            fetching: (0..FETCH_STRIPES).map(|_| Arc::default()).collect(),
        })
    }

    /// Held while `hash` is fetched from a peer, so that a second request for it waits and
    /// then finds it cached.
    pub async fn fetch_lock(&self, hash: &str) -> tokio::sync::OwnedMutexGuard<()> {
        let stripe = hash
            .bytes()
            .fold(0usize, |a, b| a.wrapping_mul(31) ^ b as usize);
        self.fetching[stripe % FETCH_STRIPES]
            .clone()
            .lock_owned()
            .await
    }

    fn path(&self, hash: &str) -> PathBuf {
        self.dir.join(&hash[..2]).join(hash)
    }

    /// Bytes cached now.
    pub async fn bytes(&self) -> u64 {
        self.index.lock().await.total
    }

    /// Whether `hash` is cached (not read: a corrupt file is found on `get`).
    pub async fn has(&self, hash: &str) -> bool {
        is_chunk_name(hash) && self.index.lock().await.sizes.contains_key(hash)
    }

    /// The bytes of `hash` if cached and intact; a corrupt copy is removed.
    pub async fn get(&self, hash: &str) -> Result<Option<Vec<u8>>> {
        check_name(hash)?;
        let mut index = self.index.lock().await;
        if !index.sizes.contains_key(hash) {
            return Ok(None);
        }
        let path = self.path(hash);
        let read = tokio::fs::read(&path).await;
        match read {
            Ok(data) if name_of(&data) == hash => {
                index.touch(hash);
                Ok(Some(data))
            }
            Ok(_) => {
                tracing::warn!(chunk = %hash, "cached chunk is corrupt: removed, to be fetched again");
                let _ = tokio::fs::remove_file(&path).await;
                index.remove(hash);
                Ok(None)
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                index.remove(hash);
                Ok(None)
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Caches `data` under `hash` (it must be its name), making room by removing the least
    /// recently used chunks. A chunk larger than the whole cache, or a failed write (a full
    /// disk), is an error and leaves nothing behind.
    pub async fn put(&self, hash: &str, data: &[u8]) -> Result<()> {
        check_name(hash)?;
        if name_of(data) != hash {
            return Err(Error::Invalid(format!(
                "chunk {hash}: its bytes do not hash to its name"
            )));
        }
        let size = data.len() as u64;
        if size > self.capacity {
            return Err(Error::TooLarge {
                size: data.len(),
                limit: self.capacity as usize,
            });
        }
        let mut index = self.index.lock().await;
        if index.sizes.contains_key(hash) && tokio::fs::metadata(self.path(hash)).await.is_ok() {
            index.touch(hash);
            return Ok(());
        }
        while index.total + size > self.capacity {
            let Some(old) = index.oldest() else { break };
            let _ = tokio::fs::remove_file(self.path(&old)).await;
            index.remove(&old);
        }
        let path = self.path(hash);
        let written = write_atomically(&path, data.to_vec()).await;
        match written {
            Ok(()) => {
                index.add(hash, size);
                Ok(())
            }
            Err(e) => Err(e.into()),
        }
    }
}

/// Writes `data` to a temporary file beside `path`, syncs it and renames it into place; on
/// any failure the temporary file is removed.
async fn write_atomically(path: &Path, data: Vec<u8>) -> std::io::Result<()> {
    let path = path.to_path_buf();
    tokio::task::spawn_blocking(move || {
        use std::io::Write;
        let dir = path.parent().unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir)?;
        let mut tmp = tempfile::Builder::new().prefix(".tmp").tempfile_in(dir)?;
        tmp.write_all(&data)?;
        tmp.as_file().sync_all()?;
        tmp.persist(&path).map_err(|e| e.error)?;
        Ok(())
    })
    .await
    .map_err(std::io::Error::other)?
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chunk(n: u8, len: usize) -> (String, Vec<u8>) {
        let data = vec![n; len];
        (name_of(&data), data)
    }

    #[tokio::test]
    async fn keeps_and_reads_back_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let store = ChunkStore::open(dir.path(), 1 << 20).unwrap();
        let (h, d) = chunk(1, 1000);
        assert_eq!(store.get(&h).await.unwrap(), None);
        store.put(&h, &d).await.unwrap();
        assert_eq!(store.get(&h).await.unwrap(), Some(d.clone()));
        // Reopened, the cache still has it.
        let again = ChunkStore::open(dir.path(), 1 << 20).unwrap();
        assert_eq!(again.get(&h).await.unwrap(), Some(d));
        assert_eq!(again.bytes().await, 1000);
    }

    #[tokio::test]
    async fn refuses_bytes_that_do_not_hash_to_the_name_and_bad_names() {
        let dir = tempfile::tempdir().unwrap();
        let store = ChunkStore::open(dir.path(), 1 << 20).unwrap();
        let (h, _) = chunk(1, 10);
        assert!(store.put(&h, b"something else").await.is_err());
        assert!(store.get("../../etc/passwd").await.is_err());
        assert!(store.put("ABC", b"x").await.is_err());
        assert_eq!(store.bytes().await, 0);
    }

    #[tokio::test]
    async fn a_corrupt_copy_is_removed_and_reported_missing() {
        let dir = tempfile::tempdir().unwrap();
        let store = ChunkStore::open(dir.path(), 1 << 20).unwrap();
        let (h, d) = chunk(7, 4096);
        store.put(&h, &d).await.unwrap();
        let path = dir.path().join(&h[..2]).join(&h);
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[100] ^= 1;
        std::fs::write(&path, bytes).unwrap();
        assert_eq!(store.get(&h).await.unwrap(), None);
        assert!(!path.exists());
        assert!(!store.has(&h).await);
        store.put(&h, &d).await.unwrap();
        assert_eq!(store.get(&h).await.unwrap(), Some(d));
    }

    #[tokio::test]
    async fn the_least_recently_used_go_first_and_the_bound_holds() {
        let dir = tempfile::tempdir().unwrap();
        let store = ChunkStore::open(dir.path(), 3000).unwrap();
        let (a, da) = chunk(1, 1000);
        let (b, db) = chunk(2, 1000);
        let (c, dc) = chunk(3, 1000);
        let (d, dd) = chunk(4, 1000);
        store.put(&a, &da).await.unwrap();
        store.put(&b, &db).await.unwrap();
        store.put(&c, &dc).await.unwrap();
        store.get(&a).await.unwrap(); // a is used again: b is now the oldest
        store.put(&d, &dd).await.unwrap();
        assert!(store.has(&a).await && store.has(&c).await && store.has(&d).await);
        assert!(!store.has(&b).await);
        assert_eq!(store.bytes().await, 3000);
        let (big, dbig) = chunk(5, 4000);
        assert!(store.put(&big, &dbig).await.is_err());
    }

    #[tokio::test]
    async fn a_failed_write_leaves_nothing_behind() {
        let dir = tempfile::tempdir().unwrap();
        let store = ChunkStore::open(dir.path(), 1 << 20).unwrap();
        let (h, d) = chunk(9, 100);
        // The chunk's folder is a file: the write fails as on a full disk.
        std::fs::write(dir.path().join(&h[..2]), b"in the way").unwrap();
        assert!(store.put(&h, &d).await.is_err());
        assert!(!store.has(&h).await);
        assert_eq!(store.bytes().await, 0);
    }
}
