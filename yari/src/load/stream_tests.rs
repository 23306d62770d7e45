//! The streaming loaders: the model file bytes of every SPD scene (small sizes) and of the
//! examples equal those of the whole-tree path and those `sunray compile` wrote before the
//! readers streamed; a file's diagnostics, shown from an excerpt, equal those of its whole
//! text, truncated texts included.

use super::*;
use crate::modelfile::{fnv1a, ModelEncoder};
use crate::spd::{generate, Database};

/// Each SPD scene at a small size, with the length and FNV-1a of the `.srw` that
/// `sunray spd NAME --size N -o x.nff; sunray compile x.nff -o x.srw` wrote before.
const SPD_MODELS: [(Database, u32, usize, u64); 11] = [
    (Database::Tetra, 2, 1922, 0x501f2933f56fa90c),
    (Database::Mount, 1, 1451, 0xebfaf3911616a8db),
    (Database::Balls, 1, 1242, 0xade09b6c10d9205d),
    (Database::Gears, 1, 25456, 0x62b87fba595d54ad),
    (Database::Rings, 1, 13737, 0x9da1516359ed30cb),
    (Database::Tree, 2, 3833, 0x883f40e0979d9a09),
    (Database::Teapot, 1, 9550, 0x1b3fc2298e781bbd),
    (Database::Lattice, 1, 5705, 0x6437578d3cad3051),
    (Database::Shells, 1, 21278, 0xfc5cbb6ec9cba460),
    (Database::Jacks, 1, 1775, 0x55473ab3163f8e71),
    (Database::Sombrero, 1, 190618, 0x85cc99f03da7131b),
];

/// The examples, with the length and FNV-1a of their `.srw` as written before.
const EXAMPLE_MODELS: [(&str, usize, u64); 5] = [
    ("thesis/cubes.yari", 3727, 0xb8d00e6b985a2a6d),
    ("thesis/tetra16.yari", 1922, 0x4c4b8aa801ecc61a),
    ("smooth/terminator.yari", 12578, 0xfeeea8e4e63d5413),
    ("modeler/bat.yari", 4496, 0x1dbbd93ac38fec5c),
    ("modeler/king.yari", 33606, 0x6580c90e706743a9),
];

/// A directory of one test's own.
fn dir(test: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("yari-stream-{test}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The model file of `path`, read as a stream and encoded as its objects arrive.
fn streamed(path: &Path) -> Vec<u8> {
    let mut encoder = ModelEncoder::new();
    let loaded = stream_path(path, &ColourTable::builtin(), &mut |_, o| encoder.push(&o))
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(loaded.world.objects.is_empty());
    encoder.finish(&loaded.world).unwrap()
}

/// The model file of `text` by the whole-tree path: the syntax tree, then the world.
fn whole(text: &str, kind: InputKind) -> Vec<u8> {
    let src = Source::new("t", text);
    let scene = match kind {
        InputKind::Nff => crate::nff::parse(&src),
        InputKind::Off => crate::off::parse(&src),
        _ => crate::parse::parse(&src),
    }
    .unwrap();
    let world = crate::compile::compile(&scene, &ColourTable::builtin())
        .unwrap()
        .world;
    modelfile::to_bytes(&world).unwrap()
}

#[test]
fn spd_scenes_stream_to_the_model_files_they_compiled_to_before() {
    let d = dir("spd");
    for (db, size, len, hash) in SPD_MODELS {
        let text = crate::nff::write(&generate(db, size).unwrap());
        let path = d.join(format!("{}.nff", db.name()));
        std::fs::write(&path, &text).unwrap();
        let bytes = streamed(&path);
        assert_eq!(bytes, whole(&text, InputKind::Nff), "{}", db.name());
        assert_eq!(
            (bytes.len(), fnv1a(&bytes)),
            (len, hash),
            "{} {size}",
            db.name()
        );
    }
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn examples_stream_to_the_model_files_they_compiled_to_before() {
    for (name, len, hash) in EXAMPLE_MODELS {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../examples")
            .join(name);
        let text = std::fs::read_to_string(&path).unwrap();
        let bytes = streamed(&path);
        assert_eq!(bytes, whole(&text, InputKind::Yari), "{name}");
        assert_eq!((bytes.len(), fnv1a(&bytes)), (len, hash), "{name}");
    }
}

#[test]
fn an_off_mesh_streams_to_the_model_file_of_its_tree() {
    let d = dir("off");
    let off = "NOFF\n# a tetrahedron\n4 4 6\n0 0 0 0 0 -1\n1 0 0 1 0 0\n0 1 0 0 1 0\n\
               0 0 1 0 0 0\n3 0 2 1\n3 0 1 3 255 0 0\n3 0 3 2 1 0 0 1\n3 1 2 3\n";
    let path = d.join("t.off");
    std::fs::write(&path, off).unwrap();
    assert_eq!(streamed(&path), whole(off, InputKind::Off));
    std::fs::remove_dir_all(&d).unwrap();
}

/// What loading `text` as a file named `name` says (its summary, or its error), and the
/// same for the text whole.
fn both(name: &str, text: &str, kind: InputKind) -> (String, String) {
    let d = dir("diagnostics");
    let path = d.join(name);
    std::fs::write(&path, text).unwrap();
    let say = |r: Result<Loaded, LoadError>| match r {
        Ok(l) => format!("ok {}", l.render_warnings()),
        Err(e) => format!("error {e}"),
    };
    let colours = ColourTable::builtin();
    let shown = path.display().to_string();
    let file = say(stream_path(&path, &colours, &mut |_, _| {}));
    let text = say(load_str(&shown, text, kind, &colours));
    std::fs::remove_file(&path).unwrap();
    (file, text)
}

#[test]
fn a_streamed_file_shows_the_diagnostics_of_its_whole_text() {
    let nff = "b 0.1 0.2 0.3\nv\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 30\nhither 1\n\
               resolution 4 4\nl 0 0 5\nf 1 1 1 1.5 0 1 0 1\n# é comment\ns 0 0 0 1\n\
               pp 3\n0 0 0 0 0 0\n1 0 0 0 0 1\n0 1 0 0 0 1\np 3 0 0 0 0 0 0 1 0 0\nc 0 0 0 1 0 0 1 1\n";
    for cut in 0..=nff.len() {
        if nff.is_char_boundary(cut) {
            let (file, text) = both("cut.nff", &nff[..cut], InputKind::Nff);
            assert_eq!(file, text, "cut at {cut}");
        }
    }
    for bad in [
        "s 0 0 0 -1\nq\n",
        "v\nfrom 0 0 0\nat 0 0 0\n",
        "p 2 0 0 0",
        "f 1 1 1 1 0 1 x 1\n",
    ] {
        let (file, text) = both("bad.nff", bad, InputKind::Nff);
        assert!(file.starts_with("error "), "{file}");
        assert_eq!(file, text);
    }
    let off = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 0.5 0.5 0.5\n";
    for cut in 0..=off.len() {
        let (file, text) = both("cut.off", &off[..cut], InputKind::Off);
        assert_eq!(file, text, "cut at {cut}");
    }
    let yari = "resolution(4,4);\nbegin\n  sphere(center=0,0,0; radius=1)\nend\n";
    let (file, text) = both("bad.yari", yari, InputKind::Yari);
    assert!(file.contains("bad.yari:3:33: error:"), "{file}");
    assert_eq!(file, text);
}

#[test]
fn a_file_that_is_not_text_is_refused_even_after_an_error() {
    let d = dir("binary");
    let path = d.join("bin.nff");
    std::fs::write(&path, b"q\n# \xff\xfe\n").unwrap();
    let r = stream_path(&path, &ColourTable::builtin(), &mut |_, _| {});
    assert!(matches!(r, Err(LoadError::NotText { .. })), "{r:?}");
    std::fs::remove_dir_all(&d).unwrap();
}
