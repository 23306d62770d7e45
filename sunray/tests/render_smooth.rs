//! Smooth shading end to end: an NFF `pp` renders with its normals; a coarse smooth sphere
//! lit from the side shows no dark facets at the shadow terminator (Hanika's fix), compared
//! pixel by pixel with the exact sphere.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use glam::DVec3;
use sunray::accel::{Accel, AccelOptions};
use sunray::film::Film;
use sunray::render::{render_image, Progress, RenderOptions};
use sunray::scene::Scene;
use yari::model::{Camera, Light, Object, Shape, Surface, World};

fn render(w: &World) -> Film {
    let mut scene = Scene::new(w.clone());
    let accel = Accel::build(&mut scene.prims, &AccelOptions::default());
    render_image(
        &scene,
        &accel,
        &RenderOptions::for_scene(&scene),
        2,
        true,
        Progress::Hidden,
    )
    .0
}

fn nff_world(text: &str) -> World {
    let src = yari::span::Source::new("t.nff", text);
    let scene = yari::nff::parse(&src).unwrap_or_else(|d| panic!("{}", d.render(&src)));
    yari::compile::compile(&scene, &yari::colour::ColourTable::builtin())
        .unwrap()
        .world
}

const VIEW: &str = "v\nfrom 0 0 10\nat 0 0 0\nup 0 1 0\nangle 20\nhither 1\nresolution 5 5\n\
                    b 0 0 0\nl 0 0 10\nf 1 1 1 1 0 0 0 1\n";

#[test]
fn an_nff_pp_renders_with_its_normals() {
    let corners = ["-2 -2 0", "2 -2 0", "0 2 0"];
    let normals = ["-1 -1 2", "1 -1 2", "0 1 1"];
    let pp: String = corners
        .iter()
        .zip(normals)
        .map(|(c, n)| format!("{c} {n}\n"))
        .collect();
    let p = corners.join("\n");
    let smooth = render(&nff_world(&format!("{VIEW}pp 3\n{pp}")));
    let flat = render(&nff_world(&format!("{VIEW}p 3\n{p}\n")));
    // The centre pixel sees (0,0,0), where the normals weigh 1/4, 1/4, 1/2 (by hand, see
    // shading::smooth_tests): N.L = 0.98130; flat it is 1. One NFF light is 0.5 and so is
    // the ambient (Haines's sqrt(n)/(2n)): the pixel is 0.5 N.L + 0.5.
    let (s2, s6) = (2f64.sqrt(), 6f64.sqrt());
    let (y, z) = (0.5 / s2 - 0.5 / s6, 1.0 / s6 + 0.5 / s2);
    let want = (0.5 * z / (y * y + z * z).sqrt() + 0.5) as f32;
    let centre = 2 * 5 + 2;
    assert!(
        (smooth.pixels[centre][0] - want).abs() < 1e-6,
        "{:?}",
        smooth.pixels[centre]
    );
    assert_eq!(flat.pixels[centre], [1.0; 3]);
    // Only the triangle's pixels change, and every one of them does (the normals lean).
    for (a, b) in smooth.pixels.iter().zip(&flat.pixels) {
        if b[0] == 0.0 {
            assert_eq!(a, b, "the background stays");
        } else {
            assert!(a[0] < b[0], "{a:?} vs {b:?}");
        }
    }
    // A pp whose normals are the plane's renders as the p does.
    let plane: String = corners.iter().map(|c| format!("{c} 0 0 1\n")).collect();
    let same = render(&nff_world(&format!("{VIEW}pp 3\n{plane}")));
    assert_eq!(same.to_rgb8(), flat.to_rgb8());
}

/// A UV sphere of radius 1 about the y axis, `around` faces around and `down` bands from
/// pole to pole, its vertex normals the exact sphere's (or none, when `smooth` is false).
fn sphere_mesh(around: usize, down: usize, smooth: bool) -> Vec<Shape> {
    let point = |i: usize, k: usize| {
        let theta = std::f64::consts::PI * i as f64 / down as f64;
        let phi = std::f64::consts::TAU * (k % around) as f64 / around as f64;
        DVec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            theta.sin() * phi.sin(),
        )
    };
    let mut out = Vec::new();
    for i in 0..down {
        for k in 0..around {
            let mut v = vec![
                point(i, k),
                point(i, k + 1),
                point(i + 1, k + 1),
                point(i + 1, k),
            ];
            if i == 0 {
                v.remove(1);
            } else if i == down - 1 {
                v.remove(2);
            }
            // Outward: the right-hand rule must agree with the radial direction.
            let c: DVec3 = v.iter().copied().sum::<DVec3>() / v.len() as f64;
            if (v[1] - v[0]).cross(v[2] - v[0]).dot(c) < 0.0 {
                v.reverse();
            }
            out.push(if smooth {
                Shape::SmoothPolygon {
                    normals: v.clone(),
                    vertices: v,
                }
            } else {
                Shape::Polygon { vertices: v }
            });
        }
    }
    out
}

/// A white matte ball in front of a blue background, lit only from the side.
fn side_lit(shapes: Vec<Shape>, size: u32) -> World {
    let mut w = World {
        resolution: [size, size],
        background: DVec3::new(0.0, 0.0, 1.0),
        ambient: DVec3::ZERO,
        camera: Camera {
            position: DVec3::new(0.0, 0.0, 4.0),
            at: DVec3::ZERO,
            up: DVec3::Y,
            half_angle_deg: 16.0,
            aperture: 0.0,
            focus_distance: 1.0,
        },
        lights: vec![Light {
            position: DVec3::new(1000.0, 300.0, 150.0),
            color: DVec3::ONE,
            radius: 0.0,
        }],
        samples: 1,
        target_error: None,
        surfaces: vec![Surface {
            ka: 0.0,
            ..Surface::default()
        }],
        objects: shapes
            .into_iter()
            .map(|shape| Object {
                shape,
                surface: 0,
                motion: DVec3::ZERO,
            })
            .collect(),
        features: Default::default(),
    };
    w.features = yari::compile::features(&w);
    w
}

/// Per pixel where both images show the ball: how much darker `mesh` is than `exact` where
/// `exact` is lit; the largest deficit and how many pixels are black there.
fn terminator_deficit(mesh: &Film, exact: &Film) -> (f32, usize) {
    let ball = |p: &[f32; 3]| p[0] == p[2];
    let mut worst = 0.0f32;
    let mut black = 0;
    for (m, e) in mesh.pixels.iter().zip(&exact.pixels) {
        if ball(m) && ball(e) && e[0] > 0.0 {
            worst = worst.max(e[0] - m[0]);
            black += usize::from(m[0] == 0.0 && e[0] > 0.05);
        }
    }
    (worst, black)
}

#[test]
fn a_coarse_smooth_sphere_has_no_dark_facets_at_the_terminator() {
    let size = 96;
    let exact = render(&side_lit(
        vec![Shape::Sphere {
            center: DVec3::ZERO,
            radius: 1.0,
        }],
        size,
    ));
    let smooth = render(&side_lit(sphere_mesh(10, 6, true), size));
    let flat = render(&side_lit(sphere_mesh(10, 6, false), size));
    if let Some(dir) = std::env::var_os("SUNRAY_TEST_IMAGES") {
        let dir = std::path::Path::new(&dir);
        exact.write(&dir.join("terminator-exact.png")).unwrap();
        smooth.write(&dir.join("terminator-smooth.png")).unwrap();
        flat.write(&dir.join("terminator-flat.png")).unwrap();
    }
    let (worst, black) = terminator_deficit(&smooth, &exact);
    eprintln!("smooth: worst deficit {worst}, black {black}");
    assert_eq!(black, 0, "black pixels where the exact sphere is lit");
    assert!(
        worst < 0.12,
        "a smooth facet is {worst} darker than the exact sphere"
    );
    // The flat mesh, for scale: its facets are far darker in places.
    let (flat_worst, _) = terminator_deficit(&flat, &exact);
    eprintln!("flat: worst deficit {flat_worst}");
    assert!(flat_worst > 2.0 * worst);
}
