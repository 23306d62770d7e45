//! The generators against Haines's own output: his generators' files (tetra6.nff, mount6.nff,
//! balls4.nff, as written by the SPD's `tetra`, `mount` and `balls` at their default sizes)
//! are not kept in the repository; their SHA-256 and length are, and the text our generators
//! print must have exactly those, byte for byte. The other tests then use our output, which
//! is thereby Haines's file.

use super::{generate, Database};
use crate::nff::{read, write, NffScene};
use crate::span::Source;
use sha2::{Digest, Sha256};

/// Haines's files: name, database, size factor, length in bytes, SHA-256 (hex), measured with
/// `wc -c` and `sha256sum` on the output of his generators.
const HAINES: [(&str, Database, u32, usize, &str); 3] = [
    (
        "tetra6.nff",
        Database::Tetra,
        6,
        255_616,
        "6bb2da0228e0edc67f1d780926aafc9fd1bd04c1887472a4af5b567a208dbffe",
    ),
    (
        "mount6.nff",
        Database::Mount,
        6,
        632_253,
        "c48f8bdbcc7f28e661939b9c246e41c78d562662bc9b43819000cdc9538809b9",
    ),
    (
        "balls4.nff",
        Database::Balls,
        4,
        305_317,
        "ca955919729183aff08bde63286a8b6dc4196626f99f642f150b9210ed7249bf",
    ),
];

pub(super) fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Our generator's text for one of Haines's files, checked to be that file byte for byte,
/// and read back.
fn reference(name: &str) -> (String, NffScene) {
    let &(_, db, size, len, sha) = HAINES
        .iter()
        .find(|h| h.0 == name)
        .unwrap_or_else(|| panic!("no recorded file {name}"));
    let text = write(&generate(db, size).unwrap());
    assert_eq!(text.len(), len, "{name}: length differs from Haines's file");
    assert_eq!(
        hex(&Sha256::digest(text.as_bytes())),
        sha,
        "{name}: text differs from Haines's file"
    );
    let src = Source::new(name, text.clone());
    let (scene, _) = read(&src).unwrap_or_else(|d| panic!("{}", d.render(&src)));
    (text, scene)
}

#[test]
fn tetra6_matches_haines() {
    reference("tetra6.nff");
}

#[test]
fn mount6_matches_haines() {
    reference("mount6.nff");
}

#[test]
fn balls4_matches_haines() {
    reference("balls4.nff");
}

/// The text read back prints the same text (the NFF reader and writer agree).
#[test]
fn haines_files_read_back_to_the_same_text() {
    for (name, ..) in HAINES {
        let (text, scene) = reference(name);
        assert_eq!(write(&scene), text, "{name}");
    }
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
        // Haines's sqrt(n)/(2n) for n lights, as each light.
        let a = crate::nff::to_yari::haines_intensity(world.lights.len());
        assert_eq!(world.ambient, glam::DVec3::splat(a), "{file}");
        assert!(world
            .lights
            .iter()
            .all(|l| l.color == glam::DVec3::splat(a)));
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
        .all(|c| (c.x - 3.0f64.sqrt() / 6.0).abs() < 1e-12));
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

/// The files the tests render are Haines's files, under his names.
#[test]
fn reference_files_are_written_under_haines_names() {
    let dir = std::env::temp_dir().join(format!("yari-spd-ref-{}", std::process::id()));
    super::write_reference_files(&dir).unwrap();
    for (name, _, _, len, sha) in HAINES {
        let bytes = std::fs::read(dir.join(name)).unwrap();
        assert_eq!(bytes.len(), len, "{name}");
        assert_eq!(hex(&Sha256::digest(&bytes)), sha, "{name}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
