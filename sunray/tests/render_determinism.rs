//! Determinism: any split of the image among threads gives the same bytes, every accelerator
//! gives the same image, and the mailbox changes only the work done.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use glam::DVec3;
use sunray::accel::{Accel, AccelKind, AccelOptions};
use sunray::film::Film;
use sunray::render::{render_image, Progress, RenderOptions};
use sunray::scene::Scene;
use sunray::stats::Counters;
use yari::model::World;

fn spd(db: yari::spd::Database, size: u32) -> World {
    sunray::bench::spd_world(db, size).unwrap()
}

fn render(
    world: &World,
    kind: AccelKind,
    threads: usize,
    mailbox: bool,
    res: u32,
) -> (Film, Counters) {
    let mut scene = Scene::new(world.clone());
    let accel = Accel::build(
        &mut scene.prims,
        &AccelOptions {
            kind,
            ..Default::default()
        },
    );
    let mut opts = RenderOptions::for_scene(&scene);
    (opts.width, opts.height) = (res, res);
    render_image(&scene, &accel, &opts, threads, mailbox, Progress::Hidden)
}

#[test]
fn accelerators_give_identical_images_on_tetra_and_mount() {
    for world in [
        spd(yari::spd::Database::Tetra, 4),
        spd(yari::spd::Database::Mount, 3),
    ] {
        let (ex, cex) = render(&world, AccelKind::Exhaustive, 1, true, 48);
        let (oc, coc) = render(&world, AccelKind::Octree, 1, true, 48);
        let (oc_off, coc_off) = render(&world, AccelKind::Octree, 1, false, 48);
        let (bv, _) = render(&world, AccelKind::Bvh, 1, true, 48);
        assert!(ex == oc, "octree differs from exhaustive");
        assert!(ex == bv, "bvh differs from exhaustive");
        assert!(oc == oc_off, "mailbox changed the image");
        // Same rays everywhere; the octree does fewer tests; the mailbox saves some.
        assert_eq!(cex.rays(), coc.rays());
        assert!(coc.intersection_tests < cex.intersection_tests);
        assert!(coc.mailbox_hits > 0);
        assert_eq!(
            coc.intersection_tests + coc.mailbox_hits,
            coc_off.intersection_tests
        );
    }
}

/// A scene that uses every stochastic feature.
fn stochastic_world() -> World {
    let mut w = spd(yari::spd::Database::Balls, 1);
    w.samples = 4;
    w.lights[0].radius = 0.5;
    w.features.area_lights = true;
    w.camera.aperture = 0.05;
    w.camera.focus_distance = 3.0;
    w.features.depth_of_field = true;
    for s in &mut w.surfaces {
        s.gloss = 3.0;
        s.translucency = 2.0;
    }
    w.features.gloss = true;
    w.features.translucency = true;
    w.objects[1].motion = DVec3::new(0.2, 0.0, 0.0);
    w.features.motion_blur = true;
    w.features.antialiasing = true;
    w
}

#[test]
fn thread_count_does_not_change_the_bytes() {
    let w = stochastic_world();
    let (one, c1) = render(&w, AccelKind::Auto, 1, true, 40);
    let (two, c2) = render(&w, AccelKind::Auto, 2, true, 40);
    let (three, _) = render(&w, AccelKind::Auto, 3, true, 40);
    assert!(one.to_rgb8() == two.to_rgb8() && one == three);
    assert_eq!(c1, c2, "counters are summed per thread, not estimated");
    assert_eq!(c1.eye, 40 * 40 * 4);
}

#[test]
fn features_gate_the_stochastic_paths() {
    // A light radius that World::features does not announce is ignored (the plain path); once
    // announced, the penumbra changes the image.
    let mut w = spd(yari::spd::Database::Balls, 1);
    let (plain, c_plain) = render(&w, AccelKind::Bvh, 1, true, 24);
    assert_eq!(c_plain.eye, 24 * 24);
    w.lights[0].radius = 2.0;
    let (unannounced, _) = render(&w, AccelKind::Bvh, 1, true, 24);
    assert!(plain == unannounced);
    w.features.area_lights = true;
    let (soft, _) = render(&w, AccelKind::Bvh, 1, true, 24);
    assert!(plain != soft);
}
