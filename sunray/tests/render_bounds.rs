//! Render settings out of bounds from a user (flags or scene) are refused by `sunray render`
//! and `sunray submit` with a one-line error and exit code 1, before anything is allocated or
//! started: no abort, no panic, no image.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn sunray() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_sunray"));
    c.env_remove("REM_ADDR")
        .env_remove("REM_SECRET")
        .env_remove("REM_SECRET_FILE");
    c
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("sunray-bounds-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `sunray SUBCOMMAND ARGS -o DIR/out.png` (the built-in scene unless ARGS name one).
fn run(dir: &Path, subcommand: &str, args: &[&str]) -> Output {
    sunray()
        .args([subcommand, "-q"])
        .args(args)
        .arg("-o")
        .arg(dir.join("out.png"))
        .output()
        .unwrap()
}

/// Exit code 1 (not a signal), one line on stderr naming every word of `words`, no panic and
/// no image.
fn assert_refused(dir: &Path, out: &Output, words: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{:?}: {err}", out.status);
    assert_eq!(err.lines().count(), 1, "not one line: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for w in words {
        assert!(err.contains(w), "{w:?} not in {err}");
    }
    assert!(!dir.join("out.png").exists());
}

#[test]
fn render_refuses_a_width_of_u32_max_with_one_line() {
    let d = tmp("width");
    let out = run(&d, "render", &["--resolution", "4294967295x16"]);
    assert_refused(
        &d,
        &out,
        &["sunray: error:", "width", "4294967295", "1..=16384"],
    );
    let out = run(&d, "render", &["--resolution", "16x16385"]);
    assert_refused(&d, &out, &["height", "16385", "1..=16384"]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn render_refuses_every_flag_out_of_bounds() {
    let d = tmp("flags");
    for (args, words) in [
        (
            &["--samples", "4294967295"][..],
            &["samples", "4294967295"][..],
        ),
        (
            &["--depth", "1000000000"],
            &["max_depth", "1000000000", "1..=64"],
        ),
        (&["--depth", "65"], &["max_depth", "65", "1..=64"]),
        (&["--min-weight=-1"], &["min_weight", "-1", "[0, 1]"]),
        (&["--min-weight", "NaN"], &["min_weight", "NaN"]),
        (
            &["--max-per-voxel", "1048577"],
            &["max_per_voxel", "1048577"],
        ),
        (
            &["--max-depth", "13"],
            &["octree_max_depth", "13", "0..=12"],
        ),
        (
            &["--resolution", "16384x16384"],
            &["16384 x 16384", "268435456 pixels", "134217728"],
        ),
    ] {
        let out = run(&d, "render", args);
        assert_refused(&d, &out, words);
    }
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn render_refuses_a_scene_asking_for_too_large_an_image() {
    let d = tmp("scene");
    // The thesis's tetrahedron, 20000 pixels wide (yari itself takes up to 65536).
    let thesis = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/thesis/tetra16.yari");
    let text = std::fs::read_to_string(thesis).unwrap();
    assert!(text.contains("resolution(512,512);"));
    let scene = d.join("huge.yari");
    std::fs::write(
        &scene,
        text.replace("resolution(512,512);", "resolution(20000,16);"),
    )
    .unwrap();
    let out = run(&d, "render", &[scene.to_str().unwrap()]);
    assert_refused(&d, &out, &["width", "20000", "1..=16384"]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn submit_refuses_settings_out_of_bounds_before_starting_anything() {
    let d = tmp("submit");
    // No remd is configured: without the check, submit would start a private one and a worker.
    let out = run(&d, "submit", &["--resolution", "4294967295x16"]);
    assert_refused(&d, &out, &["width", "4294967295", "1..=16384"]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn edge_values_are_rendered() {
    let d = tmp("edges");
    let out = run(
        &d,
        "render",
        &[
            "--resolution",
            "4x2",
            "--depth",
            "64",
            "--min-weight",
            "0",
            "--max-depth",
            "12",
            "--max-per-voxel",
            "1",
            "--accel",
            "octree",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(d.join("out.png").exists());
    std::fs::remove_dir_all(&d).unwrap();
}
