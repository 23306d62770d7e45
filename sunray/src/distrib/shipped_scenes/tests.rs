use super::*;

fn entry(chunks: usize, size: u64) -> ShippedScene {
    let model = ShippedModel {
        chunks: (0..chunks).map(|i| format!("{i:064x}")).collect(),
        size,
        hash: 7,
        bytes_sent: 123,
    };
    let summary = SceneSummary {
        objects: 3,
        primitives: 5,
        unbounded: 1,
        resolution: [64, 48],
        samples: 2,
        target_error: Some(0.01),
    };
    ShippedScene::new(summary, vec!["w".into()], &model, Vec::new())
}

#[test]
fn the_key_follows_the_scene_and_the_colour_file_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, colours) = (dir.path().join("s.nff"), dir.path().join("c.col"));
    std::fs::write(&scene, "b 0 0 0\n").unwrap();
    std::fs::write(&colours, "teal 0 0.5 0.5\n").unwrap();
    let plain = SceneKey::of(&scene, None).unwrap();
    assert_eq!(
        plain,
        SceneKey::of(&scene, None).unwrap(),
        "the same bytes, the same key"
    );
    let coloured = SceneKey::of(&scene, Some(&colours)).unwrap();
    assert_ne!(plain, coloured);
    std::fs::write(&colours, "teal 0 0.5 0.6\n").unwrap();
    assert_ne!(coloured, SceneKey::of(&scene, Some(&colours)).unwrap());
    std::fs::write(&scene, "b 0 0 1\n").unwrap();
    assert_ne!(plain, SceneKey::of(&scene, None).unwrap());
    assert!(SceneKey::of(&dir.path().join("missing"), None).is_err());
}

#[test]
fn an_entry_kept_is_found_and_its_model_sends_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = ShippedScenes::at(dir.path());
    let scene = dir.path().join("s.nff");
    std::fs::write(&scene, "b 0 0 0\n").unwrap();
    let key = SceneKey::of(&scene, None).unwrap();
    assert_eq!(scenes.find(&key), None);
    let e = entry(3, 2 * rem::client::blob::CHUNK_BYTES as u64 + 5);
    scenes.keep(&key, &e).unwrap();
    let found = scenes.find(&key).unwrap();
    assert_eq!(found, e);
    let model = &found.model;
    assert_eq!(
        (model.chunks.len(), model.hash, model.bytes_sent),
        (3, 7, 0)
    );
}

#[test]
fn an_entry_stands_only_while_the_files_its_model_was_made_from_are_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = ShippedScenes::at(dir.path());
    let (scene, mesh) = (dir.path().join("s.yari"), dir.path().join("m.ply"));
    std::fs::write(&scene, "begin mesh(file = \"m.ply\"); end\n").unwrap();
    std::fs::write(&mesh, "ply one").unwrap();
    let key = SceneKey::of(&scene, None).unwrap();
    let mut e = entry(1, 10);
    e.inputs = vec![ShippedInput {
        key: scenes.key_of(&mesh, None).unwrap(),
        path: mesh.clone(),
    }];
    scenes.keep(&key, &e).unwrap();
    assert_eq!(scenes.find(&key), Some(e.clone()));
    std::fs::write(&mesh, "ply two").unwrap();
    assert_eq!(scenes.find(&key), None, "the mesh changed");
    std::fs::write(&mesh, "ply one").unwrap();
    assert_eq!(scenes.find(&key), Some(e), "as it was");
    std::fs::remove_file(&mesh).unwrap();
    assert_eq!(scenes.find(&key), None, "the mesh is gone");
}

#[test]
fn a_damaged_or_unsound_entry_is_not_trusted() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = ShippedScenes::at(dir.path());
    let scene = dir.path().join("s.nff");
    std::fs::write(&scene, "b 0 0 0\n").unwrap();
    let key = SceneKey::of(&scene, None).unwrap();
    let chunk = rem::client::blob::CHUNK_BYTES as u64;
    scenes.keep(&key, &entry(2, chunk + 1)).unwrap();
    assert!(scenes.find(&key).is_some());
    let path = scenes.path(&key);
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    assert_eq!(scenes.find(&key), None, "cut short");
    for bad in [
        entry(2, 2 * chunk + 1), // more bytes than its chunks hold
        entry(2, chunk),         // fewer than its chunks need
        entry(0, 0),             // no chunk
        ShippedScene {
            version: ENTRY_VERSION + 1,
            ..entry(1, 10)
        },
        {
            let mut e = entry(1, 10);
            e.model.chunks = vec!["../../etc/passwd".into()];
            e
        },
        {
            let mut e = entry(1, 10);
            let input = dir.path().join("m.ply");
            e.inputs = vec![ShippedInput {
                key: SceneKey("not a key".into()),
                path: input,
            }];
            e
        },
    ] {
        scenes.keep(&key, &bad).unwrap();
        assert_eq!(scenes.find(&key), None, "{bad:?}");
    }
}

#[test]
fn the_least_recently_used_entries_go_first() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = ShippedScenes::at(dir.path());
    let keys: Vec<SceneKey> = (0..4)
        .map(|i| {
            let scene = dir.path().join(format!("s{i}.nff"));
            std::fs::write(&scene, format!("b 0 0 {i}\n")).unwrap();
            SceneKey::of(&scene, None).unwrap()
        })
        .collect();
    let old = std::time::SystemTime::now() - std::time::Duration::from_secs(3600);
    for (i, key) in keys.iter().enumerate() {
        scenes.keep(key, &entry(1, 10)).unwrap();
        // Written an hour ago, a minute apart, the first the oldest.
        let f = std::fs::File::options()
            .append(true)
            .open(scenes.path(key))
            .unwrap();
        f.set_modified(old + std::time::Duration::from_secs(60 * i as u64))
            .unwrap();
    }
    // Finding the first makes it the most recently used.
    assert!(scenes.find(&keys[0]).is_some());
    scenes.prune(2);
    let kept: Vec<bool> = keys.iter().map(|k| scenes.path(k).exists()).collect();
    assert_eq!(kept, [true, false, false, true]);
}

#[test]
fn a_stamp_names_the_key_of_an_unchanged_file_and_never_of_a_changed_one() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = ShippedScenes::at(&dir.path().join("cache"));
    let scene = dir.path().join("s.nff");
    std::fs::write(&scene, "b 0 0 0\n").unwrap();
    let now = std::time::Duration::ZERO;
    let hashed = SceneKey::of(&scene, None).unwrap();
    assert_eq!(scenes.key_after(&scene, None, now).unwrap(), hashed);
    let stamps = dir.path().join("cache").join("shipped").join("stamps");
    assert_eq!(std::fs::read_dir(&stamps).unwrap().count(), 1, "stamped");
    // The stamp answers without reading the file: a stamp that lies is believed ...
    let stamp = std::fs::read_dir(&stamps)
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    std::fs::write(&stamp, "ab".repeat(32)).unwrap();
    assert_eq!(
        scenes.key_after(&scene, None, now).unwrap().0,
        "ab".repeat(32)
    );
    // ... but any write to the file (the same length here) makes another stamp. The file
    // system's clock is coarse: the write is made again until its times differ (a bound of
    // a second; a tick is a few milliseconds).
    let times = |p: &Path| {
        let m = std::fs::metadata(p).unwrap();
        (
            m.modified().unwrap(),
            std::os::unix::fs::MetadataExt::ctime_nsec(&m),
        )
    };
    let before = times(&scene);
    let t0 = std::time::Instant::now();
    loop {
        std::fs::write(&scene, "b 0 0 1\n").unwrap();
        if times(&scene) != before {
            break;
        }
        assert!(t0.elapsed().as_secs() < 1, "the file's times never changed");
        std::thread::yield_now();
    }
    let changed = scenes.key_after(&scene, None, now).unwrap();
    assert_eq!(changed, SceneKey::of(&scene, None).unwrap());
    assert_ne!(changed, hashed);
    // A colour file is part of the stamp; a file changed just now is not stamped.
    let colours = dir.path().join("c.col");
    std::fs::write(&colours, "teal 0 0.5 0.5\n").unwrap();
    let before = std::fs::read_dir(&stamps).unwrap().count();
    let coloured = scenes.key_of(&scene, Some(&colours)).unwrap();
    assert_eq!(coloured, SceneKey::of(&scene, Some(&colours)).unwrap());
    assert_eq!(
        std::fs::read_dir(&stamps).unwrap().count(),
        before,
        "not settled"
    );
}
