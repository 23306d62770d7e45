//! OBJ, PLY and glTF meshes written by `sunray convert` and `sunray spd` (the fixture
//! generators) from Haines's tetra (flat triangles) and teapot (patches with vertex normals,
//! and flat faces): every format and encoding compiles to the NFF's own geometry (glTF's
//! 32-bit floats: where the NFF's coordinates are floats), renders to one image, and bad files
//! get one line with the file and the place, exit 2, and no output.

use super::*;
use yari::colour::ColourTable;
use yari::mesh::write::PlyEncoding;
use yari::model::{Shape, World};

/// The world's shapes (surfaces differ: the NFF's fills against a mesh's grey).
fn shapes(world: &World) -> Vec<Shape> {
    world.objects.iter().map(|o| o.shape.clone()).collect()
}

/// `sunray spd DB --size SIZE -o OUT` (the format by OUT's extension): OUT's bytes.
fn spd_to(db: &str, size: &str, out: &Path) -> Vec<u8> {
    assert_ok(&sunray(&[
        "spd",
        db,
        "--size",
        size,
        "-o",
        out.to_str().unwrap(),
    ]));
    std::fs::read(out).unwrap()
}

fn load(path: &Path) -> yari::load::Loaded {
    yari::load::load_path(path, &ColourTable::builtin())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn every_mesh_format_holds_the_nff_geometry_and_renders_one_image() {
    let dir = scratch("meshes");
    for (db, size, triangles, normals) in [("tetra", "3", 64, false), ("teapot", "2", 248, true)] {
        let nff = dir.join(format!("{db}.nff"));
        spd_to(db, size, &nff);
        let want = shapes(&load(&nff).world);
        // `sunray convert` writes OBJ and binary little-endian PLY from the NFF file; the
        // library's writer the other two encodings, from the same file.
        let path = |name: &str| dir.join(format!("{db}-{name}"));
        for name in ["m.obj", "le.ply", "m.glb"] {
            let out = path(name);
            assert_ok(&sunray(&[
                "convert",
                nff.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ]));
        }
        let src = yari::span::Source::new("n", std::fs::read_to_string(&nff).unwrap());
        let faces = yari::mesh::faces_of(&yari::nff::read(&src).unwrap().0).unwrap();
        for (name, e) in [
            ("ascii.ply", PlyEncoding::Ascii),
            ("be.ply", PlyEncoding::BinaryBigEndian),
        ] {
            let mut bytes = Vec::new();
            yari::mesh::write::ply(&faces, e, &mut bytes).unwrap();
            std::fs::write(path(name), bytes).unwrap();
        }
        let mut images = Vec::new();
        for name in ["m.obj", "le.ply", "ascii.ply", "be.ply", "m.glb"] {
            let p = path(name);
            let loaded = load(&p);
            // glTF holds 32-bit floats: tetra's coordinates are (multiples of powers of two),
            // the teapot's are not, so its triangles are rounded.
            let exact = name != "m.glb" || db == "tetra";
            let got = shapes(&loaded.world);
            if exact {
                assert_eq!(got, want, "{db} {name}");
            } else {
                assert_eq!(
                    got.len() as u64,
                    triangles,
                    "{db} {name}: triangles, quads fanned"
                );
            }
            let mesh = loaded.mesh.unwrap();
            assert_eq!(
                (mesh.triangles, mesh.normals),
                (triangles, normals),
                "{name}"
            );
            let png = dir.join(format!("{db}-{name}.png"));
            let p = p.to_str().unwrap();
            assert_ok(&sunray(&[
                "render",
                "-q",
                "--resolution",
                "48x48",
                p,
                "-o",
                png.to_str().unwrap(),
            ]));
            images.push(std::fs::read(&png).unwrap());
            let check = sunray(&["check", p]);
            assert_ok(&check);
            let said = String::from_utf8_lossy(&check.stdout).to_string();
            assert!(said.contains(&format!("({triangles} triangles)")), "{said}");
        }
        assert!(
            images.iter().all(|png| *png == images[0]),
            "{db}: the images differ"
        );
        // `sunray spd` writes the scene's own polygons (not rounded as NFF's text is): the
        // same geometry as its YARI.
        let (spd_yari, spd_ply) = (path("spd.yari"), path("spd.ply"));
        for out in [&spd_yari, &spd_ply] {
            spd_to(db, size, out);
        }
        assert_eq!(
            shapes(&load(&spd_ply).world),
            shapes(&load(&spd_yari).world),
            "{db}"
        );
        // convert writes a mesh's polygons as YARI.
        let yari_out = path("m.yari");
        let obj = path("m.obj");
        assert_ok(&sunray(&[
            "convert",
            obj.to_str().unwrap(),
            "-o",
            yari_out.to_str().unwrap(),
        ]));
        assert_eq!(shapes(&load(&yari_out).world), want, "{db}: converted");
    }
}

#[test]
fn bad_meshes_get_one_line_exit_2_and_no_output() {
    let dir = scratch("bad-meshes");
    let whole = spd_to("tetra", "1", &dir.join("t.ply"));
    let glb = spd_to("tetra", "1", &dir.join("t.glb"));
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "range.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n".to_vec(),
            "range.obj:4: face: vertex index 9 is out of range",
        ),
        (
            "two.obj",
            b"v 0 0 0\nv 1 0 0\nf 1 2\n".to_vec(),
            "two.obj:3: face has 2 corners (at least 3)",
        ),
        (
            "nan.obj",
            b"v 0 0 0\nv 1 nan 0\n".to_vec(),
            "nan.obj:2: v: nan is not a finite number",
        ),
        (
            "mtl.obj",
            b"mtllib gone.mtl\nv 0 0 0\n".to_vec(),
            "mtl.obj:1: cannot read its material library gone.mtl",
        ),
        (
            "cut.ply",
            whole[..whole.len() - 5].to_vec(),
            "cut.ply: byte ",
        ),
        ("cut.glb", glb[..glb.len() / 2].to_vec(), "cut.glb: "),
    ];
    for (name, bytes, want) in cases {
        let input = dir.join(name);
        std::fs::write(&input, bytes).unwrap();
        let png = dir.join(format!("{name}.png"));
        let out = sunray(&[
            "render",
            "-q",
            input.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert!(err.contains(want), "{name}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{name}: {err}");
        assert!(!png.exists(), "{name}: an image was written");
    }
    let out = sunray(&[
        "render",
        "-q",
        dir.join("missing.ply").to_str().unwrap(),
        "-o",
        "x.png",
    ]);
    assert_ne!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.ply"));
}

/// A YARI scene placing meshes, run as a user runs it from another folder: `check` names each
/// mesh, and `render` of the scene, of its compiled `.srw` and of its flat YARI (`convert`)
/// give one image, the same whichever format holds the triangles.
#[test]
fn a_yari_scene_places_meshes_relative_to_itself() {
    let dir = scratch("placed");
    std::fs::create_dir_all(dir.join("models")).unwrap();
    let path = |n: &str| dir.join(n);
    let arg = |p: &Path| p.to_str().unwrap().to_string();
    let mut images = Vec::new();
    for ext in ["ply", "obj"] {
        spd_to("teapot", "2", &path(&format!("models/teapot.{ext}")));
        let scene = path(&format!("placed-{ext}.yari"));
        std::fs::write(
            &scene,
            format!(
                "resolution(40,32);\ncamera(position = 0,-8,3; at = 0,0,0.5; up = 0,0,1; angle = 20);\n\
                 light(position = 4,-5,9; color = white);\nbegin\n  attribute(color = 0.9,0.6,0.2);\n  \
                 begin rotate(0,0,40); scale(0.7,0.7,0.7); mesh(file = \"models/teapot.{ext}\"); end\n  \
                 translate(1.2,0,0);\n  mesh(file = \"models/teapot.{ext}\"; materials = file);\nend\n"
            ),
        )
        .unwrap();
        let check = Command::new(env!("CARGO_BIN_EXE_sunray"))
            .current_dir(std::env::temp_dir())
            .args(["check", &arg(&scene)])
            .output()
            .unwrap();
        assert_ok(&check);
        let said = String::from_utf8_lossy(&check.stdout);
        let mesh = format!("mesh {}: ", path(&format!("models/teapot.{ext}")).display());
        assert_eq!(said.matches(&mesh).count(), 2, "{said}");
        assert!(said.contains("(248 triangles)"), "{said}");
        let (srw, flat) = (
            path(&format!("{ext}.srw")),
            path(&format!("{ext}-flat.yari")),
        );
        assert_ok(&sunray(&["compile", &arg(&scene), "-o", &arg(&srw)]));
        assert_ok(&sunray(&["convert", &arg(&scene), "-o", &arg(&flat)]));
        assert!(!std::fs::read_to_string(&flat).unwrap().contains("mesh("));
        for input in [&scene, &srw, &flat] {
            let png = path(&format!(
                "{}.png",
                input.file_name().unwrap().to_str().unwrap()
            ));
            let out = Command::new(env!("CARGO_BIN_EXE_sunray"))
                .current_dir(std::env::temp_dir())
                .args(["render", "-q", &arg(input), "-o", &arg(&png)])
                .output()
                .unwrap();
            assert_ok(&out);
            images.push(std::fs::read(&png).unwrap());
        }
    }
    assert!(images.iter().all(|i| *i == images[0]), "the images differ");
    std::fs::remove_dir_all(&dir).unwrap();
}
