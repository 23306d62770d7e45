//! A scene file's stamp: what the file system says of it (device, inode, size, modification
//! and change times to the nanosecond), with the colour file's and this build's. A stamp seen
//! before names the [`SceneKey`] its bytes hashed to, so a file unchanged since is not read
//! again: the trust git's index and make put in a file's times. A write changes the change
//! time, which no program can set back. A file changed within the last [`SETTLE`] is not
//! stamped: on a file system whose times are coarse, a second write within the same tick
//! would leave its times as they were (git's "racily clean" files).

use super::{this_build, SceneKey, ShippedScenes};
use sha2::{Digest, Sha256};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// How long a file must have been left alone before its stamp names its key.
pub const SETTLE: Duration = Duration::from_secs(2);

/// Most stamps kept; the least recently used go first.
const MAX_STAMPS: usize = 256;

/// The stamp of the scene file at `scene` and of the colour file `colours`, with this build,
/// and whether both have been left alone for `settle`.
fn stamp_of(
    scene: &Path,
    colours: Option<&Path>,
    settle: Duration,
) -> std::io::Result<(String, bool)> {
    let mut h = Sha256::new();
    h.update(b"sunray scene stamp 1\0");
    h.update(this_build()?);
    let mut settled = true;
    for (what, path) in [("scene", Some(scene)), ("colours", colours)] {
        let Some(path) = path else { continue };
        let m = std::fs::metadata(path)?;
        let absolute = std::path::absolute(path)?;
        h.update(format!(
            "\0{what} {} {} {} {} {} {}.{} {}.{}\0",
            absolute.display(),
            m.dev(),
            m.ino(),
            m.len(),
            m.mode(),
            m.mtime(),
            m.mtime_nsec(),
            m.ctime(),
            m.ctime_nsec()
        ));
        let changed = [(m.mtime(), m.mtime_nsec()), (m.ctime(), m.ctime_nsec())]
            .map(|(s, ns)| {
                SystemTime::UNIX_EPOCH
                    + Duration::from_secs(s.max(0) as u64)
                    + Duration::from_nanos(ns.max(0) as u64)
            })
            .into_iter()
            .max()
            .unwrap_or(SystemTime::UNIX_EPOCH);
        settled &= SystemTime::now()
            .duration_since(changed)
            .is_ok_and(|d| d >= settle);
    }
    let digest = h.finalize();
    Ok((digest.iter().map(|b| format!("{b:02x}")).collect(), settled))
}

impl ShippedScenes {
    fn stamp_path(&self, stamp: &str) -> PathBuf {
        self.dir.join("stamps").join(stamp)
    }

    /// The key of the scene file at `scene` with the colour file `colours`: named by the
    /// files' stamp when they are unchanged since it was kept, else hashed (and the stamp
    /// kept, once the files have been left alone for [`SETTLE`]).
    pub fn key_of(&self, scene: &Path, colours: Option<&Path>) -> std::io::Result<SceneKey> {
        self.key_after(scene, colours, SETTLE)
    }

    /// [`key_of`](Self::key_of), stamping files left alone for `settle`.
    pub(super) fn key_after(
        &self,
        scene: &Path,
        colours: Option<&Path>,
        settle: Duration,
    ) -> std::io::Result<SceneKey> {
        let (stamp, settled) = stamp_of(scene, colours, settle)?;
        let path = self.stamp_path(&stamp);
        if let Ok(key) = std::fs::read_to_string(&path) {
            if key.len() == 64 && key.bytes().all(|b| b.is_ascii_hexdigit()) {
                if let Ok(f) = std::fs::File::options().append(true).open(&path) {
                    let _ = f.set_modified(SystemTime::now());
                }
                return Ok(SceneKey(key));
            }
        }
        let key = SceneKey::of(scene, colours)?;
        if settled {
            // A stamp is a shortcut: one that cannot be written costs a hash next time.
            let stamps = self.dir.join("stamps");
            if std::fs::create_dir_all(&stamps).is_ok()
                && crate::film::write_atomically(&path, key.0.as_bytes()).is_ok()
            {
                super::prune(&stamps, "", MAX_STAMPS);
            }
        }
        Ok(key)
    }
}
