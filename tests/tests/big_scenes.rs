//! Scenes larger than a REM message through the farm: the model travels as REM chunks
//! named by their hash, each host caches what it fetched, and a second job of the same
//! scene ships nothing. tetra at size 9 (262,144 triangles) compiles to about 26 MB, over
//! REM's 16 MiB message limit, on three real remd daemons.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::path::Path;
use sunray_e2e::bins::sunray;
use sunray_e2e::reference::reference;
use sunray_e2e::remd::LoopbackCluster;

const FLAGS: [&str; 2] = ["--resolution", "48x32"];

/// `sunray spd tetra --size 9` into `dir`.
fn tetra9(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("tetra9.nff");
    let st = sunray()
        .args(["spd", "tetra", "--size", "9", "-o"])
        .arg(&path)
        .status()
        .unwrap();
    assert!(st.success());
    path
}

/// Submits `scene` on three hosts through daemon a, following it; its statistics.
fn submit(cluster: &LoopbackCluster, scene: &Path, out: &Path) -> serde_json::Value {
    let json = out.with_extension("json");
    let run = cluster
        .submit()
        .args(["--hosts", "3", "-q", "-o"])
        .arg(out)
        .arg("--stats-json")
        .arg(&json)
        .args(FLAGS)
        .arg(scene)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap()
}

/// (host, bytes received, cached) of each node that started.
fn scene_figures(stats: &serde_json::Value) -> Vec<(String, u64, bool)> {
    stats["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| {
            (
                n["host"].as_str().unwrap().to_string(),
                n["scene_bytes_received"].as_u64().unwrap(),
                n["scene_cached"].as_bool().unwrap(),
            )
        })
        .collect()
}

#[test]
fn a_scene_over_the_message_limit_renders_and_a_second_job_ships_nothing() {
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    let scene = tetra9(dir.path());
    let (want, _) = reference(dir.path(), &scene, &FLAGS);

    let first = dir.path().join("first.png");
    let stats = submit(&cluster, &scene, &first);
    assert!(
        std::fs::read(&first).unwrap() == want,
        "differs from sunray render"
    );
    let figures = scene_figures(&stats);
    assert_eq!(figures.len(), 3, "{figures:?}");
    // The hosts other than the submitting one fetched the chunks they lacked.
    let fetched: u64 = figures.iter().map(|f| f.1).sum();
    assert!(fetched > 0, "{figures:?}");
    assert!(
        figures.iter().any(|f| f.0 == "a" && f.2 && f.1 == 0),
        "the submitting host had the model: {figures:?}"
    );

    let second = dir.path().join("second.png");
    let stats = submit(&cluster, &scene, &second);
    assert!(std::fs::read(&second).unwrap() == want);
    let figures = scene_figures(&stats);
    assert!(
        figures.iter().all(|f| f.1 == 0 && f.2),
        "every host had the scene cached: {figures:?}"
    );

    // A chunk corrupted in one host's cache is dropped and fetched again.
    let chunks = cluster.dir.path().join("state-b").join("chunks");
    let mut corrupted = 0;
    for sub in std::fs::read_dir(&chunks).unwrap().flatten() {
        for f in std::fs::read_dir(sub.path()).unwrap().flatten() {
            let mut bytes = std::fs::read(f.path()).unwrap();
            bytes[1000] ^= 0x55;
            std::fs::write(f.path(), bytes).unwrap();
            corrupted += 1;
        }
    }
    assert!(corrupted > 0);
    let third = dir.path().join("third.png");
    let stats = submit(&cluster, &scene, &third);
    assert!(
        std::fs::read(&third).unwrap() == want,
        "a corrupt chunk was rendered"
    );
    let b: Vec<_> = scene_figures(&stats)
        .into_iter()
        .filter(|f| f.0 == "b")
        .collect();
    assert!(
        b.iter().all(|f| !f.2 && f.1 > 0),
        "b fetched its corrupted chunks again: {b:?}"
    );
}
