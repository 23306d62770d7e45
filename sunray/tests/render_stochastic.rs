//! Stochastic ray tracing: each effect widens the band of partially covered pixels it should
//! widen (penumbra, motion streak, defocus), compared with the same scene without it.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use glam::DVec3;
use sunray::accel::{Accel, AccelOptions};
use sunray::film::Film;
use sunray::render::{render_image, Progress, RenderOptions};
use sunray::scene::Scene;
use yari::model::{Camera, Light, Object, Shape, Surface, World};

/// A white floor (y = 0) under a sphere, one light above, camera looking down at an angle.
fn world() -> World {
    let floor = Surface {
        color: DVec3::ONE,
        ka: 0.0,
        ..Surface::default()
    };
    let ball = Surface {
        color: DVec3::new(1.0, 0.0, 0.0),
        ka: 0.0,
        ..Surface::default()
    };
    let mut w = World {
        resolution: [64, 64],
        background: DVec3::ZERO,
        ambient: DVec3::ZERO,
        camera: Camera {
            position: DVec3::new(0.0, 6.0, 6.0),
            at: DVec3::ZERO,
            up: DVec3::Y,
            half_angle_deg: 25.0,
            aperture: 0.0,
            focus_distance: 1.0,
        },
        // Far away, so the floor is lit evenly; to the side, so the shadow shows.
        lights: vec![Light {
            position: DVec3::new(600.0, 800.0, 0.0),
            color: DVec3::ONE,
            radius: 0.0,
        }],
        samples: 16,
        target_error: None,
        surfaces: vec![floor, ball],
        objects: vec![
            Object {
                shape: Shape::Polygon {
                    vertices: vec![
                        DVec3::new(-10.0, 0.0, -10.0),
                        DVec3::new(-10.0, 0.0, 10.0),
                        DVec3::new(10.0, 0.0, 10.0),
                        DVec3::new(10.0, 0.0, -10.0),
                    ],
                },
                surface: 0,
                motion: DVec3::ZERO,
            },
            Object {
                shape: Shape::Sphere {
                    center: DVec3::new(0.0, 1.5, 0.0),
                    radius: 1.0,
                },
                surface: 1,
                motion: DVec3::ZERO,
            },
        ],
        features: Default::default(),
    };
    w.features.antialiasing = true;
    w.features.polygons = 1;
    w.features.spheres = 1;
    w
}

fn render(w: &World) -> Film {
    let mut scene = Scene::new(w.clone());
    let accel = Accel::build(&mut scene.prims, &AccelOptions::default());
    let film = render_image(
        &scene,
        &accel,
        &RenderOptions::for_scene(&scene),
        2,
        true,
        Progress::Hidden,
    )
    .0;
    if let Some(dir) = std::env::var_os("SUNRAY_TEST_IMAGES") {
        let name = format!(
            "{:x}.png",
            film.pixels
                .iter()
                .map(|p| p[0].to_bits() as u64)
                .sum::<u64>()
        );
        film.write(&std::path::Path::new(&dir).join(name)).unwrap();
    }
    film
}

/// Pixels of the floor (grey: r = g = b) that are neither fully lit nor fully dark.
fn partial_floor(f: &Film, lit: f32) -> usize {
    f.pixels
        .iter()
        .filter(|p| (p[0] - p[1]).abs() < 1e-6 && p[0] > 0.02 * lit && p[0] < 0.98 * lit)
        .count()
}

/// Pixels that mix the pure red ball with the grey floor.
fn partial_ball(f: &Film) -> usize {
    f.pixels
        .iter()
        .filter(|p| p[0] > p[1] + 0.05 && p[1] > 0.05)
        .count()
}

#[test]
fn area_light_casts_a_penumbra() {
    let point = world();
    let mut area = world();
    area.lights[0].radius = 200.0;
    area.features.area_lights = true;
    let grey = |p: &&[f32; 3]| (p[0] - p[1]).abs() < 1e-6;
    let lit = render(&point)
        .pixels
        .iter()
        .filter(grey)
        .map(|p| p[0])
        .fold(0.0, f32::max);
    let hard = partial_floor(&render(&point), lit);
    let soft = partial_floor(&render(&area), lit);
    assert!(soft > 3 * hard.max(10), "penumbra pixels: {soft} vs {hard}");
}

#[test]
fn motion_blurs_along_the_motion() {
    let still = world();
    let mut moving = world();
    moving.objects[1].motion = DVec3::new(2.0, 0.0, 0.0);
    moving.features.motion_blur = true;
    let a = partial_ball(&render(&still));
    let b = partial_ball(&render(&moving));
    assert!(b > 3 * a.max(10), "blurred ball pixels: {b} vs {a}");
}

#[test]
fn defocus_spreads_edges_away_from_the_focal_plane() {
    let pin = world();
    let mut lens = world();
    lens.camera.aperture = 0.4;
    lens.camera.focus_distance = 20.0; // far behind the ball
    lens.features.depth_of_field = true;
    let a = partial_ball(&render(&pin));
    let b = partial_ball(&render(&lens));
    assert!(b > 2 * a.max(10), "defocused ball edge pixels: {b} vs {a}");
}
