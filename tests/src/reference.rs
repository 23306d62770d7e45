//! Reference renders and their outputs: `sunray render` of a scene (what every distributed
//! image must equal byte for byte), JSON statistics, commands run to their end.

use super::bins::sunray;
use std::path::Path;
use std::process::{Command, Output};

/// `sunray render` of `scene` with `flags` into `dir`: the PNG bytes and the stats JSON.
pub fn reference(dir: &Path, scene: &Path, flags: &[&str]) -> (Vec<u8>, serde_json::Value) {
    let stem = scene
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy());
    let out = dir.join(format!("reference-{stem}.png"));
    let json = dir.join(format!("reference-{stem}.json"));
    let st = sunray()
        .arg("render")
        .arg("-q")
        .arg(scene)
        .args(flags)
        .arg("-o")
        .arg(&out)
        .arg("--stats-json")
        .arg(&json)
        .status()
        .unwrap();
    assert!(st.success(), "sunray render {}", scene.display());
    (std::fs::read(&out).unwrap(), read_json(&json))
}

/// A JSON file.
pub fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// Runs a command to its end, printing its stderr on failure.
pub fn output(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap();
    if !out.status.success() {
        eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    }
    out
}
