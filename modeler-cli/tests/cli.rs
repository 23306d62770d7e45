//! The `modeler` binary as a user runs it: exit codes, messages, standard input scripts.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn modeler(project: &Path, args: &[&str], stdin: Option<&str>) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_modeler"))
        .arg("-p")
        .arg(project)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut input = child.stdin.take().unwrap();
    input.write_all(stdin.unwrap_or("").as_bytes()).unwrap();
    drop(input);
    child.wait_with_output().unwrap()
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[test]
fn a_scene_built_from_standard_input_exports_as_yari_that_parses() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("scene.json");
    let script = "new\nadd sphere ball --center 0,1,0 --radius 1\n\
                  skeleton new sq --plane xz --closed -1,-1 1,-1 1,1 -1,1\n\
                  extrude slab --outline sq --by 0,-0.2,0\nsurface slab --color white --kdr 0.5\n";
    let out = modeler(&p, &["script", "-"], Some(script));
    assert!(out.status.success(), "{}", text(&out.stderr));
    let out = modeler(&p, &["export"], None);
    assert!(out.status.success());
    let yari_text = text(&out.stdout);
    assert!(
        yari_text.contains("/* ball */") && yari_text.contains("/* slab */"),
        "{yari_text}"
    );
    let scene = yari::parse::parse(&yari::span::Source::new("out", yari_text.as_str())).unwrap();
    assert_eq!(scene.body.items.len(), 2);
}

#[test]
fn a_bad_argument_exits_non_zero_names_it_and_leaves_the_project() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("scene.json");
    assert!(modeler(&p, &["new"], None).status.success());
    let before = std::fs::read(&p).unwrap();
    let out = modeler(
        &p,
        &["add", "sphere", "b", "--center", "0,0", "--radius", "1"],
        None,
    );
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert!(err.contains("--center") && err.contains("x,y,z"), "{err}");
    let out = modeler(&p, &["light", "color", "key", "no_such_colour"], None);
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("no_such_colour"));
    let out = modeler(&p, &["script", "-"], Some("background red\nscale key 2\n"));
    assert!(
        text(&out.stderr).contains("<stdin>:2:"),
        "{}",
        text(&out.stderr)
    );
    assert_eq!(std::fs::read(&p).unwrap(), before);
}

#[test]
fn help_is_available_for_commands_and_inside_scripts() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("scene.json");
    let out = modeler(&p, &["revolve", "--help"], None);
    assert!(out.status.success());
    assert!(text(&out.stdout).contains("--step"));
    assert!(modeler(&p, &["new"], None).status.success());
    let out = modeler(
        &p,
        &["script", "-"],
        Some("extrude --help\nresolution 64 48\n"),
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("--outline"));
    assert!(text(&modeler(&p, &["show"], None).stdout).contains("resolution 64x48"));
}
