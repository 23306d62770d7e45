use super::*;
use crate::export::to_yari;
use crate::project::Camera;
use yari::colour::ColourTable;

fn compile(text: &str) -> yari::model::World {
    let scene = yari::parse::parse(&Source::new("t", text)).unwrap();
    yari::compile::compile(&scene, &ColourTable::builtin())
        .unwrap()
        .world
}

/// A project using every object kind, property and setting the modeler knows.
pub(crate) fn everything() -> Project {
    let mut p = Project::new_default();
    p.settings.samples = Some(4);
    p.settings.target_error = Some(0.0125);
    p.settings.background = Some(Color::Named("UNC_Blue".into()));
    p.settings.camera = Some(Camera {
        position: [1.5, -2.0, 30.0],
        at: [0.0, 1.0, 0.0],
        up: [0.0, 1.0, 0.0],
        angle: 17.25,
        aperture: Some(0.1),
        focus: Some(29.0),
    });
    p.settings.lights.push(Light {
        name: "fill.2".into(),
        position: [-5.0, 3.0, 1e-7],
        color: Color::Rgb([0.3, 0.2, 0.1]),
        radius: Some(0.5),
    });
    let shiny = Surface {
        color: Some(Color::Rgb([0.1, 0.2, 1.0 / 3.0])),
        kdr: Some(0.4),
        kdt: Some(0.9),
        ka: Some(0.5),
        phong: Some(160.0),
        refract: Some(1.5),
        texture: Some(Texture {
            id: 1.0,
            color: [0.5176, 0.4118, 0.2784],
            scale: [1.0, 2.0, 3.0],
        }),
        gloss: Some(2.0),
        translucency: Some(1.0),
        transmissivity: Some(0.8),
        texture_space: Some([1.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, -0.25]),
    };
    let ball = Object {
        name: "ball".into(),
        surface: Some(shiny),
        transforms: vec![
            Transform::Translate([1.0, 2.0, 3.0]),
            Transform::Rotate([10.0, 20.0, 30.0]),
            Transform::Scale([1.0, 2.0, 1.0]),
            Transform::Motion([0.0, 0.1, 0.0]),
            Transform::Matrix([1.0, 0.1, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 2.0]),
        ],
        primitives: vec![Primitive::Sphere {
            center: [0.0, 0.0, -1.0],
            radius: 0.75,
        }],
        children: vec![],
    };
    let plate = Object {
        name: "plate".into(),
        surface: None,
        transforms: vec![],
        primitives: vec![
            Primitive::Polygon {
                vertices: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.1]],
                normals: Some(vec![[0.0, 0.0, 1.0], [0.1, 0.0, 1.0], [0.0, -0.1, 1.0]]),
            },
            Primitive::Quadric {
                coeffs: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0],
                clip: vec![
                    Clip::Box {
                        min: [-1.0, -1.0, 0.0],
                        max: [1.0, 1.0, 2.0],
                    },
                    Clip::Plane {
                        normal: [0.0, 1.0, 1.0],
                        offset: 0.5,
                    },
                ],
            },
        ],
        children: vec![],
    };
    let empty = Object {
        name: "empty".into(),
        ..Object::default()
    };
    let inner = Object {
        name: "inner".into(),
        surface: Some(Surface {
            color: Some(Color::Named("red".into())),
            ..Surface::default()
        }),
        children: vec![plate, empty],
        ..Object::default()
    };
    let outer = Object {
        name: "outer".into(),
        surface: Some(Surface {
            kdr: Some(0.5),
            ..Surface::default()
        }),
        children: vec![inner, ball],
        ..Object::default()
    };
    p.objects.push(outer);
    p.objects.push(Object {
        name: "lonely.1".into(),
        primitives: vec![Primitive::Sphere {
            center: [9.0, 9.0, 9.0],
            radius: 1.0,
        }],
        ..Object::default()
    });
    p.objects.push(Object {
        name: "statue".into(),
        transforms: vec![Transform::Scale([2.0, 2.0, 2.0])],
        primitives: vec![
            Primitive::Mesh {
                file: "scans/statue 2.ply".into(),
                materials_file: true,
            },
            Primitive::Mesh {
                file: "/abs/base.obj".into(),
                materials_file: false,
            },
        ],
        ..Object::default()
    });
    p
}

#[test]
fn project_to_yari_to_project_keeps_every_object_name_and_property() {
    let p = everything();
    let text = to_yari(&p);
    let back = from_yari(&Source::new("export.yari", text.as_str())).unwrap();
    assert_eq!(back.settings, p.settings);
    assert_eq!(back.objects, p.objects);
    // And once more from the re-read project: the text is a fixed point.
    assert_eq!(to_yari(&back), text);
    // A mesh is its statement, kept as written.
    assert!(
        text.contains("mesh(file = \"scans/statue 2.ply\"; materials = file);")
            && text.contains("mesh(file = \"/abs/base.obj\");"),
        "{text}"
    );
}

#[test]
fn names_come_from_the_comment_right_before_a_block() {
    let text = "/* key */ light(position=1,2,3; color=white);\nlight(position=0,0,0; color=white);\n\
                begin\n  /* a long sentence */\n  begin sphere(center=0,0,0; radius=1); end\n  /* lamp */\n  begin end\nend\n";
    let p = from_yari(&Source::new("t", text)).unwrap();
    assert_eq!(
        p.settings
            .lights
            .iter()
            .map(|l| l.name.as_str())
            .collect::<Vec<_>>(),
        ["key", "light1"]
    );
    assert_eq!(p.object_names(), ["object1", "lamp"]);
    assert_eq!(comment_name("/* x */ ", 8), Some("x".into()));
    assert_eq!(comment_name("/* x */ y ", 10), None);
}

#[test]
fn duplicate_comment_names_are_made_unique() {
    let text = "begin /* a */ begin end /* a */ begin end begin end end";
    let p = from_yari(&Source::new("t", text)).unwrap();
    assert_eq!(p.object_names(), ["a", "a.1", "object1"]);
}

#[test]
fn mid_block_transforms_and_attributes_become_parts_that_render_the_same() {
    let text = "background(color=black);\nbegin\n attribute(color=green);\n sphere(center=0,0,0; radius=1);\n \
        /* g */ begin\n  translate(1,0,0); attribute(color=blue); rotate(0,90,0);\n  sphere(center=0,0,1; radius=1);\n  scale(2,2,2);\n  \
        polygon(vertices=3; 0 0 0 1 0 0 0 1 0);\n  attribute(color=red);\n  begin rotate(90,0,0); sphere(center=0,1,0; radius=0.5); end\n  \
        /* h */ begin attribute(kdr=0.1); sphere(center=3,0,0; radius=1); end\n end\n translate(0,5,0);\n sphere(center=0,0,0; radius=2);\nend\n";
    let p = from_yari(&Source::new("t", text)).unwrap();
    assert_eq!(
        p.object_names(),
        ["part1", "g", "g.1", "g.2", "g.3", "h", "part2"]
    );
    // Groups carry no transformations; their header moved into the parts.
    let g = p.object("g").unwrap();
    assert!(g.transforms.is_empty() && g.primitives.is_empty());
    assert_eq!(p.object("g.3").unwrap().transforms.len(), 4);
    assert_eq!(p.object("h").unwrap().transforms.len(), 3);
    // What renders is unchanged: the compiled worlds are identical.
    assert_eq!(compile(&to_yari(&p)), compile(text));
}

#[test]
fn the_thesis_scenes_open_as_projects_and_compile_to_the_same_world() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/thesis");
    for file in ["tetra16.yari", "cubes.yari"] {
        let path = format!("{dir}/{file}");
        let Ok(text) = std::fs::read_to_string(&path) else {
            panic!("missing reference scene {path}");
        };
        let p = from_yari(&Source::new(file, text.as_str())).unwrap();
        assert!(!p.objects.is_empty(), "{file}");
        let exported = to_yari(&p);
        assert_eq!(compile(&exported), compile(&text), "{file}");
        // A second round trip changes nothing.
        let again = from_yari(&Source::new(file, exported.as_str())).unwrap();
        assert_eq!(again.objects, p.objects, "{file}");
    }
}

#[test]
fn a_bad_yari_file_is_reported_with_its_position() {
    let e = from_yari(&Source::new(
        "bad.yari",
        "begin\n sphere(center=0,0,0; radius=);\nend\n",
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("bad.yari:2:"), "{e}");
}

#[test]
fn an_empty_attribute_reads_back_as_a_default_surface() {
    let mut p = Project::new_default();
    p.objects.push(Object {
        name: "plain".into(),
        surface: Some(Surface::default()),
        primitives: vec![Primitive::Sphere {
            center: [0.0; 3],
            radius: 1.0,
        }],
        ..Object::default()
    });
    let back = from_yari(&Source::new("t", to_yari(&p).as_str())).unwrap();
    assert_eq!(back.objects, p.objects);
}
