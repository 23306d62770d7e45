use super::*;
use crate::render::parallel::{render_image, Progress};
use crate::render::RenderOptions;
use yari::spd::Database;

/// A scene of `db` with its BVH, as a worker has it once ready.
fn ready(db: Database, size: u32) -> (Scene, Accel) {
    let mut scene = Scene::new(crate::bench::spd_world(db, size).unwrap());
    let opts = AccelOptions {
        kind: AccelKind::Bvh,
        ..AccelOptions::default()
    };
    let accel = Accel::build(&mut scene.prims, &opts);
    (scene, accel)
}

fn image(scene: &Scene, accel: &Accel) -> Vec<u8> {
    let opts = RenderOptions {
        width: 40,
        height: 30,
        ..RenderOptions::for_scene(scene)
    };
    render_image(scene, accel, &opts, 2, true, Progress::Hidden)
        .0
        .to_rgb8()
}

fn path_in(dir: &Path) -> PathBuf {
    path_of(dir, 42, &AccelOptions::default()).unwrap()
}

#[test]
fn a_kept_scene_is_used_mapped_and_renders_the_same_image() {
    // Triangles; smooth triangles; solid transparent meshes; quadrics and spheres.
    for db in [
        Database::Tetra,
        Database::Teapot,
        Database::Gears,
        Database::Tree,
    ] {
        let dir = tempfile::tempdir().unwrap();
        let path = path_in(dir.path());
        let (scene, accel) = ready(db, 1);
        assert!(load(&path, 42).unwrap().is_none(), "nothing kept yet");
        keep(&path, 42, &scene, &accel).unwrap();
        let (mapped, maccel) = load(&path, 42).unwrap().unwrap();
        assert!(mapped.prims.is_mapped(), "{db:?}");
        assert!(maccel.bvh().unwrap().is_mapped(), "{db:?}");
        assert_eq!(mapped.world.surfaces, scene.world.surfaces);
        assert_eq!((mapped.objects, maccel.kind), (scene.objects, accel.kind));
        assert_eq!(image(&mapped, &maccel), image(&scene, &accel), "{db:?}");
    }
}

#[test]
fn damaged_cut_short_or_unsealed_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = path_in(dir.path());
    let (scene, accel) = ready(Database::Tetra, 2);
    keep(&path, 42, &scene, &accel).unwrap();
    let good = std::fs::read(&path).unwrap();
    let seal = std::fs::read(checksum::seal_path(&path)).unwrap();
    let refused = |bytes: &[u8], why: &str| {
        std::fs::write(&path, bytes).unwrap();
        match load(&path, 42) {
            Err(PreparedError::Refused { .. }) => {}
            other => panic!("{why}: {:?}", other.map(|o| o.is_some())),
        }
    };
    assert!(load(&path, 42).unwrap().is_some());
    assert!(
        matches!(load(&path, 43), Err(PreparedError::Refused { .. })),
        "another model"
    );
    // A bit changed anywhere: in the header, the world, a table (the triangles, the BVH's
    // nodes near the end), the checksum.
    for at in [9, 200, good.len() / 2, good.len() - 100, good.len() - 1] {
        let mut b = good.clone();
        b[at] ^= 0x10;
        refused(&b, &format!("a bit at {at}"));
    }
    for n in [0, 100, good.len() / 2, good.len() - 1] {
        refused(&good[..n], &format!("cut to {n}"));
    }
    std::fs::remove_file(checksum::seal_path(&path)).unwrap();
    refused(&good, "unsealed");
    std::fs::write(
        checksum::seal_path(&path),
        b"sunray prepared scene: 1 bytes",
    )
    .unwrap();
    refused(&good, "sealed for another file");
    // Kept again, it is good again.
    keep(&path, 42, &scene, &accel).unwrap();
    assert_eq!(std::fs::read(checksum::seal_path(&path)).unwrap(), seal);
    assert!(load(&path, 42).unwrap().is_some());
}

#[test]
fn only_bvh_scenes_are_kept() {
    let dir = tempfile::tempdir().unwrap();
    let octree = AccelOptions {
        kind: AccelKind::Octree,
        ..AccelOptions::default()
    };
    assert!(path_of(dir.path(), 1, &octree).is_none());
    let mut scene = Scene::new(crate::bench::spd_world(Database::Tetra, 1).unwrap());
    let accel = Accel::build(&mut scene.prims, &octree);
    let path = path_in(dir.path());
    keep(&path, 42, &scene, &accel).unwrap();
    assert!(!path.exists());
}
