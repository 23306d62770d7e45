//! The `mesh(file = ...)` statement as a user writes it: a YARI file beside its meshes.

use super::*;
use crate::ast::{BodyItem, Primitive, Spanned};
use crate::mesh::{Face, Surface};
use crate::span::Span;

const PREAMBLE: &str =
    "resolution(16,16);\ncamera(position = 0,0,9; at = 0,0,0; up = 0,1,0; angle = 20);\n\
                        light(position = 4,5,9; color = white);\n";

/// A folder of its own for one test.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("yari-mesh-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("models")).unwrap();
    dir
}

/// Two triangles and a quad, the quad with a normal per corner.
fn faces() -> Vec<Face> {
    let tri = |z: f64| Face {
        vertices: vec![[0.0, 0.0, z], [1.0, 0.0, z], [0.0, 1.0, z]],
        normals: None,
        surface: Surface::Default,
    };
    let quad = Face {
        vertices: vec![
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.5],
            [0.0, 1.0, 1.5],
        ],
        normals: Some(vec![[0.0, -0.7, 1.0]; 4]),
        surface: Surface::Default,
    };
    vec![tri(0.0), tri(-0.5), quad]
}

fn load(path: &Path) -> Result<Loaded, LoadError> {
    load_path(path, &ColourTable::builtin())
}

#[test]
fn a_mesh_under_a_graphics_stack_is_its_triangles_written_out_in_full() {
    let dir = folder("stack");
    let mut ply = Vec::new();
    crate::mesh::write::ply(
        &faces(),
        ply_rs_bw::ply::Encoding::BinaryLittleEndian,
        &mut ply,
    )
    .unwrap();
    std::fs::write(dir.join("models/part.ply"), ply).unwrap();
    let stack = "attribute(color = red; kdr = 0.6);\n  translate(1,2,3);\n  rotate(10,20,30);\n  \
                 scale(2,1,0.5);\n  transform(1 0.1 0 0 0 1 0 0 0 0 1 0.25);\n  motion(0,0.1,0);\n";
    let placed = format!(
        "{PREAMBLE}begin\n  {stack}  mesh(file = \"models/part.ply\");\n  sphere(center = 0,0,0; radius = 0.5);\nend\n"
    );
    std::fs::write(dir.join("placed.yari"), &placed).unwrap();
    // The same triangles as polygons in the scene itself, under the same statements.
    let mut scene = crate::parse::parse(&Source::new("placed.yari", placed.as_str())).unwrap();
    let at = scene
        .body
        .items
        .iter()
        .position(|i| matches!(i.node, BodyItem::Mesh(_)))
        .unwrap();
    let polygons = faces().into_iter().map(|f| {
        let p = Primitive::Polygon {
            vertices: f.vertices,
            normals: f.normals,
        };
        Spanned::new(BodyItem::Primitive(p), Span::default())
    });
    scene.body.items.splice(at..=at, polygons);
    let full = crate::writer::write_scene(&scene);
    assert!(!full.contains("mesh("), "{full}");

    let from_mesh = load(&dir.join("placed.yari")).unwrap();
    let written = load_str("full.yari", full, InputKind::Yari, &ColourTable::builtin()).unwrap();
    assert_eq!(from_mesh.world, written.world);
    assert_eq!(from_mesh.world.features.polygons, 3);
    assert_eq!(from_mesh.world.objects.len(), 4);
    assert!(
        from_mesh.warnings.items.is_empty(),
        "{:?}",
        from_mesh.warnings
    );
    // What was placed, found beside the scene (the test runs elsewhere).
    assert_eq!(from_mesh.meshes.len(), 1);
    assert_eq!(from_mesh.meshes[0].path, dir.join("models/part.ply"));
    assert_eq!(from_mesh.meshes[0].summary.triangles, 4);
    assert_eq!(from_mesh.inputs(), [dir.join("models/part.ply")]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_files_own_materials_are_used_only_when_asked_and_end_with_the_statement() {
    let dir = folder("materials");
    std::fs::write(
        dir.join("models/box.obj"),
        "mtllib box.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl blue\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(dir.join("models/box.mtl"), "newmtl blue\nKd 0 0 1\n").unwrap();
    let scene = |materials: &str| {
        format!(
            "{PREAMBLE}begin\n attribute(color = red);\n mesh(file = \"models/box.obj\"{materials});\n \
             sphere(center = 3,0,0; radius = 1);\nend\n"
        )
    };
    let colours = |text: String| {
        std::fs::write(dir.join("s.yari"), text).unwrap();
        let loaded = load(&dir.join("s.yari")).unwrap();
        let w = &loaded.world;
        let of = |k: usize| w.surfaces[w.objects[k].surface as usize].color.to_array();
        (of(0), of(1), loaded.inputs())
    };
    let red = [1.0, 0.0, 0.0];
    let (mesh, sphere, _) = colours(scene(""));
    assert_eq!(
        (mesh, sphere),
        (red, red),
        "the current attribute by default"
    );
    let (mesh, sphere, _) = colours(scene("; materials = current"));
    assert_eq!((mesh, sphere), (red, red));
    let (mesh, sphere, inputs) = colours(scene("; materials = file"));
    assert_eq!(
        (mesh, sphere),
        ([0.0, 0.0, 1.0], red),
        "the file's, then red again"
    );
    // The material library is one of the files the world was made from.
    assert_eq!(
        inputs,
        [dir.join("models/box.obj"), dir.join("models/box.mtl")]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn what_the_compiler_says_of_a_meshs_faces_is_said_once_at_the_statement() {
    let dir = folder("faces");
    // Two faces with no area, then a good one.
    std::fs::write(
        dir.join("models/flat.obj"),
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 3 2 1\nf 1 2 4\n",
    )
    .unwrap();
    let text = format!("{PREAMBLE}begin\n  mesh(file = \"models/flat.obj\");\nend\n");
    std::fs::write(dir.join("s.yari"), text).unwrap();
    let loaded = load(&dir.join("s.yari")).unwrap();
    assert_eq!(loaded.world.objects.len(), 1);
    let shown = loaded.render_warnings();
    assert_eq!(loaded.warnings.items.len(), 1, "{shown}");
    assert!(
        shown.starts_with(&format!(
            "{}:5:3: warning: in models/flat.obj: degenerate polygon dropped: it has no area (2 faces)",
            dir.join("s.yari").display()
        )),
        "{shown}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_mesh_that_cannot_be_read_is_an_error_at_its_name_in_the_mesh_readers_words() {
    let dir = folder("bad");
    std::fs::write(dir.join("models/bad.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap();
    std::fs::write(dir.join("models/notes.txt"), "hello\n").unwrap();
    let error = |file: &str| {
        let text = format!("{PREAMBLE}begin\n  mesh(file = \"{file}\");\nend\n");
        std::fs::write(dir.join("s.yari"), text).unwrap();
        let e = load(&dir.join("s.yari")).unwrap_err().to_string();
        let first = e.lines().next().unwrap().to_string();
        let caret = e.lines().nth(2).unwrap_or("").trim().to_string();
        (first, caret)
    };
    let at = format!("{}:5:15: error: ", dir.join("s.yari").display());
    let (first, caret) = error("models/bad.obj");
    assert!(
        first.starts_with(&format!("{at}{}", dir.join("models/bad.obj:3: ").display())),
        "{first}"
    );
    assert!(first.contains("out of range"), "{first}");
    assert_eq!(caret, "^~~~~~~~~~~~~~~~");
    let (first, _) = error("models/missing.ply");
    assert!(
        first.starts_with(&format!(
            "{at}cannot read {}",
            dir.join("models/missing.ply").display()
        )),
        "{first}"
    );
    let (first, _) = error("models/notes.txt");
    assert_eq!(
        first,
        format!("{at}`models/notes.txt` is not a mesh file: expected .obj, .ply, .gltf or .glb")
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_writer_keeps_the_statement() {
    let text =
        "begin\n  mesh(file = \"a b/c.ply\");\n  mesh(file = \"/d.glb\"; materials = file);\nend\n";
    let scene = crate::parse::parse(&Source::new("s.yari", text)).unwrap();
    let written = crate::writer::write_scene(&scene);
    assert_eq!(written, text);
    let mut again = crate::parse::parse(&Source::new("s.yari", written.as_str())).unwrap();
    let mut first = scene.clone();
    crate::writer::erase_spans(&mut again);
    crate::writer::erase_spans(&mut first);
    assert_eq!(again, first);
}
