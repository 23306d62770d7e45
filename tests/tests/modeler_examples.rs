//! The modeler's example scenes (thesis Fig. 2.2, the chess king, and Fig. 2.3, the bat),
//! rebuilt from their scripts in `examples/modeler/`, checked against the committed YARI
//! files, checked geometrically, and rendered by `sunray render`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a measurement tool: a failure ends it with a message

use clap::Parser;
use modeler::mesh::Mesh;
use modeler::preview::{raster::Canvas, shapes::Drawables, views};
use modeler::project::{Color, Object, Primitive, Project};
use std::path::{Path, PathBuf};

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/modeler")
}

fn modeler(project: &Path, args: &[&str]) {
    let mut argv = vec!["modeler", "-p", project.to_str().unwrap()];
    argv.extend_from_slice(args);
    let cli = modeler::cli::commands::Cli::try_parse_from(&argv).unwrap();
    let mut out = Vec::new();
    modeler::cli::run(cli, &mut out).unwrap_or_else(|e| panic!("modeler {args:?}: {e}"));
}

/// Runs an example's script into `dir`; returns the project and the exported YARI file.
fn build(name: &str, dir: &Path) -> (Project, PathBuf) {
    let project = dir.join(format!("{name}.modeler.json"));
    let script = examples().join(format!("{name}.modeler"));
    modeler(&project, &["script", script.to_str().unwrap()]);
    let yari = dir.join(format!("{name}.yari"));
    modeler(&project, &["export", "-o", yari.to_str().unwrap()]);
    (Project::load(&project).unwrap(), yari)
}

/// Splits YARI text into words and numbers, so that texts compare with a tolerance on
/// numbers (sin and cos may differ in the last bit between math libraries).
fn tokens(text: &str) -> Vec<&str> {
    text.split(|c: char| c.is_whitespace() || ",;()=".contains(c))
        .filter(|t| !t.is_empty())
        .collect()
}

#[test]
fn the_committed_examples_are_what_their_scripts_build() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["king", "bat"] {
        let (_, yari) = build(name, dir.path());
        let built = std::fs::read_to_string(&yari).unwrap();
        let committed = std::fs::read_to_string(examples().join(format!("{name}.yari"))).unwrap();
        let (a, b) = (tokens(&built), tokens(&committed));
        assert_eq!(
            a.len(),
            b.len(),
            "{name}.yari is out of date: run examples/modeler/build.sh"
        );
        for (x, y) in a.iter().zip(&b) {
            let same = x == y
                || matches!((x.parse::<f64>(), y.parse::<f64>()), (Ok(u), Ok(v)) if (u - v).abs() <= 1e-9 * (1.0 + u.abs()));
            assert!(
                same,
                "{name}.yari is out of date ({x} vs {y}): run examples/modeler/build.sh"
            );
        }
    }
}

fn polygons(o: &Object) -> Vec<Vec<[f64; 3]>> {
    o.primitives
        .iter()
        .filter_map(|p| match p {
            Primitive::Polygon { vertices, .. } => Some(vertices.clone()),
            _ => None,
        })
        .collect()
}

#[test]
fn revolved_and_extruded_parts_are_closed_and_outward() {
    let dir = tempfile::tempdir().unwrap();
    for (name, parts) in [
        ("king", &["king.body", "king.cross"][..]),
        ("bat", &["bat"][..]),
    ] {
        let (project, _) = build(name, dir.path());
        for part in parts {
            let polys = polygons(project.object(part).unwrap());
            assert!(polys.len() > 10, "{part}");
            let mesh = Mesh::from_polygons(polys.iter().map(|p| p.as_slice()));
            mesh.check_closed()
                .unwrap_or_else(|e| panic!("{part}: {e}"));
            assert!(mesh.signed_volume() > 0.0, "{part} faces inward");
        }
    }
    // The king's body: 8 steps of 45 degrees around the axis.
    let (king, _) = build("king", dir.path());
    let n = polygons(king.object("king.body").unwrap()).len();
    assert_eq!(n % 8, 0, "{n} polygons");
}

/// Pixels covered by the object as the camera sees it, shrunk by one pixel at the edges.
fn silhouette(project: &Project, size: usize) -> Vec<bool> {
    let scene = modeler::export::to_scene(project);
    let world = yari::compile::compile(&scene, &yari::colour::ColourTable::builtin())
        .unwrap()
        .world;
    let cam = &world.camera;
    let view =
        views::perspective_view(cam.position, cam.at, cam.up, cam.half_angle_deg, size, 1e-3)
            .unwrap();
    let mut canvas = Canvas::new(size, size, [0.0; 3]);
    for (poly, _) in Drawables::from_world(&world).polygons {
        let pts: Vec<[f64; 3]> = view
            .clip_near(&poly, true)
            .iter()
            .map(|p| view.project(*p))
            .collect();
        canvas.fill_polygon(&pts, [1.0; 3]);
    }
    let covered = |x: i64, y: i64| {
        x >= 0
            && y >= 0
            && (x as usize) < size
            && (y as usize) < size
            && canvas.color[y as usize * size + x as usize] == [1.0; 3]
    };
    (0..size * size)
        .map(|i| {
            let (x, y) = ((i % size) as i64, (i / size) as i64);
            (-1..=1).all(|dy| (-1..=1).all(|dx| covered(x + dx, y + dy)))
        })
        .collect()
}

#[test]
fn sunray_renders_the_examples_with_no_background_through_the_solids() {
    let dir = tempfile::tempdir().unwrap();
    let size = 96;
    for name in ["king", "bat"] {
        let (project, yari) = build(name, dir.path());
        let png = dir.path().join(format!("{name}.png"));
        let res = format!("{size}x{size}");
        let argv = [
            "sunray",
            "render",
            yari.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--resolution",
            &res,
            "-q",
        ];
        let cli = sunray::cli::Cli::try_parse_from(argv).unwrap();
        sunray::cli::run(cli).unwrap_or_else(|e| panic!("sunray render {name}: {e}"));
        let img = image::open(&png).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (size as u32, size as u32));
        let Some(Color::Rgb(bg)) = &project.settings.background else {
            panic!("{name}: the example should set an r,g,b background");
        };
        let bg = bg.map(|c| (c * 255.0).round() as i32);
        let is_background = |p: &image::Rgb<u8>| (0..3).all(|k| (p.0[k] as i32 - bg[k]).abs() <= 2);
        let mask = silhouette(&project, size);
        let inside = mask.iter().filter(|m| **m).count();
        assert!(
            inside > size * size / 20,
            "{name}: silhouette of {inside} pixels is too small to test"
        );
        let leaks: Vec<(usize, usize)> = (0..size * size)
            .filter(|&i| {
                mask[i] && is_background(img.get_pixel((i % size) as u32, (i / size) as u32))
            })
            .map(|i| (i % size, i / size))
            .collect();
        assert!(
            leaks.is_empty(),
            "{name}: background shows through at {leaks:?}"
        );
        // The check can fail: outside the silhouette the background is there.
        let outside_bg = (0..size * size)
            .filter(|&i| {
                !mask[i] && is_background(img.get_pixel((i % size) as u32, (i / size) as u32))
            })
            .count();
        assert!(
            outside_bg > size * size / 4,
            "{name}: only {outside_bg} background pixels"
        );
    }
}
