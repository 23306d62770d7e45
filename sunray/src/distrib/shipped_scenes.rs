//! Scenes this user has shipped to the farm before, remembered on the submitting host, so
//! that submitting the same file again compiles nothing and sends nothing (DESIGN section
//! 10): what a farm job needs of its scene besides the model (its [summary](SceneSummary) and
//! the compiler's warnings) and the names of the model's REM chunks.
//!
//! An entry is found by a [`SceneKey`]: the SHA-256 of the scene file's bytes and of the
//! colour file that applies (`--colours` or `$YARI_COLORS`), of this program's version and of
//! this build (the executable's size and time), so a changed scene, colour table or compiler
//! never finds an old entry. Hashing a file costs far less than compiling it (SHA-256 runs at
//! 1-2 GB/s where the CPU has its instructions). An entry is used only while the local remd
//! still has every chunk it names (`CachedChunks`); else the scene is compiled and shipped as
//! for a first submit, and the entry written anew.
//!
//! The key is found without reading the file when its stamp (its inode, size and times, see
//! [`stamps`]) is the one it had when it was last hashed.
//!
//! Entries are small JSON files in `$SUNRAY_CACHE_DIR`, else `$XDG_CACHE_HOME/sunray`, else
//! `~/.cache/sunray` (folder `shipped/`), written whole or not at all; at most
//! [`MAX_ENTRIES`] are kept, the least recently used removed first. An entry that does not
//! read as one (damaged, hand-edited, of another version) is ignored, never trusted.

use crate::distrib::model_chunks::ShippedModel;
use crate::scene::summary::SceneSummary;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::io::Read;
use std::path::{Path, PathBuf};

/// Most entries kept; the least recently used go first.
pub const MAX_ENTRIES: usize = 64;

/// Most other files an entry's model may be made from (a scene that places more meshes is
/// compiled again at each submit).
pub const MAX_INPUTS: usize = 256;

/// The variable naming the folder of this user's caches.
pub const CACHE_DIR_ENV: &str = "SUNRAY_CACHE_DIR";

/// What an entry's version must be (a change of its fields changes it).
const ENTRY_VERSION: u32 = 2;

/// Which scene an entry is of: a hex SHA-256 of the inputs that make its model.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct SceneKey(String);

impl SceneKey {
    /// The key of the scene file at `scene`, compiled with the colour file `colours` (the
    /// one that applies, if any) by this build.
    pub fn of(scene: &Path, colours: Option<&Path>) -> std::io::Result<SceneKey> {
        let mut h = Sha256::new();
        h.update(format!("sunray shipped scene {ENTRY_VERSION}\0"));
        h.update(env!("CARGO_PKG_VERSION"));
        h.update(this_build()?);
        h.update(b"\0scene\0");
        hash_file(&mut h, scene)?;
        if let Some(c) = colours {
            h.update(b"\0colours\0");
            hash_file(&mut h, c)?;
        }
        let digest = h.finalize();
        Ok(SceneKey(
            digest.iter().map(|b| format!("{b:02x}")).collect(),
        ))
    }

    /// True for a key as [`SceneKey::of`] makes them: 64 hex digits.
    fn is_sound(&self) -> bool {
        self.0.len() == 64 && self.0.bytes().all(|b| b.is_ascii_hexdigit())
    }
}

/// The executable's size and modification time: another build of the compiler is another
/// key.
fn this_build() -> std::io::Result<Vec<u8>> {
    let meta = std::fs::metadata(std::env::current_exe()?)?;
    let modified = meta
        .modified()?
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    Ok(format!("\0build {} {modified}\0", meta.len()).into_bytes())
}

fn hash_file(h: &mut Sha256, path: &Path) -> std::io::Result<()> {
    let mut file = std::fs::File::open(path)?;
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = file.read(&mut buf)?;
        if n == 0 {
            return Ok(());
        }
        h.update(&buf[..n]);
    }
}

/// A file other than the scene file that a model was made from (a mesh a YARI scene
/// placed, an OBJ's material library, a glTF's buffer), with the key its bytes had.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShippedInput {
    /// The file, absolute.
    pub path: PathBuf,
    /// Its key when the model was made.
    pub key: SceneKey,
}

/// A scene shipped before: what the job needs of it, and its model's chunks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShippedScene {
    /// The entry's version ([`ENTRY_VERSION`]).
    pub version: u32,
    /// The scene's counts and own settings.
    pub summary: SceneSummary,
    /// The compiler's warnings, as printed when it was compiled.
    pub warnings: Vec<String>,
    /// The model as it was shipped (what that cost is not kept: shipped again, it sends
    /// nothing).
    pub model: ShippedModel,
    /// The other files the model was made from; the entry stands only while each has the
    /// key it had.
    pub inputs: Vec<ShippedInput>,
}

impl ShippedScene {
    /// The entry of a scene shipped as `model`, made from the scene file and `inputs`.
    pub fn new(
        summary: SceneSummary,
        warnings: Vec<String>,
        model: &ShippedModel,
        inputs: Vec<ShippedInput>,
    ) -> ShippedScene {
        ShippedScene {
            version: ENTRY_VERSION,
            summary,
            warnings,
            inputs,
            model: ShippedModel {
                bytes_sent: 0,
                ..model.clone()
            },
        }
    }

    /// True when the entry is one this build wrote: its version, chunk names REM takes, no
    /// more chunks than a model may have, and a size they can hold.
    fn is_sound(&self) -> bool {
        let (chunks, size) = (&self.model.chunks, self.model.size);
        let chunk = rem::client::blob::CHUNK_BYTES as u64;
        self.version == ENTRY_VERSION
            && self.inputs.len() <= MAX_INPUTS
            && self
                .inputs
                .iter()
                .all(|i| i.key.is_sound() && i.path.is_absolute())
            && !chunks.is_empty()
            && chunks.len() <= rem::client::blob::MAX_CHUNKS
            && chunks
                .iter()
                .all(|c| rem::wire::chunk_name::is_chunk_name(c))
            && size <= chunks.len() as u64 * chunk
            && size > (chunks.len() as u64 - 1) * chunk
    }
}

/// The folder of remembered scenes.
#[derive(Clone, Debug)]
pub struct ShippedScenes {
    dir: PathBuf,
}

impl ShippedScenes {
    /// The folder `shipped/` of `cache` (this user's cache folder).
    pub fn at(cache: &Path) -> ShippedScenes {
        ShippedScenes {
            dir: cache.join("shipped"),
        }
    }

    /// This user's: under `$SUNRAY_CACHE_DIR`, else `$XDG_CACHE_HOME/sunray`, else
    /// `$HOME/.cache/sunray`; none when none of these is set.
    pub fn for_user() -> Option<ShippedScenes> {
        let var = |k: &str| {
            std::env::var_os(k)
                .filter(|v| !v.is_empty())
                .map(PathBuf::from)
        };
        let cache = var(CACHE_DIR_ENV)
            .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("sunray")))
            .or_else(|| var("HOME").map(|d| d.join(".cache").join("sunray")))?;
        Some(ShippedScenes::at(&cache))
    }

    fn path(&self, key: &SceneKey) -> PathBuf {
        self.dir.join(format!("{}.json", key.0))
    }

    /// The entry of `key`, if one is kept and sound and every other file its model was made
    /// from is as it was (it then counts as just used).
    pub fn find(&self, key: &SceneKey) -> Option<ShippedScene> {
        let path = self.path(key);
        let bytes = std::fs::read(&path).ok()?;
        let entry: ShippedScene = serde_json::from_slice(&bytes).ok()?;
        if !entry.is_sound() {
            return None;
        }
        let unchanged = |i: &ShippedInput| self.key_of(&i.path, None).is_ok_and(|k| k == i.key);
        if !entry.inputs.iter().all(unchanged) {
            return None;
        }
        if let Ok(f) = std::fs::File::options().append(true).open(&path) {
            let _ = f.set_modified(std::time::SystemTime::now());
        }
        Some(entry)
    }

    /// Keeps `entry` as `key`'s (whole or not at all), then removes the least recently used
    /// entries beyond [`MAX_ENTRIES`].
    pub fn keep(&self, key: &SceneKey, entry: &ShippedScene) -> std::io::Result<()> {
        std::fs::create_dir_all(&self.dir)?;
        let bytes = serde_json::to_vec(entry).map_err(std::io::Error::other)?;
        crate::film::write_atomically(&self.path(key), &bytes).map_err(std::io::Error::other)?;
        self.prune(MAX_ENTRIES);
        Ok(())
    }

    /// Removes the least recently used entries beyond `keep`.
    fn prune(&self, keep: usize) {
        prune(&self.dir, ".json", keep);
    }
}

/// Removes the least recently used files of `dir` whose names end with `suffix`, beyond
/// `keep`.
fn prune(dir: &Path, suffix: &str, keep: usize) {
    let Ok(files) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<(std::time::SystemTime, PathBuf)> = files
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with(suffix))
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
        .collect();
    if entries.len() <= keep {
        return;
    }
    entries.sort();
    for (_, path) in &entries[..entries.len() - keep] {
        let _ = std::fs::remove_file(path);
    }
}

mod stamps;
#[cfg(test)]
mod tests;
