//! The workspace's binaries as the tests run them: this build's `sunray` and `remd` (built
//! on first use, as this package cannot name another package's binaries).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The workspace root.
pub fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// target/<profile>, where cargo puts this build's binaries.
pub fn bin_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/<test> -> target/<profile>
    exe.parent()
        .and_then(Path::parent)
        .expect("target dir")
        .to_path_buf()
}

/// Builds `sunray` and `remd` once per test binary and returns their folder. It builds them
/// as `cargo test --workspace` does, so after the README's test command it is a no-op:
/// with the tests (dev-dependencies unify features, so a plain `cargo build` of the two
/// packages compiles them again, differently), and without the variables cargo gave this
/// test (build scripts such as ring's rerun when CARGO_PKG_NAME or CARGO_MANIFEST_DIR
/// change, and everything above them is compiled again).
pub fn ensure_built() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = bin_dir();
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| env!("CARGO").to_string());
        let target = dir.parent().expect("target root").to_path_buf();
        let mut cmd = Command::new(cargo);
        cmd.args(["build", "--quiet", "--workspace", "--bins", "--tests"])
            .arg("--target-dir")
            .arg(&target)
            .current_dir(workspace());
        for (key, _) in std::env::vars_os() {
            let k = key.to_string_lossy();
            let per_crate = ["CARGO_PKG_", "CARGO_MANIFEST_", "CARGO_BIN_", "CARGO_CFG_"]
                .iter()
                .any(|p| k.starts_with(p))
                || [
                    "CARGO_CRATE_NAME",
                    "CARGO_PRIMARY_PACKAGE",
                    "CARGO_TARGET_TMPDIR",
                    "OUT_DIR",
                ]
                .contains(&k.as_ref());
            if per_crate {
                cmd.env_remove(&key);
            }
        }
        if dir.file_name().is_some_and(|n| n == "release") {
            cmd.arg("--release");
        }
        let st = cmd.status().expect("run cargo build");
        assert!(st.success(), "building sunray and remd failed");
        dir
    })
}

/// This build's `sunray`.
pub fn sunray_bin() -> PathBuf {
    ensure_built().join("sunray")
}

/// This build's `remd`.
pub fn remd_bin() -> PathBuf {
    ensure_built().join("remd")
}

/// This build's `rem`.
pub fn rem_bin() -> PathBuf {
    ensure_built().join("rem")
}

/// `sunray` with no REM configuration from the environment, and the tests' own cache of
/// scenes shipped before (not the user's `~/.cache/sunray`).
pub fn sunray() -> Command {
    let mut c = Command::new(sunray_bin());
    c.env_remove("REM_ADDR")
        .env_remove("REM_SECRET")
        .env_remove("REM_SECRET_FILE")
        .env("SUNRAY_CACHE_DIR", bin_dir().join("e2e-sunray-cache"));
    c
}

/// Sends signal `sig` to process `pid`.
pub fn signal(pid: i32, sig: i32) {
    // SAFETY: kill(2) has no memory-safety preconditions; a stale pid is the caller's risk.
    unsafe {
        libc::kill(pid, sig);
    }
}
