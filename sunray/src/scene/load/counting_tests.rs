//! A job's scene is counted, not built ([`compile_for_job`](super::compile_for_job)): the
//! counting builder must give what building the primitives gives, on every SPD database,
//! every example and the built-in scene, degenerate and unbounded objects included.

use crate::geometry::primitives::{PrimitiveCounts, PrimitivesBuilder};
use std::path::Path;
use yari::colour::ColourTable;
use yari::load::InputKind;

/// The counts and dropped objects of the scene `text` by both builders.
fn both(name: &str, text: &str, kind: InputKind) -> [(PrimitiveCounts, usize, String); 2] {
    let table = ColourTable::builtin();
    let (mut built, mut counted) = (PrimitivesBuilder::new(), PrimitivesBuilder::counting());
    yari::load::stream_str(name, text, kind, &table, &mut |surfaces, o| {
        built.add(surfaces, &o);
        counted.add(surfaces, &o);
    })
    .unwrap_or_else(|e| panic!("{name}: {e}"));
    let summary = |b: &PrimitivesBuilder| {
        let dropped: Vec<String> = b.dropped().iter().map(|d| format!("{d:?}")).collect();
        (b.counts(), b.objects(), dropped.join("; "))
    };
    let (c, b) = (summary(&counted), summary(&built));
    // The built primitives, finished, count the same as while building.
    let objects = built.objects();
    let (prims, _) = built.finish();
    assert_eq!(PrimitiveCounts::of(&prims), b.0, "{name}");
    assert_eq!(objects, b.1);
    [b, c]
}

#[test]
fn counting_gives_the_counts_and_drops_of_building() {
    let mut inputs: Vec<(String, String, InputKind)> = Vec::new();
    for db in yari::spd::Database::ALL {
        let size = *db.sizes().start();
        let scene = yari::spd::generate(db, size).unwrap();
        let name = format!("{}{size}.nff", db.name());
        inputs.push((name, yari::nff::write::write(&scene), InputKind::Nff));
    }
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    for sub in ["thesis", "modeler", "smooth"] {
        for f in std::fs::read_dir(examples.join(sub)).unwrap().flatten() {
            let p = f.path();
            if p.extension().is_some_and(|e| e == "yari") {
                let text = std::fs::read_to_string(&p).unwrap();
                inputs.push((p.display().to_string(), text, InputKind::Yari));
            }
        }
    }
    inputs.push((
        "built-in".into(),
        super::DEFAULT_SCENE.into(),
        InputKind::Yari,
    ));
    // A polygon that the compiler lets through and an unbounded object (a quadric without a
    // clip box).
    inputs.push((
        "degenerate.yari".into(),
        "begin attribute(color = 1,1,1 ; kdr = 1);\n\
         polygon(vertices = 3; 0,0,0 0,0,0 1,1,1);\n\
         quadric(1 0 0 0 1 0 0 -1 0 0);\n\
         sphere(center = 0,0,0 ; radius = 1);\nend\n"
            .into(),
        InputKind::Yari,
    ));
    let (mut dropped, mut unbounded, mut others) = (dropped_objects(), 0, 0);
    for (name, text, kind) in &inputs {
        let [built, counted] = both(name, text, *kind);
        assert_eq!(counted, built, "{name}");
        dropped += usize::from(!built.2.is_empty());
        unbounded += built.0.unbounded;
        others += built.0.others;
    }
    // The rules' every branch was taken somewhere.
    assert!(unbounded >= 1 && others >= 1, "{unbounded} {others}");
    assert!(dropped >= 2);
}

/// Objects the compiler never makes but a model file may hold (the builder drops them),
/// given to both builders: how many were dropped, alike.
fn dropped_objects() -> usize {
    use yari::model::{Object, Shape};
    let o = |shape| Object {
        shape,
        surface: 0,
        motion: glam::DVec3::ZERO,
    };
    let p = glam::DVec3::ONE;
    let objects = [
        o(Shape::Sphere {
            center: p,
            radius: 0.0,
        }),
        o(Shape::Polygon {
            vertices: vec![p, p, p],
        }),
        o(Shape::Sphere {
            center: p,
            radius: 1.0,
        }),
    ];
    let surfaces = [yari::model::Surface::default()];
    let (mut built, mut counted) = (PrimitivesBuilder::new(), PrimitivesBuilder::counting());
    for obj in &objects {
        built.add(&surfaces, obj);
        counted.add(&surfaces, obj);
    }
    let reasons = |b: &PrimitivesBuilder| format!("{:?}", b.dropped());
    assert_eq!(reasons(&counted), reasons(&built));
    assert_eq!(counted.counts(), built.counts());
    assert_eq!(counted.counts().spheres, 1);
    built.dropped().len()
}
