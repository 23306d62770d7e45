//! The submitting host remembers the scenes it shipped: the same file submitted again is
//! not compiled nor shipped again; a changed one is.

use super::*;

/// `sunray submit --hosts 2 -q FLAGS SCENE` with this user's cache at `cache`, its image and
/// statistics written as `NAME.png` and `NAME.json` in `dir`: the image's bytes and the
/// statistics.
fn submit_remembering(
    cluster: &LoopbackCluster,
    cache: &Path,
    dir: &Path,
    flags: &[&str],
    scene: &Path,
    name: &str,
) -> (Vec<u8>, serde_json::Value) {
    let (out, json) = (
        dir.join(format!("{name}.png")),
        dir.join(format!("{name}.json")),
    );
    succeed(
        cluster
            .submit()
            .env("SUNRAY_CACHE_DIR", cache)
            .args(["--hosts", "2", "-q"])
            .args(flags)
            .arg(scene)
            .arg("-o")
            .arg(&out)
            .arg("--stats-json")
            .arg(&json),
    );
    (std::fs::read(&out).unwrap(), read_json(&json))
}

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
        let (image, stats) = submit_remembering(&cluster, &cache, dir.path(), &FLAGS, &scene, name);
        assert!(image == want, "{name}: differs from sunray render");
        stats
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

/// A YARI scene that places a mesh file ships the mesh's triangles with it: the farm's image
/// is `sunray render`'s. The scene is remembered with the mesh it was made from, so a second
/// submit sends nothing, and one after the mesh changed (the YARI file untouched) is
/// compiled again and shows the new mesh.
#[test]
fn a_scene_placing_a_mesh_ships_it_and_is_compiled_again_when_the_mesh_changes() {
    let cluster = LoopbackCluster::start(2);
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let models = dir.path().join("models");
    std::fs::create_dir(&models).unwrap();
    let mesh = models.join("tetra.ply");
    let write_mesh = |size: &str| {
        let st = sunray_e2e::bins::sunray()
            .args(["spd", "tetra", "--size", size, "-o"])
            .arg(&mesh)
            .status()
            .unwrap();
        assert!(st.success());
    };
    write_mesh("2");
    let scene = dir.path().join("placed.yari");
    std::fs::write(
        &scene,
        "resolution(64,96);\ncamera(position = 0,0,9; at = 0,0,0; up = 0,1,0; angle = 20);\n\
         light(position = 5,5,9; color = white);\nbegin\n  attribute(color = orange);\n  \
         rotate(0,30,0);\n  mesh(file = \"models/tetra.ply\");\n  translate(-1.5,0,0);\n  \
         mesh(file = \"models/tetra.ply\"; materials = file);\nend\n",
    )
    .unwrap();
    let run = |name: &str| submit_remembering(&cluster, &cache, dir.path(), &[], &scene, name);
    let (want, _) = reference(dir.path(), &scene, &[]);
    let (first, stats) = run("first");
    assert!(
        first == want,
        "the placed mesh through the farm differs from sunray render"
    );
    assert!(stats["scene_bytes_sent"].as_u64().unwrap() > 0);
    let (second, stats) = run("second");
    assert!(second == want);
    assert_eq!(
        stats["scene_bytes_sent"], 0,
        "remembered: nothing sent again"
    );

    write_mesh("3");
    let (changed, _) = reference(dir.path(), &scene, &[]);
    assert!(changed != want, "a finer tetra draws another image");
    let (third, stats) = run("third");
    assert!(third == changed, "the changed mesh was not compiled again");
    assert!(stats["scene_bytes_sent"].as_u64().unwrap() > 0);
}
