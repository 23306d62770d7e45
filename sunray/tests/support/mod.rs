//! Fixtures the sunray integration tests share, all from the repository: the thesis's two
//! printed examples (`examples/thesis/`) and Haines's SPD scenes, written by our generators
//! (yari's reference tests check that text against the SHA-256 of Haines's own files).
#![allow(dead_code)]

use std::path::PathBuf;
use std::sync::OnceLock;

/// `examples/thesis/NAME` (`tetra16.yari` or `cubes.yari`).
pub fn thesis(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../examples/thesis")
        .join(name)
}

/// Haines's SPD file `NAME` (`tetra6.nff`, `mount6.nff` or `balls4.nff`), generated once per
/// test process under cargo's target/tmp.
pub fn spd_file(name: &str) -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    let dir = DIR.get_or_init(|| {
        let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("spd");
        yari::spd::write_reference_files(&dir).unwrap();
        dir
    });
    dir.join(name)
}
