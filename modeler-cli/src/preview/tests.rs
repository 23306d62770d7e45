use super::*;
use crate::project::{Clip, Color, Object, Primitive, Surface};
use std::path::Path;

fn with(objects: Vec<Object>) -> Project {
    let mut p = Project::new_default();
    p.objects = objects;
    p
}

fn coloured(name: &str, rgb: [f64; 3], prims: Vec<Primitive>) -> Object {
    Object {
        name: name.into(),
        surface: Some(Surface {
            color: Some(Color::Rgb(rgb)),
            ..Surface::default()
        }),
        primitives: prims,
        ..Object::default()
    }
}

fn square(z: f64, half: f64) -> Primitive {
    Primitive::Polygon {
        vertices: vec![
            [-half, -half, z],
            [half, -half, z],
            [half, half, z],
            [-half, half, z],
        ],
        normals: None,
    }
}

/// The pixel at (x, y) of the view in grid cell (cx, cy).
fn px(img: &image::RgbImage, size: usize, cx: usize, cy: usize, x: usize, y: usize) -> [u8; 3] {
    let (ox, oy) = (GAP + cx * (size + GAP), GAP + cy * (size + GAP));
    img.get_pixel((ox + x) as u32, (oy + y) as u32).0
}

const FRONT: (usize, usize) = (0, 1);
const PERSP: (usize, usize) = (1, 0);

#[test]
fn the_image_holds_four_views_of_the_requested_size() {
    let img = render_project(
        &with(vec![]),
        Path::new("."),
        &Options {
            size: 50,
            style: Style::Flat,
        },
    )
    .unwrap();
    assert_eq!(
        img.dimensions(),
        (2 * 50 + 3 * GAP as u32, 2 * 50 + 3 * GAP as u32)
    );
}

#[test]
fn flat_shading_hides_the_farther_square_in_the_front_view() {
    let size = 64;
    // Red at z = 1 in front of a larger green square at z = 0.
    let p = with(vec![
        coloured("green", [0.0, 1.0, 0.0], vec![square(0.0, 2.0)]),
        coloured("red", [1.0, 0.0, 0.0], vec![square(1.0, 1.0)]),
    ]);
    let img = render_project(
        &p,
        Path::new("."),
        &Options {
            size,
            style: Style::Flat,
        },
    )
    .unwrap();
    let centre = px(&img, size, FRONT.0, FRONT.1, size / 2, size / 2 + 5);
    assert!(centre[0] > 200 && centre[1] == 0, "{centre:?}");
    let edge = px(&img, size, FRONT.0, FRONT.1, size / 2 + 20, size / 2 + 20);
    assert!(edge[1] > 200 && edge[0] == 0, "{edge:?}");
    // The perspective view (camera on +z) sees red in the middle too.
    let mid = px(&img, size, PERSP.0, PERSP.1, size / 2, size / 2 + 3);
    assert!(mid[0] > 150 && mid[1] == 0, "{mid:?}");
}

#[test]
fn wireframe_draws_edges_and_leaves_faces_empty() {
    let size = 64;
    let p = with(vec![coloured(
        "red",
        [1.0, 0.0, 0.0],
        vec![square(0.0, 1.0)],
    )]);
    let img = render_project(
        &p,
        Path::new("."),
        &Options {
            size,
            style: Style::Wire,
        },
    )
    .unwrap();
    let (cx, cy) = FRONT;
    let reddish = |c: [u8; 3]| c[0] as i32 > c[1] as i32 + 60;
    let reds = (0..size)
        .flat_map(|y| (0..size).map(move |x| (x, y)))
        .filter(|&(x, y)| reddish(px(&img, size, cx, cy, x, y)))
        .count();
    // Four edges of about 55 pixels (the square fills 1/1.15 of the view).
    assert!((150..260).contains(&reds), "{reds}");
    let inside = px(&img, size, cx, cy, size / 2 + 10, size / 2 + 10);
    assert!(!reddish(inside), "{inside:?}");
}

#[test]
fn spheres_and_clipped_quadrics_show_in_the_front_view() {
    let size = 64;
    let cylinder = Primitive::Quadric {
        coeffs: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0],
        clip: vec![Clip::Box {
            min: [-1.0, -1.0, -1.0],
            max: [1.0, 1.0, 1.0],
        }],
    };
    let p = with(vec![
        coloured(
            "ball",
            [0.0, 0.0, 1.0],
            vec![Primitive::Sphere {
                center: [5.0, 0.0, 0.0],
                radius: 1.0,
            }],
        ),
        coloured("tube", [1.0, 1.0, 0.0], vec![cylinder]),
    ]);
    for style in [Style::Flat, Style::Wire] {
        let img = render_project(&p, Path::new("."), &Options { size, style }).unwrap();
        let (cx, cy) = FRONT;
        let count = |pred: &dyn Fn([u8; 3]) -> bool| {
            (0..size)
                .flat_map(|y| (0..size).map(move |x| (x, y)))
                .filter(|&(x, y)| pred(px(&img, size, cx, cy, x, y)))
                .count()
        };
        let blue = count(&|c| c[2] as i32 > c[0] as i32 + 60);
        let yellow = count(&|c| c[0] as i32 > c[2] as i32 + 60 && c[1] as i32 > c[2] as i32 + 60);
        assert!(
            blue > 20 && yellow > 20,
            "{style:?}: blue {blue} yellow {yellow}"
        );
    }
}

#[test]
fn skeletons_are_drawn_over_the_views() {
    let size = 64;
    let mut p = with(vec![]);
    let mut s = crate::skeleton::Skeleton::new(
        "s",
        crate::skeleton::Plane::Xy,
        crate::skeleton::SkeletonKind::Lines,
    );
    s.points = vec![[-1.0, 0.0], [1.0, 0.0]];
    p.skeletons.push(s);
    let img = render_project(
        &p,
        Path::new("."),
        &Options {
            size,
            style: Style::Wire,
        },
    )
    .unwrap();
    // The line y = 0 lies between the two middle rows of pixel centres, so its antialiased
    // stroke shares itself between them: count the columns where either is skeleton yellow.
    let yellowish = |c: [u8; 3]| {
        let [r, g, b] = c.map(i32::from);
        g > 100 && r > b + 60 && g > b + 60
    };
    let (cx, cy) = FRONT;
    let n = (0..size)
        .filter(|&x| {
            yellowish(px(&img, size, cx, cy, x, size / 2 - 1))
                || yellowish(px(&img, size, cx, cy, x, size / 2))
        })
        .count();
    assert!(n > 40, "{n}");
    // Nothing yellow two rows away.
    let off = (0..size)
        .filter(|&x| yellowish(px(&img, size, cx, cy, x, size / 2 + 2)))
        .count();
    assert_eq!(off, 0);
}

#[test]
fn an_unknown_colour_name_is_a_clear_error() {
    let p = with(vec![Object {
        name: "x".into(),
        surface: Some(Surface {
            color: Some(Color::Named("nosuchcolour".into())),
            ..Surface::default()
        }),
        primitives: vec![square(0.0, 1.0)],
        ..Object::default()
    }]);
    let e = render_project(
        &p,
        Path::new("."),
        &Options {
            size: 32,
            style: Style::Flat,
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("nosuchcolour"), "{e}");
}
