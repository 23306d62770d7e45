//! Built accelerators kept on the host, so that each host builds one once per scene: a
//! worker looks for the BVH of its scene in the host's process cache (the folder REM gives
//! every process, `REM_CACHE_DIR`), reads it if it is there and passes the checks of
//! [`super::bvh::file`], and otherwise builds it and leaves it there for the next worker or
//! job. The key is the model's hash and primitive count; only the BVH is kept (the octree
//! is for the thesis's comparisons, and the exhaustive list costs nothing to build).
//!
//! A cache that cannot be written (a full disk) costs a warning, never the render.

use super::bvh::Bvh;
use super::{Accel, AccelKind, AccelOptions, Structure};
use crate::geometry::Primitives;
use std::path::{Path, PathBuf};

/// How an accelerator was had.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Provenance {
    /// Read from the host's cache rather than built.
    pub cached: bool,
    /// Why the cache could not be used or written, for a warning.
    pub warning: Option<String>,
}

/// The suffix of every file the host's caches keep (this BVH's, and the prepared scenes of
/// [`crate::prepared`]): it names how the primitives were made, `.v2` since polygons are cut
/// shortest ear first ([`yari::polygon`]). A `.v1` file holds the triangles cut before and is
/// never read.
pub const FILE_SUFFIX: &str = ".v2";

/// The file of the BVH of the model with `model_hash` and `prims` primitives in `dir`.
fn path_of(dir: &Path, model_hash: u64, prims: usize) -> PathBuf {
    dir.join(format!("sunray-bvh-{model_hash:016x}-{prims}{FILE_SUFFIX}"))
}

/// The accelerator of `prims` (a model with hash `model_hash`) as `opts` asks, from the cache
/// folder `dir` when it holds a good one, else built (and, being a BVH, stored there).
pub fn build_or_load(
    prims: &mut Primitives,
    opts: &AccelOptions,
    model_hash: u64,
    dir: Option<&Path>,
) -> (Accel, Provenance) {
    let bounded = prims.len() - prims.unbounded_count();
    let (Some(dir), AccelKind::Bvh) = (dir, opts.kind.resolve(bounded)) else {
        return (Accel::build(prims, opts), Provenance::default());
    };
    let path = path_of(dir, model_hash, prims.len());
    let mut provenance = Provenance::default();
    match std::fs::read(&path) {
        Ok(bytes) => match Bvh::from_bytes(&bytes, prims) {
            Ok(bvh) => {
                // Touched, so the host's trimming keeps what is used.
                let _ = std::fs::File::options()
                    .write(true)
                    .open(&path)
                    .and_then(|f| f.set_modified(std::time::SystemTime::now()));
                provenance.cached = true;
                return (Accel::of_bvh(prims, bvh), provenance);
            }
            Err(e) => provenance.warning = Some(format!("{}: {e}; built anew", path.display())),
        },
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => provenance.warning = Some(format!("{}: {e}", path.display())),
    }
    let bvh = Bvh::build(prims);
    // Written under a temporary name, then renamed: a full disk leaves no half file.
    if let Err(e) = crate::film::write_atomically(&path, &bvh.to_bytes(prims)) {
        provenance.warning = Some(format!("cannot keep the built BVH: {e}"));
    }
    (Accel::of_bvh(prims, bvh), provenance)
}

impl Accel {
    /// The accelerator made of a BVH of `prims`.
    pub fn of_bvh(prims: &Primitives, bvh: Bvh) -> Accel {
        Accel {
            kind: AccelKind::Bvh,
            structure: Structure::Bvh(bvh),
            unbounded: prims.unbounded(),
        }
    }

    /// The BVH, when the accelerator is one.
    pub fn bvh(&self) -> Option<&Bvh> {
        match &self.structure {
            Structure::Bvh(bvh) => Some(bvh),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prims() -> Primitives {
        let w = crate::bench::spd_world(yari::spd::Database::Tetra, 3).unwrap();
        crate::scene::Scene::new(w).prims
    }

    #[test]
    fn the_second_worker_reads_what_the_first_built() {
        let dir = tempfile::tempdir().unwrap();
        let opts = AccelOptions::default();
        let (a, first) = build_or_load(&mut prims(), &opts, 7, Some(dir.path()));
        assert_eq!(first, Provenance::default());
        let (b, second) = build_or_load(&mut prims(), &opts, 7, Some(dir.path()));
        assert!(second.cached && second.warning.is_none(), "{second:?}");
        assert_eq!((a.kind, a.node_count()), (b.kind, b.node_count()));
        // Another model, another file; a damaged file is rebuilt, with a warning.
        let (_, other) = build_or_load(&mut prims(), &opts, 8, Some(dir.path()));
        assert!(!other.cached);
        let path = path_of(dir.path(), 7, prims().len());
        std::fs::write(&path, b"SUNRAYB1 garbage").unwrap();
        let (_, damaged) = build_or_load(&mut prims(), &opts, 7, Some(dir.path()));
        assert!(!damaged.cached && damaged.warning.is_some(), "{damaged:?}");
        let (_, again) = build_or_load(&mut prims(), &opts, 7, Some(dir.path()));
        assert!(again.cached, "the rebuilt BVH replaced the damaged file");
        // The octree is built every time.
        let octree = AccelOptions {
            kind: AccelKind::Octree,
            ..opts
        };
        let (_, o) = build_or_load(&mut prims(), &octree, 7, Some(dir.path()));
        assert!(!o.cached);
    }

    #[test]
    fn a_cache_that_cannot_be_written_is_a_warning() {
        let (accel, p) = build_or_load(
            &mut prims(),
            &AccelOptions::default(),
            7,
            Some(Path::new("/nonexistent/cache")),
        );
        assert!(!p.cached && p.warning.is_some());
        assert_eq!(accel.kind, AccelKind::Bvh);
    }
}
