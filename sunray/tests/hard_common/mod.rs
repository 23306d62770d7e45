//! Shared helpers of the hard-case suites (`hard_*.rs`): load a YARI text, render it with a
//! chosen accelerator, and the invariant every test render is checked against (no NaN or
//! infinite value in the float image).
#![allow(dead_code)]

use sunray::accel::{Accel, AccelKind, AccelOptions};
use sunray::film::Film;
use sunray::render::{render_image, Progress, RenderOptions};
use sunray::scene::Scene;
use yari::model::World;

/// Compiles YARI text; panics with the diagnostics if it does not compile.
pub fn world(text: &str) -> World {
    match yari::load::load_str(
        "hard.yari",
        text,
        yari::load::InputKind::Yari,
        &yari::colour::ColourTable::builtin(),
    ) {
        Ok(l) => l.world,
        Err(e) => panic!("scene does not compile: {e}"),
    }
}

/// Renders `world` at its own resolution and samples with accelerator `kind`, and checks the
/// invariant: every channel of every pixel is finite.
pub fn render_with(world: &World, kind: AccelKind) -> Film {
    let mut scene = Scene::new(world.clone());
    let accel = Accel::build(
        &mut scene.prims,
        &AccelOptions {
            kind,
            ..AccelOptions::default()
        },
    );
    let opts = RenderOptions::for_scene(&scene);
    let (film, _) = render_image(&scene, &accel, &opts, 2, true, Progress::Hidden);
    assert_finite(&film);
    film
}

pub fn render(world: &World) -> Film {
    render_with(world, AccelKind::Auto)
}

pub fn assert_finite(film: &Film) {
    let bad = film
        .pixels
        .iter()
        .filter(|p| p.iter().any(|c| !c.is_finite()))
        .count();
    assert_eq!(bad, 0, "{bad} pixels are NaN or infinite");
}

/// Pixels whose 8-bit value differs by more than 1/255 in some channel.
pub fn differing_pixels(a: &Film, b: &Film) -> usize {
    assert_eq!((a.width, a.height), (b.width, b.height));
    a.to_rgb8()
        .chunks(3)
        .zip(b.to_rgb8().chunks(3))
        .filter(|(x, y)| x.iter().zip(y.iter()).any(|(p, q)| p.abs_diff(*q) > 1))
        .count()
}

/// Asserts that at most 0.1% of the pixels differ by more than 1/255.
pub fn assert_same_picture(a: &Film, b: &Film, what: &str) {
    let d = differing_pixels(a, b);
    let n = a.pixels.len();
    assert!(
        d * 1000 <= n,
        "{what}: {d} of {n} pixels differ by more than 1/255"
    );
}

/// Pixels exactly equal to `colour` (in 8 bits).
pub fn count_colour(film: &Film, colour: [u8; 3]) -> usize {
    film.to_rgb8().chunks(3).filter(|p| *p == colour).count()
}

/// Writes `film` to $SUNRAY_TEST_IMAGES/`name`.png when that variable is set (to look at).
pub fn save(film: &Film, name: &str) {
    if let Some(dir) = std::env::var_os("SUNRAY_TEST_IMAGES") {
        film.write(&std::path::Path::new(&dir).join(format!("{name}.png")))
            .unwrap();
    }
}
