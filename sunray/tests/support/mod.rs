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
/// test process under cargo's target/tmp (written under a temporary name and renamed, so test
/// processes running at once never see half a file).
pub fn spd_file(name: &str) -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    let dir = DIR.get_or_init(|| {
        let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("spd");
        std::fs::create_dir_all(&dir).unwrap();
        for (db, size, file) in [
            (yari::spd::Database::Tetra, 6, "tetra6.nff"),
            (yari::spd::Database::Mount, 6, "mount6.nff"),
            (yari::spd::Database::Balls, 4, "balls4.nff"),
        ] {
            let text = yari::nff::write(&yari::spd::generate(db, size).unwrap());
            let tmp = dir.join(format!("{file}.{}", std::process::id()));
            std::fs::write(&tmp, text).unwrap();
            std::fs::rename(&tmp, dir.join(file)).unwrap();
        }
        dir
    });
    dir.join(name)
}
