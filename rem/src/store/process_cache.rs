//! A folder on each host where REM's processes keep what they can rebuild but would rather
//! not (SunRay keeps the accelerators it built there, so the next worker or job on this host
//! reads one instead of building it). remd makes it under its state directory, owned by the
//! user its children run as, tells every child where it is (`REM_CACHE_DIR`), and keeps it
//! within `process_cache_bytes` by removing the least recently used files (by modification
//! time: a reader touches what it uses) when it starts and every minute after.
//!
//! Nothing in it is trusted: any process of the host may write there, so a reader checks
//! everything it reads and rebuilds what does not pass. A file is written whole or not at
//! all (a temporary name, then a rename), so a full disk leaves no half file.

use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// The process cache of one host.
#[derive(Clone, Debug)]
pub struct ProcessCache {
    dir: PathBuf,
    limit: u64,
}

impl ProcessCache {
    /// Makes (or keeps) `dir`, owned by `owner` (uid, gid) when given, readable and writable
    /// by its owner alone; bounded to `limit` bytes.
    pub fn open(
        dir: &Path,
        limit: u64,
        owner: Option<(u32, u32)>,
    ) -> std::io::Result<ProcessCache> {
        use std::os::unix::fs::PermissionsExt;
        std::fs::create_dir_all(dir)?;
        if let Some((uid, gid)) = owner {
            std::os::unix::fs::chown(dir, Some(uid), Some(gid))?;
        }
        std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o700))?;
        Ok(ProcessCache {
            dir: dir.to_path_buf(),
            limit,
        })
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Removes the least recently used files until the rest fit in the limit (and any
    /// temporary file an hour old: a writer that died half way); how many files and bytes
    /// went.
    pub fn trim(&self) -> std::io::Result<(usize, u64)> {
        let mut files: Vec<(SystemTime, u64, PathBuf)> = Vec::new();
        for entry in std::fs::read_dir(&self.dir)? {
            let entry = entry?;
            let meta = match entry.metadata() {
                Ok(m) if m.is_file() => m,
                _ => continue,
            };
            let modified = meta.modified().unwrap_or(SystemTime::UNIX_EPOCH);
            files.push((modified, meta.len(), entry.path()));
        }
        files.sort();
        let mut total: u64 = files.iter().map(|f| f.1).sum();
        let stale = SystemTime::now() - std::time::Duration::from_secs(3600);
        let (mut removed, mut bytes) = (0, 0);
        for (modified, len, path) in files {
            let temporary = path
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with('.'));
            if total <= self.limit && !(temporary && modified < stale) {
                continue;
            }
            if std::fs::remove_file(&path).is_ok() {
                total -= len;
                removed += 1;
                bytes += len;
            }
        }
        Ok((removed, bytes))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_least_recently_used_files_go_first() {
        let dir = tempfile::tempdir().unwrap();
        let cache = ProcessCache::open(&dir.path().join("cache"), 250, None).unwrap();
        let now = SystemTime::now();
        for (k, age) in [("a", 30), ("b", 10), ("c", 20)] {
            let path = cache.dir().join(k);
            std::fs::write(&path, [0u8; 100]).unwrap();
            let f = std::fs::File::options().write(true).open(&path).unwrap();
            f.set_modified(now - std::time::Duration::from_secs(age))
                .unwrap();
        }
        assert_eq!(cache.trim().unwrap(), (1, 100));
        let mut left: Vec<String> = std::fs::read_dir(cache.dir())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
            .collect();
        left.sort();
        assert_eq!(left, ["b", "c"], "a was used longest ago");
        assert_eq!(cache.trim().unwrap(), (0, 0));
    }
}
