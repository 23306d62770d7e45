//! Scenes the tests render, all from the repository: Haines's SPD scenes written by our
//! generators (yari's reference tests check them against the SHA-256 of Haines's own files),
//! the thesis's printed examples and the built-in example scene.

use std::path::PathBuf;
use std::sync::OnceLock;

/// A folder holding `tetra6.nff`, `mount6.nff` and `balls4.nff`, written once per test
/// process under target/<profile>/e2e-fixtures.
pub fn spd_dir() -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = super::bins::bin_dir().join("e2e-fixtures/spd");
        yari::spd::write_reference_files(&dir).unwrap();
        dir
    })
    .clone()
}

/// Haines's SPD scene `NAME` (`tetra6`, `mount6` or `balls4`) as an NFF file.
pub fn spd(name: &str) -> PathBuf {
    spd_dir().join(format!("{name}.nff"))
}

/// Haines's tetra at `size` (4^size triangles) as `tetraSIZE.nff` beside [`spd`]'s files
/// (so the compose cluster sees it at `/scenes`), written once per run.
pub fn spd_tetra(size: u32) -> PathBuf {
    let path = spd_dir().join(format!("tetra{size}.nff"));
    if !path.exists() {
        let scene = yari::spd::generate(yari::spd::Database::Tetra, size).unwrap();
        let tmp = path.with_extension(format!("tmp-{}", std::process::id()));
        std::fs::write(&tmp, yari::nff::write::write(&scene)).unwrap();
        std::fs::rename(&tmp, &path).unwrap();
    }
    path
}

/// The built-in example scene's source.
pub fn default_scene() -> PathBuf {
    super::bins::workspace().join("sunray/src/scene/default_scene.yari")
}

/// `examples/thesis/NAME` (`tetra16.yari` or `cubes.yari`).
pub fn thesis(name: &str) -> PathBuf {
    super::bins::workspace().join("examples/thesis").join(name)
}
