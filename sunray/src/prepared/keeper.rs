//! The keeper: a process of its own (`sunray prepare-scene`) that turns a model into a
//! prepared scene file, so the file is finished and sealed even when the worker that asked
//! for it is ended with its job (REM ends a worker's whole process group; the keeper starts
//! a group of its own). The worker streams the model's bytes to the keeper's standard input
//! as they arrive, waits for it, and maps what it kept; a worker that is ended meanwhile
//! leaves the keeper to finish for the next job.
//!
//! One keeper works on a file at a time (a lock beside it); one that finds the file kept
//! while it waited ends at once, reading nothing.
//!
//! The keeper is bounded: it stops itself after [`KEEPER_LIMIT`] (an alarm), and what it
//! writes is bounded by the cache folder, which remd keeps within its limit. The model is
//! checked against its hash before anything is kept.

use super::PreparedError;
use crate::accel::{Accel, AccelKind, AccelOptions};
use crate::scene::Scene;
use std::io::Read;
use std::path::Path;
use std::process::{Child, Command, Stdio};

/// The longest a keeper runs.
pub const KEEPER_LIMIT: std::time::Duration = std::time::Duration::from_secs(900);

/// What the keeper prints on its standard output when it kept the scene and read its BVH
/// from the host's cache; [`KEPT_BUILT`] when it built it.
pub const KEPT_CACHED: &str = "kept accel_cached";
/// See [`KEPT_CACHED`].
pub const KEPT_BUILT: &str = "kept accel_built";

/// Why a keeper did not keep its scene.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum KeeperError {
    /// The model did not arrive whole or does not decode.
    #[error("the model: {0}")]
    Model(String),
    /// The model is not the one named (its hash differs).
    #[error("the model's bytes are not the scene's model (hash differs)")]
    Hash,
    /// Writing or checking the file failed.
    #[error(transparent)]
    Prepared(#[from] PreparedError),
}

/// Reads a model from `input`, builds its scene and BVH as `opts` asks (the BVH read from
/// the host's cache `bvh_dir` when it is there) and keeps them at `path`; whether the BVH
/// was read from the cache.
pub fn keep_model(
    input: &mut impl Read,
    path: &Path,
    model_hash: u64,
    opts: &AccelOptions,
    bvh_dir: Option<&Path>,
) -> Result<bool, KeeperError> {
    // One keeper of a file at a time: two workers of a job on one host (the embedded
    // default) would each decode and build the same scene. The second waits for the first,
    // and keeps nothing (reads none of its input) when the file is there and good.
    let _turn = KeepLock::take(path)?;
    if let Ok(Some(_)) = super::load(path, model_hash) {
        return Ok(true);
    }
    let mut hashing = HashingReader {
        inner: input,
        hash: yari::modelfile::FNV_OFFSET,
    };
    let mut scene =
        Scene::read_model(&mut hashing).map_err(|e| KeeperError::Model(e.to_string()))?;
    std::io::copy(&mut hashing, &mut std::io::sink())
        .map_err(|e| KeeperError::Model(e.to_string()))?;
    if hashing.hash != model_hash {
        return Err(KeeperError::Hash);
    }
    let (accel, provenance): (Accel, _) =
        crate::accel::cache::build_or_load(&mut scene.prims, opts, model_hash, bvh_dir);
    super::keep(path, model_hash, &scene, &accel)?;
    Ok(provenance.cached)
}

/// The turn of one keeper at a prepared file: an exclusive `flock` on `FILE.lock`, which the
/// system releases when the keeper ends, however it ends.
struct KeepLock(#[allow(dead_code)] std::fs::File);

impl KeepLock {
    /// Waits for the turn at `path`.
    fn take(path: &Path) -> Result<KeepLock, KeeperError> {
        use std::os::fd::AsRawFd;
        let mut name = path.as_os_str().to_owned();
        name.push(".lock");
        let io = |e: std::io::Error| {
            KeeperError::Prepared(PreparedError::Io {
                path: std::path::PathBuf::from(&name),
                source: e,
            })
        };
        let file = std::fs::File::options()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&name)
            .map_err(io)?;
        // SAFETY: flock takes an open descriptor of `file`, which lives as long as the lock.
        if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX) } != 0 {
            return Err(io(std::io::Error::last_os_error()));
        }
        Ok(KeepLock(file))
    }
}

/// A reader that hashes what it reads (FNV-1a 64, the model's hash).
struct HashingReader<'a, R: Read> {
    inner: &'a mut R,
    hash: u64,
}

impl<R: Read> Read for HashingReader<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.hash = yari::modelfile::fnv1a_update(self.hash, &buf[..n]);
        Ok(n)
    }
}

/// Starts a keeper (this program's `prepare-scene`) of the model with `model_hash` at
/// `path`, in a process group of its own, its standard input to be fed the model.
pub fn spawn(path: &Path, model_hash: u64, opts: &AccelOptions) -> std::io::Result<Child> {
    use std::os::unix::process::CommandExt;
    let kind = match opts.kind {
        AccelKind::Bvh => "bvh",
        _ => "auto",
    };
    Command::new(std::env::current_exe()?)
        .arg("prepare-scene")
        .arg("--out")
        .arg(path)
        .arg("--model-hash")
        .arg(format!("{model_hash:016x}"))
        .arg("--accel")
        .arg(kind)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .process_group(0)
        .spawn()
}

/// Bounds this process (a keeper) to [`KEEPER_LIMIT`]: SIGALRM ends it then.
pub fn bound_time() {
    // SAFETY: alarm only arms this process's timer; SIGALRM's default action ends it.
    unsafe {
        libc::alarm(KEEPER_LIMIT.as_secs() as libc::c_uint);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small tetra's model (its world, bytes and hash), a folder for its prepared file,
    /// the default accelerator options, and that file's path.
    struct Fixture {
        world: yari::model::World,
        bytes: Vec<u8>,
        hash: u64,
        dir: tempfile::TempDir,
        opts: AccelOptions,
        path: std::path::PathBuf,
    }

    fn fixture() -> Fixture {
        let world = crate::bench::spd_world(yari::spd::Database::Tetra, 2).unwrap();
        let bytes = yari::modelfile::to_bytes(&world).unwrap();
        let hash = yari::modelfile::fnv1a(&bytes);
        let dir = tempfile::tempdir().unwrap();
        let opts = AccelOptions::default();
        let path = super::super::path_of(dir.path(), hash, &opts).unwrap();
        Fixture {
            world,
            bytes,
            hash,
            dir,
            opts,
            path,
        }
    }

    #[test]
    fn a_keeper_keeps_the_model_it_reads_and_refuses_another() {
        let Fixture {
            world,
            bytes,
            hash,
            dir,
            opts,
            path,
        } = fixture();
        let cached = keep_model(&mut &bytes[..], &path, hash, &opts, Some(dir.path())).unwrap();
        assert!(!cached);
        let (scene, _) = super::super::load(&path, hash).unwrap().unwrap();
        assert_eq!(scene.prims.len(), Scene::new(world).prims.len());
        // Again: the BVH comes from the host's cache.
        assert!(keep_model(&mut &bytes[..], &path, hash, &opts, Some(dir.path())).unwrap());
        let other = dir.path().join("other");
        let wrong = keep_model(&mut &bytes[..], &other, hash ^ 1, &opts, None);
        assert!(matches!(wrong, Err(KeeperError::Hash)), "{wrong:?}");
        assert!(!other.exists());
        let cut = keep_model(&mut &bytes[..100], &other, hash, &opts, None);
        assert!(matches!(cut, Err(KeeperError::Model(_))), "{cut:?}");
    }

    /// An input that must not be read.
    struct Untouched(std::sync::Arc<std::sync::atomic::AtomicBool>);

    impl Read for Untouched {
        fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
            self.0.store(true, std::sync::atomic::Ordering::SeqCst);
            Ok(0)
        }
    }

    #[test]
    fn a_second_keeper_waits_its_turn_and_keeps_nothing_when_the_file_is_kept() {
        let Fixture {
            bytes,
            hash,
            dir: _dir,
            opts,
            path,
            ..
        } = fixture();
        keep_model(&mut &bytes[..], &path, hash, &opts, None).unwrap();
        let turn = KeepLock::take(&path).unwrap();
        let read = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let second = {
            let (path, read) = (path.clone(), read.clone());
            std::thread::spawn(move || {
                keep_model(&mut Untouched(read), &path, hash, &opts, None).unwrap()
            })
        };
        drop(turn);
        assert!(second.join().unwrap(), "the kept file serves");
        assert!(!read.load(std::sync::atomic::Ordering::SeqCst));
        // A damaged file is kept anew by the next keeper.
        std::fs::write(&path, b"damaged").unwrap();
        keep_model(&mut &bytes[..], &path, hash, &opts, None).unwrap();
        assert!(super::super::load(&path, hash).unwrap().is_some());
    }
}
