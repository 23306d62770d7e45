//! Prepared scenes kept on a host, so a later worker of the same model renders at once: the
//! scene's primitives and BVH as flat tables in one file of the host's process cache
//! (`REM_CACHE_DIR`), keyed by the model's hash and the accelerator asked for. A worker
//! that finds a sealed file maps it and renders from the mapping: the corners, triangles,
//! slots, BVH nodes and leaf items are views into it ([`crate::store::Store`]), never
//! fetched through remd nor decoded; only the world (camera, lights, surfaces) and the
//! small tables are decoded from it.
//!
//! A file is written under a temporary name, renamed into place, read back and checked in
//! full (the BVH's every box and item, [`crate::accel::bvh::Bvh::check`]), and only then
//! sealed ([`checksum`]). A reader takes a file whose seal matches its length and checksum
//! and whose tables fit together; any other file is refused (the caller rebuilds it and
//! warns), never trusted. Only BVH scenes are kept; the cache's limit is kept by remd,
//! which removes the least recently used files (a reader touches what it uses).
//!
//! # Layout
//! - [`checksum`]: the file's checksum and its seal.
//! - [`layout`]: the file's bytes: header, sections, tables.
//! - [`keeper`]: the process that builds and keeps a prepared scene, which a job's end
//!   does not interrupt.

pub mod checksum;
pub mod keeper;
pub mod layout;

use crate::accel::bvh::Bvh;
use crate::accel::{Accel, AccelKind, AccelOptions};
use crate::geometry::primitive::Dropped;
use crate::geometry::primitives::parts::{Rest, Tables};
use crate::geometry::Primitives;
use crate::scene::Scene;
use layout::Section;
use std::path::{Path, PathBuf};

/// Why a prepared scene could not be kept or used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PreparedError {
    /// Reading or writing the file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What failed.
        source: std::io::Error,
    },
    /// The file is not a good prepared scene of this model (damaged, cut short, unsealed).
    #[error("{path}: {why}")]
    Refused {
        /// The file.
        path: PathBuf,
        /// Why, in words.
        why: String,
    },
}

/// Everything of a scene but its large tables, as the file keeps it.
#[derive(serde::Serialize, serde::Deserialize)]
struct SceneRest {
    objects: u64,
    dropped: Vec<Dropped>,
    prims: Rest,
}

/// The file of the prepared scene of the model with `model_hash`, accelerated as `opts`
/// asks, in `dir`; None when such scenes are not kept (an octree, the exhaustive list). Its
/// suffix is [`crate::accel::cache::FILE_SUFFIX`].
pub fn path_of(dir: &Path, model_hash: u64, opts: &AccelOptions) -> Option<PathBuf> {
    matches!(opts.kind, AccelKind::Auto | AccelKind::Bvh).then(|| {
        dir.join(format!(
            "sunray-scene-{model_hash:016x}-{}{}",
            opts.kind.name(),
            crate::accel::cache::FILE_SUFFIX
        ))
    })
}

/// The prepared scene at `path` of the model with `model_hash`, mapped; None when there is
/// none. A file that is there but not sealed or not good is an error (to warn about; the
/// caller rebuilds it).
pub fn load(path: &Path, model_hash: u64) -> Result<Option<(Scene, Accel)>, PreparedError> {
    if !path.exists() {
        return Ok(None);
    }
    let refused = |why: String| PreparedError::Refused {
        path: path.to_path_buf(),
        why,
    };
    let opened = layout::open(path).map_err(refused)?;
    let (len, sum) = opened.len_sum;
    match checksum::sealed(path, len, sum) {
        Some(true) => {}
        Some(false) => return Err(refused("its seal is for another file".into())),
        None => return Err(refused("not sealed".into())),
    }
    let loaded = from_opened(&opened, model_hash).map_err(refused)?;
    touch(path);
    touch(&checksum::seal_path(path));
    Ok(Some(loaded))
}

/// The scene and BVH in a mapped, checked file.
fn from_opened(f: &layout::Opened, model_hash: u64) -> Result<(Scene, Accel), String> {
    if f.model_hash != model_hash {
        return Err("for another model".into());
    }
    let world = yari::modelfile::from_bytes(f.bytes(Section::World)?)
        .map_err(|e| format!("its world: {e}"))?;
    let rest: SceneRest =
        postcard::from_bytes(f.bytes(Section::Rest)?).map_err(|e| format!("its rest: {e}"))?;
    let tables = Tables {
        slots: f.table(Section::Slots)?,
        vertices: f.table(Section::Vertices)?,
        triangles: f.table(Section::Triangles)?,
    };
    let prims = Primitives::from_parts(tables, rest.prims)?;
    let bvh = Bvh::from_tables(&prims, f.table(Section::Nodes)?, f.table(Section::Items)?)
        .map_err(|e| e.to_string())?;
    let accel = Accel::of_bvh(&prims, bvh);
    let scene = Scene::from_parts(world, prims, rest.objects as usize, rest.dropped);
    Ok((scene, accel))
}

/// Marks `path` used now, so the host's trimming keeps it.
fn touch(path: &Path) {
    let _ = std::fs::File::options()
        .write(true)
        .open(path)
        .and_then(|f| f.set_modified(std::time::SystemTime::now()));
}

/// Keeps `scene` and its `accel` (of the model with `model_hash`) at `path`: written,
/// renamed into place, read back and checked in full, then sealed. Nothing is kept for an
/// accelerator that is not a BVH.
pub fn keep(
    path: &Path,
    model_hash: u64,
    scene: &Scene,
    accel: &Accel,
) -> Result<(), PreparedError> {
    let Some(bvh) = accel.bvh() else {
        return Ok(());
    };
    let io = |source| PreparedError::Io {
        path: path.to_path_buf(),
        source,
    };
    let invalid = |why: String| io(std::io::Error::new(std::io::ErrorKind::InvalidData, why));
    let mut world = scene.world.clone();
    world.objects.clear();
    let world = yari::modelfile::to_bytes(&world).map_err(|e| invalid(e.to_string()))?;
    let rest = postcard::to_stdvec(&SceneRest {
        objects: scene.objects as u64,
        dropped: scene.dropped.clone(),
        prims: scene.prims.rest(),
    })
    .map_err(|e| invalid(e.to_string()))?;
    let (slots, vertices, triangles) = scene.prims.table_slices();
    let (nodes, items) = bvh.tables();
    let contents = layout::Contents {
        model_hash,
        world: &world,
        rest: &rest,
        slots,
        vertices,
        triangles,
        nodes,
        items,
    };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
    let tmp = path.with_file_name(format!(
        ".{}.tmp{}",
        name.unwrap_or_default(),
        std::process::id()
    ));
    let written = layout::write(&tmp, &contents).and_then(|_| std::fs::rename(&tmp, path));
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(io(e));
    }
    let verified = layout::open(path).and_then(|f| {
        let (scene, accel) = from_opened(&f, model_hash)?;
        let bvh = accel.bvh().ok_or("no BVH")?;
        bvh.check(&scene.prims).map_err(|e| e.to_string())?;
        Ok(f.len_sum)
    });
    match verified {
        Ok((len, sum)) => checksum::seal(path, len, sum).map_err(|e| invalid(e.to_string())),
        Err(why) => {
            let _ = std::fs::remove_file(path);
            Err(PreparedError::Refused {
                path: path.to_path_buf(),
                why: format!("written but does not read back: {why}"),
            })
        }
    }
}

#[cfg(test)]
mod tests;
