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

/// Runs a command that must succeed (its stderr is the failure's message); its stdout.
pub fn succeed(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Runs a command to its end, printing its stderr on failure.
pub fn output(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap();
    if !out.status.success() {
        eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    }
    out
}

/// Per node of a job's statistics: its host and what `f` takes of the node.
fn per_node<T>(stats: &serde_json::Value, f: impl Fn(&serde_json::Value) -> T) -> Vec<(String, T)> {
    let nodes = stats["nodes"].as_array().unwrap();
    nodes
        .iter()
        .map(|n| (n["host"].as_str().unwrap().to_string(), f(n)))
        .collect()
}

/// Per node of a job's statistics: its host, the bytes of the scene it received and
/// whether its host had the whole scene cached.
pub fn scene_figures(stats: &serde_json::Value) -> Vec<(String, u64, bool)> {
    per_node(stats, |n| {
        (
            n["scene_bytes_received"].as_u64().unwrap(),
            n["scene_cached"].as_bool().unwrap(),
        )
    })
    .into_iter()
    .map(|(host, (bytes, cached))| (host, bytes, cached))
    .collect()
}

/// Per node of a job's statistics: its host and whether it read its accelerator from its
/// host's cache instead of building it.
pub fn accel_figures(stats: &serde_json::Value) -> Vec<(String, bool)> {
    per_node(stats, |n| n["accel_cached"].as_bool().unwrap())
}

/// Per node of a job's statistics: its host and whether it used its host's prepared scene,
/// mapped in place.
pub fn mapped_figures(stats: &serde_json::Value) -> Vec<(String, bool)> {
    per_node(stats, |n| n["scene_mapped"].as_bool().unwrap())
}

/// The hosts whose worker got as far as asking for work (so its accelerator was built or
/// read, and a built BVH kept): a worker still fetching or building when the image was done
/// is killed at the job's end, and keeps nothing.
pub fn prepared_hosts(stats: &serde_json::Value) -> Vec<String> {
    per_node(stats, |n| n["preprocess_s"].as_f64().unwrap() > 0.0)
        .into_iter()
        .filter_map(|(host, prepared)| prepared.then_some(host))
        .collect()
}
