//! Golden images: each thesis example (and our stochastic/texture demo) rendered small and
//! compared with a PNG under tests/golden/ that was looked at before it was stored.
//!
//! Tolerance: every channel within 2/255 and at most 0.5% of the pixels different at all (room
//! for last-bit differences of libm's sin/pow between platforms). To regenerate after a
//! deliberate change, run with `SUNRAY_UPDATE_GOLDEN=1` and LOOK at the new files.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::path::{Path, PathBuf};
use sunray::accel::{Accel, AccelOptions};
use sunray::render::{render_image, Progress, RenderOptions};
use sunray::scene::Scene;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

fn check(scene_path: PathBuf, golden: &str, width: u32, height: u32, samples: Option<u32>) {
    let world = yari::load::load_path(&scene_path, &yari::colour::ColourTable::builtin())
        .unwrap()
        .world;
    let mut scene = Scene::new(world);
    let accel = Accel::build(&mut scene.prims, &AccelOptions::default());
    let mut opts = RenderOptions::for_scene(&scene);
    (opts.width, opts.height) = (width, height);
    if let Some(s) = samples {
        opts.samples = s;
    }
    let (film, _) = render_image(&scene, &accel, &opts, 2, true, Progress::Hidden);
    let path = dir().join("tests/golden").join(golden);
    if std::env::var_os("SUNRAY_UPDATE_GOLDEN").is_some() {
        film.write(&path).unwrap();
        return;
    }
    let want = image::open(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8();
    assert_eq!((want.width(), want.height()), (width, height));
    let got = film.to_rgb8();
    let mut differing = 0;
    for (g, w) in got.chunks(3).zip(want.as_raw().chunks(3)) {
        let d = g
            .iter()
            .zip(w)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap_or(0);
        assert!(d <= 2, "{golden}: a channel differs by {d}");
        differing += usize::from(d > 0);
    }
    assert!(
        differing * 200 <= (width * height) as usize,
        "{golden}: {differing} pixels differ"
    );
}

mod support;
use support::{spd_file, thesis};

#[test]
fn thesis_fig_2_1_tetra16() {
    check(thesis("tetra16.yari"), "tetra16.png", 96, 96, None);
}

#[test]
fn thesis_appendix_c5_cubes() {
    check(thesis("cubes.yari"), "cubes.png", 128, 128, None);
}

#[test]
fn spd_mount_and_balls_small() {
    check(spd_file("mount6.nff"), "mount6.png", 96, 96, None);
    check(spd_file("balls4.nff"), "balls4.png", 96, 96, None);
}

#[test]
fn stochastic_features_and_textures() {
    check(
        dir().join("tests/scenes/stochastic.yari"),
        "stochastic.png",
        160,
        120,
        Some(4),
    );
}
