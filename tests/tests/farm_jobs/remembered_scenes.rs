//! The submitting host remembers the scenes it shipped: the same file submitted again is
//! not compiled nor shipped again; a changed one is.

use super::*;

/// A second submit of an unchanged scene compiles nothing and sends nothing: the submitting
/// host remembers what the job needs of the scene and its model's chunks, still with its
/// remd. A count planted in the remembered entry shows that the second job took it from
/// there; a changed scene (a comment added) is compiled and shipped again.
#[test]
fn a_scene_submitted_again_unchanged_is_not_compiled_again() {
    let cluster = LoopbackCluster::start(2);
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let scene = dir.path().join("mount6.nff");
    std::fs::copy(spd("mount6"), &scene).unwrap();
    let (want, _) = reference(dir.path(), &scene, &FLAGS);
    let run = |name: &str| {
        let (out, json) = (
            dir.path().join(format!("{name}.png")),
            dir.path().join(format!("{name}.json")),
        );
        succeed(
            cluster
                .submit()
                .env("SUNRAY_CACHE_DIR", &cache)
                .args(["--hosts", "2", "-q"])
                .args(FLAGS)
                .arg(&scene)
                .arg("-o")
                .arg(&out)
                .arg("--stats-json")
                .arg(&json),
        );
        assert!(
            std::fs::read(&out).unwrap() == want,
            "{name}: differs from sunray render"
        );
        read_json(&json)
    };
    let first = run("first");
    let objects = first["totals"]["objects"].as_u64().unwrap();
    assert!(
        first["scene_bytes_sent"].as_u64().unwrap() > 0,
        "a shipped the model once"
    );
    let entries: Vec<_> = std::fs::read_dir(cache.join("shipped"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    assert_eq!(entries.len(), 1, "{entries:?}");
    let mut entry: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&entries[0]).unwrap()).unwrap();
    entry["summary"]["objects"] = 424_242.into();
    std::fs::write(&entries[0], serde_json::to_vec(&entry).unwrap()).unwrap();

    let second = run("second");
    assert_eq!(
        second["totals"]["objects"], 424_242,
        "the remembered entry was used"
    );
    assert_eq!(second["scene_bytes_sent"], 0);

    let mut text = std::fs::read(&scene).unwrap();
    text.extend_from_slice(b"# the same scene, other bytes\n");
    std::fs::write(&scene, text).unwrap();
    let third = run("third");
    assert_eq!(
        third["totals"]["objects"], objects,
        "a changed scene is compiled again"
    );
}
