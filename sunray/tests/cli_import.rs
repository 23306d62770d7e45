//! End-to-end tests of `sunray convert`, `sunray spd` and `sunray check-board`: the real binary
//! on Haines's SPD scenes.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use yari::ast::{BodyItem, Primitive, Scene};
use yari::span::Source;

fn sunray(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sunray"))
        .args(args)
        .output()
        .expect("run sunray")
}

mod support;
use support::spd_file;

#[path = "cli_import/meshes.rs"]
mod meshes;

/// A fresh scratch directory for one test.
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sunray-cli-import-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn parse_yari(path: &Path) -> Scene {
    let src = Source::new(
        path.display().to_string(),
        std::fs::read_to_string(path).unwrap(),
    );
    yari::parse::parse(&src).unwrap_or_else(|d| panic!("{}", d.render(&src)))
}

/// (spheres, polygons, quadrics) in a scene's world block (no nesting in converted scenes).
fn counts(scene: &Scene) -> (usize, usize, usize) {
    let mut c = (0, 0, 0);
    for item in &scene.body.items {
        match item.node {
            BodyItem::Primitive(Primitive::Sphere { .. }) => c.0 += 1,
            BodyItem::Primitive(Primitive::Polygon { .. }) => c.1 += 1,
            BodyItem::Primitive(Primitive::Quadric { .. }) => c.2 += 1,
            _ => {}
        }
    }
    c
}

fn assert_ok(out: &Output) {
    assert!(
        out.status.success(),
        "failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn convert_reference_scenes_to_yari() {
    let dir = scratch("convert");
    for (file, want) in [
        ("tetra6.nff", (0, 4096, 0)),
        ("mount6.nff", (4, 8192, 0)),
        ("balls4.nff", (7381, 1, 0)),
    ] {
        let out_path = dir.join(file.replace(".nff", ".yari"));
        let input = spd_file(file);
        assert_ok(&sunray(&[
            "convert",
            input.to_str().unwrap(),
            "-o",
            out_path.to_str().unwrap(),
        ]));
        assert_eq!(counts(&parse_yari(&out_path)), want, "{file}");
    }
    // Only the outputs are left: no temporary files.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 3);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
/// `sunray spd` writes the library's text (which yari's reference tests check byte for byte
/// against the SHA-256 of Haines's own files).
fn spd_nff_output_equals_haines_files() {
    let dir = scratch("spd-nff");
    for (db, size, file) in [
        ("tetra", "6", "tetra6.nff"),
        ("mount", "6", "mount6.nff"),
        ("balls", "4", "balls4.nff"),
    ] {
        let out_path = dir.join(file);
        assert_ok(&sunray(&[
            "spd",
            db,
            "--size",
            size,
            "-o",
            out_path.to_str().unwrap(),
        ]));
        let got = std::fs::read_to_string(&out_path).unwrap();
        let want = std::fs::read_to_string(spd_file(file)).unwrap();
        assert!(got == want, "{file}: sunray spd differs from the generator");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `sunray spd --patches` writes the library's patches text (Haines's `-t` output, which
/// yari's reference tests check byte for byte); `--patch-resolution` needs `--patches`, and
/// patches past the limit are refused.
#[test]
fn spd_patches_writes_the_patches_text() {
    use yari::spd::{generate_with, CurveFormat, Database};
    let dir = scratch("spd-patches");
    let out_path = dir.join("jacks.nff");
    let out = out_path.to_str().unwrap();
    assert_ok(&sunray(&["spd", "jacks", "--patches", "-o", out]));
    let want = yari::nff::write(&generate_with(Database::Jacks, 1, CurveFormat::PATCHES).unwrap());
    assert!(std::fs::read_to_string(&out_path).unwrap() == want);
    assert!(want.contains("pp 3\n") && !want.contains("\ns ") && !want.contains("\nc "));
    let args = [
        "spd",
        "shells",
        "-s",
        "1",
        "--patches",
        "--patch-resolution",
        "2",
    ];
    assert_ok(&sunray(&[&args[..], &["-o", out]].concat()));
    let format = CurveFormat::Patches {
        resolution: Some(2),
    };
    let want = yari::nff::write(&generate_with(Database::Shells, 1, format).unwrap());
    assert!(std::fs::read_to_string(&out_path).unwrap() == want);
    let bad = sunray(&["spd", "shells", "--patch-resolution", "2", "-o", out]);
    assert!(!bad.status.success());
    let bad = sunray(&["spd", "balls", "--size", "5", "--patches", "-o", out]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("7174441 polygons"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn spd_yari_output_parses_with_the_right_counts() {
    let dir = scratch("spd-yari");
    for (db, want) in [
        ("tetra", (0, 4096, 0)),
        ("mount", (4, 8192, 0)),
        ("balls", (7381, 1, 0)),
    ] {
        let out_path = dir.join(format!("{db}.yari"));
        assert_ok(&sunray(&["spd", db, "-o", out_path.to_str().unwrap()]));
        assert_eq!(counts(&parse_yari(&out_path)), want, "{db}");
    }
    // Default output is YARI on stdout; sizes change the counts.
    let out = sunray(&["spd", "tetra", "--size", "2"]);
    assert_ok(&out);
    let src = Source::new("stdout", String::from_utf8(out.stdout).unwrap());
    assert_eq!(counts(&yari::parse::parse(&src).unwrap()), (0, 16, 0));
    let bad = sunray(&["spd", "mount", "--size", "9"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("out of range"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn convert_bad_nff_reports_and_writes_nothing() {
    let dir = scratch("bad");
    let input = dir.join("bad.nff");
    std::fs::write(&input, "b 0 0 0\ns 0 0 0 1\np 3\n0 0 0\n1 zero 0\n0 1 0\n").unwrap();
    let output = dir.join("bad.yari");
    let out = sunray(&[
        "convert",
        input.to_str().unwrap(),
        "-o",
        output.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("bad.nff:5:3: error: expected the y coordinate of vertex 2, found `zero`"),
        "{stderr}"
    );
    assert!(!output.exists(), "output written despite errors");
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        1,
        "stray files left"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn convert_off_and_refuse_unknown_formats() {
    let dir = scratch("off");
    let input = dir.join("tri.off");
    std::fs::write(
        &input,
        "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3 0.2 0.4 0.6\n",
    )
    .unwrap();
    let output = dir.join("tri.yari");
    assert_ok(&sunray(&[
        "convert",
        input.to_str().unwrap(),
        "-o",
        output.to_str().unwrap(),
    ]));
    assert_eq!(counts(&parse_yari(&output)), (0, 2, 0));

    let bad_index = dir.join("bad.off");
    std::fs::write(&bad_index, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n").unwrap();
    let out = sunray(&["convert", bad_index.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr)
        .contains("bad.off:6:7: error: vertex index 3 is out of range"));
    assert!(out.stdout.is_empty());

    let unknown = dir.join("scene.stl");
    std::fs::write(&unknown, "solid x\n").unwrap();
    let out = sunray(&["convert", unknown.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--from"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn check_board_writes_a_board() {
    let dir = scratch("board");
    let output = dir.join("board.yari");
    let args = [
        "check-board",
        "--squares",
        "4,3",
        "--colors",
        "1,0,0",
        "0,0,1",
        "--rotate",
        "-90,0,0",
        "-o",
    ];
    let mut args = args.to_vec();
    args.push(output.to_str().unwrap());
    assert_ok(&sunray(&args));
    let scene = parse_yari(&output);
    assert_eq!(counts(&scene), (0, 12, 0));
    assert!(
        !scene.view.is_empty(),
        "the default board comes with a view"
    );

    let nff = dir.join("board.nff");
    assert_ok(&sunray(&[
        "check-board",
        "--no-view",
        "-o",
        nff.to_str().unwrap(),
    ]));
    let text = std::fs::read_to_string(&nff).unwrap();
    assert_eq!(
        text.matches("\np 4\n").count() + usize::from(text.starts_with("p 4\n")),
        64
    );
    assert!(!text.contains("\nv\n") && !text.starts_with("b "));

    let named = dir.join("named.nff");
    assert_ok(&sunray(&[
        "check-board",
        "--no-view",
        "--colors",
        "UNC_Blue",
        "white",
        "-o",
        named.to_str().unwrap(),
    ]));
    assert!(std::fs::read_to_string(&named)
        .unwrap()
        .starts_with("f 0.078 0.361 0.753 1 0 100000 0 1\n"));

    let bad = sunray(&["check-board", "--squares", "0"]);
    assert!(!bad.status.success());
    let bad = sunray(&["check-board", "--colors", "whte", "black"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("unknown colour `whte`"));
    std::fs::remove_dir_all(&dir).unwrap();
}
