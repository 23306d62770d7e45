//! The generators against Haines's own output (`shared/scenes/spd/*.nff`): entity for entity,
//! number for number within the printed precision, and byte for byte as text.

use super::{generate, Database};
use crate::nff::{read, write, Entity, NffScene};
use crate::span::Source;

fn reference(name: &str) -> (String, NffScene) {
    let path = format!(
        "{}/../../shared/scenes/spd/{name}",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let src = Source::new(name, text.clone());
    let (scene, _) = read(&src).unwrap_or_else(|d| panic!("{}", d.render(&src)));
    (text, scene)
}

fn numbers(e: &Entity) -> Vec<f64> {
    match e {
        Entity::Background(c) => c.to_vec(),
        Entity::View(v) => {
            let mut n = [v.from, v.at, v.up].concat();
            n.extend([v.angle, v.hither]);
            n.extend(v.resolution.iter().flatten().map(|&x| x as f64));
            n
        }
        Entity::Light { position, color } => {
            [position.to_vec(), color.iter().flatten().copied().collect()].concat()
        }
        Entity::Fill(f) => vec![
            f.color[0], f.color[1], f.color[2], f.kd, f.ks, f.shine, f.t, f.ior,
        ],
        Entity::Sphere { center, radius } => vec![center[0], center[1], center[2], *radius],
        Entity::Polygon { vertices, .. } => vertices.concat(),
        Entity::Cone {
            base,
            base_radius,
            apex,
            apex_radius,
        } => [
            base.to_vec(),
            vec![*base_radius],
            apex.to_vec(),
            vec![*apex_radius],
        ]
        .concat(),
    }
}

/// Generated entities (at full precision) equal the file's within its `%g` precision.
fn assert_matches(db: Database, size: u32, file: &str) {
    let (text, want) = reference(file);
    let got = generate(db, size).unwrap();
    assert_eq!(
        got.entities.len(),
        want.entities.len(),
        "{file}: entity count"
    );
    for (i, (g, w)) in got.entities.iter().zip(&want.entities).enumerate() {
        assert_eq!(
            std::mem::discriminant(&g.node),
            std::mem::discriminant(&w.node),
            "{file}: entity {i}"
        );
        let (gn, wn) = (numbers(&g.node), numbers(&w.node));
        assert_eq!(gn.len(), wn.len(), "{file}: entity {i} size");
        for (a, b) in gn.iter().zip(&wn) {
            assert!(
                (a - b).abs() <= 1e-4 * b.abs().max(1.0),
                "{file}: entity {i}: {a} vs {b}"
            );
        }
    }
    assert_eq!(write(&got), text, "{file}: printed text differs");
}

#[test]
fn tetra6_matches_haines() {
    assert_matches(Database::Tetra, 6, "tetra6.nff");
}

#[test]
fn mount6_matches_haines() {
    assert_matches(Database::Mount, 6, "mount6.nff");
}

#[test]
fn balls4_matches_haines() {
    assert_matches(Database::Balls, 4, "balls4.nff");
}

#[test]
fn reference_counts() {
    assert_eq!(reference("tetra6.nff").1.counts(), (0, 4096, 0));
    assert_eq!(reference("mount6.nff").1.counts(), (4, 8192, 0));
    assert_eq!(reference("balls4.nff").1.counts(), (7381, 1, 0));
}

#[test]
fn sizes_out_of_range_are_refused() {
    assert!(generate(Database::Mount, 8).is_err());
    assert!(generate(Database::Tetra, 0).is_err());
    assert!(generate(Database::Balls, 7).is_err());
}

/// The reference files converted to YARI, printed by the YARI writer and read back by the
/// YARI parser, give the same syntax tree with the expected primitive counts.
#[test]
fn references_round_trip_through_yari_text() {
    use crate::ast::{BodyItem, Primitive};
    for (file, want) in [
        ("tetra6.nff", (0, 4096)),
        ("mount6.nff", (4, 8192)),
        ("balls4.nff", (7381, 1)),
    ] {
        let mut scene = crate::nff::to_yari(&reference(file).1);
        let text = crate::writer::write_scene(&scene);
        let src = Source::new(file, text);
        let mut back = crate::parse::parse(&src).unwrap_or_else(|d| panic!("{}", d.render(&src)));
        crate::writer::erase_spans(&mut scene);
        crate::writer::erase_spans(&mut back);
        assert_eq!(back, scene, "{file}");
        let mut counts = (0, 0);
        for item in &back.body.items {
            match item.node {
                BodyItem::Primitive(Primitive::Sphere { .. }) => counts.0 += 1,
                BodyItem::Primitive(Primitive::Polygon { .. }) => counts.1 += 1,
                _ => {}
            }
        }
        assert_eq!(counts, want, "{file}");
    }
}

/// A cone survives the trip to YARI text and back (quadric with clip planes and box).
#[test]
fn cones_round_trip_through_yari_text() {
    let src = Source::new("c.nff", "c\n0 0 0 1\n0 0 2 0.5\nc 1 1 1 0.25 2 3 4 0.25\n");
    let mut scene = crate::nff::parse(&src).unwrap();
    let text = crate::writer::write_scene(&scene);
    let ysrc = Source::new("c.yari", text);
    let mut back = crate::parse::parse(&ysrc).unwrap_or_else(|d| panic!("{}", d.render(&ysrc)));
    crate::writer::erase_spans(&mut scene);
    crate::writer::erase_spans(&mut back);
    assert_eq!(back, scene);
}

/// The converted references compile (with yari-core's compiler) to worlds with the thesis's
/// object counts, the NFF camera at half the angle and the Hall surfaces of the mapping.
#[test]
fn references_compile_to_the_expected_worlds() {
    use crate::colour::ColourTable;
    let colours = ColourTable::builtin();
    for (file, spheres, polygons, surfaces) in [
        ("tetra6.nff", 0, 4096, 1),
        ("mount6.nff", 4, 8192, 2),
        ("balls4.nff", 7381, 1, 2),
    ] {
        let scene = crate::nff::to_yari(&reference(file).1);
        let world = crate::compile::compile(&scene, &colours)
            .unwrap_or_else(|d| panic!("{file}: {d:?}"))
            .world;
        assert_eq!(
            (world.features.spheres, world.features.polygons),
            (spheres, polygons),
            "{file}"
        );
        assert_eq!(world.surfaces.len(), surfaces, "{file}");
        assert_eq!(world.camera.half_angle_deg, 22.5, "{file}");
        assert_eq!(world.ambient, glam::DVec3::ZERO, "{file}");
        assert_eq!(world.resolution, [512, 512], "{file}");
    }
    // mount's glass spheres reflect and transmit; balls' spheres reflect only.
    let mount = crate::compile::compile(&crate::nff::to_yari(&reference("mount6.nff").1), &colours)
        .unwrap()
        .world;
    assert!(mount.features.transparency && mount.features.reflection);
    let glass = &mount.surfaces[mount.objects[0].surface as usize];
    assert!(
        (glass.kdr - 0.9).abs() < 1e-12 && (glass.kdt - 0.1).abs() < 1e-12 && glass.refract == 1.5
    );
    let balls = crate::compile::compile(&crate::nff::to_yari(&reference("balls4.nff").1), &colours)
        .unwrap()
        .world;
    assert!(balls.features.reflection && !balls.features.transparency);
    let lights: Vec<_> = balls.lights.iter().map(|l| l.color).collect();
    assert_eq!(lights.len(), 3);
    assert!(lights
        .iter()
        .all(|c| (c.x - 1.0 / 3.0f64.sqrt()).abs() < 1e-12));
}

/// A converted cone compiles to a clipped quadric.
#[test]
fn cones_compile_to_clipped_quadrics() {
    let src = Source::new("c.nff", "c\n0 0 0 1\n0 0 2 0.5\n");
    let scene = crate::nff::parse(&src).unwrap();
    let world = crate::compile::compile(&scene, &crate::colour::ColourTable::builtin())
        .unwrap()
        .world;
    assert_eq!(world.features.quadrics, 1);
    match &world.objects[0].shape {
        crate::model::Shape::Quadric(q) => assert!(q.clip.len() >= 2, "{:?}", q.clip),
        s => panic!("not a quadric: {s:?}"),
    }
}
