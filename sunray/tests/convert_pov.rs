//! `sunray convert SCENE -o OUT.pov` writes POV-Ray SDL for any scene format (here NFF).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::process::Command;

#[test]
fn nff_converts_to_pov() {
    let dir = std::env::temp_dir().join(format!("sunray-convert-pov-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let nff = dir.join("s.nff");
    std::fs::write(
        &nff,
        "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 0.01\nresolution 64 48\n\
         b 0.1 0.2 0.3\nl 1 2 3\nf 1 0 0 0.7 0.3 20 0 1\ns 0 0 0 1\np 3\n0 0 0\n1 0 0\n0 1 0\n",
    )
    .unwrap();
    let out = dir.join("s.pov");
    let status = Command::new(env!("CARGO_BIN_EXE_sunray"))
        .args([
            "convert",
            nff.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .status()
        .unwrap();
    assert!(status.success());
    let text = std::fs::read_to_string(&out).unwrap();
    for want in [
        "#version 3.7;",
        "render with +W64 +H48",
        "camera { perspective location <0, 0, 5>",
        "light_source { <1, 2, 3>",
        "sphere { <0, 0, 0>, 1 texture",
        "mesh {",
    ] {
        assert!(text.contains(want), "missing {want:?}:\n{text}");
    }
    // A scene that does not load writes nothing and fails.
    let bad = dir.join("bad.nff");
    std::fs::write(&bad, "s 0 0\n").unwrap();
    let bad_out = dir.join("bad.pov");
    let status = Command::new(env!("CARGO_BIN_EXE_sunray"))
        .args([
            "convert",
            bad.to_str().unwrap(),
            "-o",
            bad_out.to_str().unwrap(),
        ])
        .status()
        .unwrap();
    assert!(!status.success());
    assert!(!bad_out.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}
