//! Haines's SPD invariants (513x513 eye rays through the pixel corners, depth 5): counts of
//! rays within 2% of the figures in his README.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use sunray::accel::{Accel, AccelKind, AccelOptions};
use sunray::render::{render_image, Progress, RenderOptions};
use sunray::scene::Scene;
use sunray::stats::Counters;

mod support;

fn spd(name: &str) -> Counters {
    let path = support::spd_file(&format!("{name}.nff"));
    let world = yari::load::load_path(&path, &yari::colour::ColourTable::builtin())
        .unwrap()
        .world;
    let mut scene = Scene::new(world);
    let accel = Accel::build(
        &mut scene.prims,
        &AccelOptions {
            kind: AccelKind::Bvh,
            ..Default::default()
        },
    );
    let opts = RenderOptions::for_scene(&scene).spd_corners();
    assert_eq!(
        (opts.width, opts.height, opts.trace.max_depth),
        (513, 513, 5)
    );
    render_image(&scene, &accel, &opts, 2, true, Progress::Hidden).1
}

fn within(got: u64, want: u64) {
    let err = (got as f64 - want as f64).abs() / want as f64;
    assert!(err < 0.02, "{got} vs {want}: {:.2}%", err * 100.0);
}

#[test]
fn tetra_invariants() {
    let c = spd("tetra6");
    assert_eq!(c.eye, 513 * 513);
    within(c.eye_hits, 49_788);
    within(c.shadow, 46_112);
    assert_eq!((c.reflected, c.refracted), (0, 0));
}

#[test]
fn mount_invariants() {
    let c = spd("mount6");
    within(c.eye_hits, 173_125);
    within(c.reflected, 354_769);
    within(c.refracted, 354_769);
    // Haines's tracer casts shadow rays only to lights in front of a surface; ours also casts
    // them to lights behind a transmitting surface (Hall's transmission terms).
    within(c.shadow - c.shadow_behind, 412_922);
}

#[test]
fn balls_invariants() {
    let c = spd("balls4");
    within(c.eye_hits, 263_169);
    within(c.reflected, 175_095);
    within(c.shadow, 954_368);
    assert_eq!(c.refracted, 0);
}
