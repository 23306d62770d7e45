//! End-to-end tests of `sunray check` and `sunray compile` on the real binary.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::path::PathBuf;
use std::process::{Command, Output};

mod support;
use support::thesis;

fn sunray(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_sunray"));
    cmd.args(args).env_remove("YARI_COLORS");
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("run sunray")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        let p = std::env::temp_dir().join(format!("sunray-cli-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }
    fn file(&self, name: &str, contents: &str) -> String {
        let p = self.0.join(name);
        std::fs::write(&p, contents).unwrap();
        p.display().to_string()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
fn check_summarises_the_thesis_scenes() {
    let tetra = thesis("tetra16.yari");
    let out = sunray(&["check", tetra.to_str().unwrap()], &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(
        text(&out.stdout),
        "tetra16.yari: 16 polygons, 1 light, 512x512\n"
    );
    assert_eq!(text(&out.stderr), "");
    let cubes = thesis("cubes.yari");
    let out = sunray(&["check", cubes.to_str().unwrap()], &[]);
    assert!(out.status.success());
    assert_eq!(
        text(&out.stdout),
        "cubes.yari: 19 polygons + 7 spheres, 2 lights, 512x512; uses reflection, textures\n"
    );
}

#[test]
fn check_reports_errors_with_carets_and_fails() {
    let dir = TempDir::new("bad");
    let bad = dir.file(
        "bad.yari",
        "begin\n  sphre(center=0,0,0; radius=1);\n  polygon(vertices=4; 0,0,0 1,0,0 0,1,0);\nend\n",
    );
    let out = sunray(&["check", &bad], &[]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(text(&out.stdout), "");
    let err = text(&out.stderr);
    assert!(err.contains("bad.yari:2:3: error: unknown command `sphre`\n    sphre(center=0,0,0; radius=1);\n    ^~~~~\n"), "{err}");
    assert!(
        err.contains("bad.yari:3:20: error: polygon declares 4 vertices but lists 3"),
        "{err}"
    );
    let out = sunray(
        &["check", &dir.0.join("missing.yari").display().to_string()],
        &[],
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("cannot read"));
}

#[test]
fn check_prints_warnings_and_still_succeeds() {
    let dir = TempDir::new("warn");
    let scene = dir.file("w.yari", "begin\n  polygon(vertices=3; 0,0,0 1,1,1 2,2,2);\n  sphere(center=0,0,0; radius=1);\nend\n");
    let out = sunray(&["check", &scene], &[]);
    assert!(out.status.success());
    let err = text(&out.stderr);
    assert!(
        err.contains("w.yari:2:3: warning: degenerate polygon dropped: it has no area"),
        "{err}"
    );
    assert!(err.contains("warning: no `camera`"), "{err}");
    assert_eq!(text(&out.stdout), "w.yari: 1 sphere, 0 lights, 512x512\n");
}

#[test]
fn colour_file_from_flag_or_environment() {
    let dir = TempDir::new("colours");
    let scene = dir.file(
        "c.yari",
        "resolution(4,4); camera(position=0,0,5; at=0,0,0; up=0,1,0; angle=20); light(position=0,5,0; color=chalk);\nbegin sphere(center=0,0,0; radius=1); end\n",
    );
    let colours = dir.file("my.colors", "# extra\nchalk 0.9 0.9 0.85\n");
    let out = sunray(&["check", &scene], &[]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("unknown colour name `chalk`"));
    assert!(sunray(&["check", &scene, "--colors", &colours], &[])
        .status
        .success());
    assert!(
        sunray(&["check", &scene], &[("YARI_COLORS", colours.as_str())])
            .status
            .success()
    );
    let broken = dir.file("broken.colors", "chalk 0.9 oops 0.85\n");
    let out = sunray(&["check", &scene, "--colors", &broken], &[]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("broken.colors:1: error: `oops` is not a number"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn compile_writes_a_model_that_check_reads() {
    let dir = TempDir::new("compile");
    let model = dir.0.join("cubes.srw").display().to_string();
    let cubes = thesis("cubes.yari");
    let out = sunray(&["compile", cubes.to_str().unwrap(), "-o", &model], &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let bytes = std::fs::read(&model).unwrap();
    assert!(bytes.starts_with(b"SUNRAYW1"));
    let out = sunray(&["check", &model], &[]);
    assert!(out.status.success());
    assert_eq!(
        text(&out.stdout),
        "cubes.srw: 19 polygons + 7 spheres, 2 lights, 512x512; uses reflection, textures\n"
    );
    // A failed compile leaves no output file.
    let bad = dir.file("bad.yari", "begin sphere(center=0,0,0; radius=-1); end\n");
    let none = dir.0.join("none.srw");
    let out = sunray(&["compile", &bad, "-o", none.to_str().unwrap()], &[]);
    assert_eq!(out.status.code(), Some(1));
    assert!(!none.exists());
}
