//! The tutorial in docs/modeler.md works as written and builds the same king as the example
//! script examples/modeler/king.modeler.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

fn repo() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

/// The `modeler ...` commands of the tutorial's shell blocks, continuations joined, as
/// script lines (without `modeler`); commands naming another project are left out.
fn tutorial_commands() -> Vec<String> {
    let doc = std::fs::read_to_string(repo().join("docs/modeler.md")).unwrap();
    let start = doc.find("## Tutorial").expect("a Tutorial section");
    let end = doc.find("## Reference").expect("a Reference section");
    let mut commands = Vec::new();
    let mut in_block = false;
    let mut pending = String::new();
    for line in doc[start..end].lines() {
        if line.starts_with("```") {
            in_block = !in_block && line == "```sh";
            continue;
        }
        if !in_block {
            continue;
        }
        pending.push_str(line.trim_end().trim_end_matches('\\'));
        pending.push(' ');
        if line.trim_end().ends_with('\\') {
            continue;
        }
        let cmd = std::mem::take(&mut pending);
        if let Some(rest) = cmd.trim().strip_prefix("modeler ") {
            if !rest.starts_with("-p ") {
                commands.push(rest.to_string());
            }
        }
    }
    commands
}

fn run(dir: &Path, args: &[&str], stdin: &str) -> String {
    let mut child = Command::new(env!("CARGO_BIN_EXE_modeler"))
        .current_dir(dir)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(stdin.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "modeler {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn the_tutorial_builds_the_example_king() {
    let commands = tutorial_commands();
    assert!(commands.len() > 15, "{commands:?}");
    let dir = tempfile::tempdir().unwrap();
    run(
        dir.path(),
        &["-p", "tutorial.json", "script", "-"],
        &commands.join("\n"),
    );
    // The tutorial's previews and export were written where it said.
    for file in ["profile.png", "king-preview.png", "king.yari"] {
        assert!(dir.path().join(file).exists(), "{file}");
    }
    let script = repo().join("examples/modeler/king.modeler");
    run(
        dir.path(),
        &["-p", "script.json", "script", script.to_str().unwrap()],
        "",
    );
    let from_tutorial = run(dir.path(), &["-p", "tutorial.json", "export"], "");
    let from_script = run(dir.path(), &["-p", "script.json", "export"], "");
    assert_eq!(from_tutorial, from_script);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("king.yari")).unwrap(),
        from_tutorial
    );
}
