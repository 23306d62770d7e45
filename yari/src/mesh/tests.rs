use super::*;
use ply_rs_bw::ply::Encoding;

/// A unit cube's six faces (quads), outward normals per corner on the first three.
fn cube() -> Vec<Face> {
    let p = |x: u8| {
        [
            f64::from(x & 1),
            f64::from((x >> 1) & 1),
            f64::from((x >> 2) & 1),
        ]
    };
    let quads = [
        ([0, 2, 3, 1], [0.0, 0.0, -1.0]),
        ([4, 5, 7, 6], [0.0, 0.0, 1.0]),
        ([0, 1, 5, 4], [0.0, -1.0, 0.0]),
        ([2, 6, 7, 3], [0.0, 1.0, 0.0]),
        ([0, 4, 6, 2], [-1.0, 0.0, 0.0]),
        ([1, 3, 7, 5], [1.0, 0.0, 0.0]),
    ];
    quads
        .iter()
        .enumerate()
        .map(|(i, (q, n))| Face {
            vertices: q.iter().map(|&k| p(k)).collect(),
            normals: (i < 3).then(|| vec![*n; 4]),
            surface: Surface::Default,
        })
        .collect()
}

fn read(kind: MeshKind, bytes: &[u8]) -> Result<(Vec<Face>, MeshSummary), MeshError> {
    let mut faces = Vec::new();
    let name = match kind {
        MeshKind::Obj => "m.obj",
        MeshKind::Ply => "m.ply",
        MeshKind::Gltf => "m.glb",
    };
    let mut input = bytes;
    let s = read_each(kind, Path::new(name), &mut input, &mut |f| faces.push(f))?;
    Ok((faces, s))
}

fn written(faces: &[Face], kind: Option<Encoding>) -> Vec<u8> {
    let mut out = Vec::new();
    match kind {
        None => write::obj(faces, &mut out).unwrap(),
        Some(e) => write::ply(faces, e, &mut out).unwrap(),
    }
    out
}

#[test]
fn obj_and_ply_in_every_encoding_read_back_the_faces_written_bit_for_bit() {
    let faces: Vec<Face> = cube()
        .into_iter()
        .map(|mut f| {
            // Coordinates that need every bit.
            for v in &mut f.vertices {
                v[0] = v[0] * 0.1 + 1.0 / 3.0;
            }
            f
        })
        .collect();
    let (obj, s) = read(MeshKind::Obj, &written(&faces, None)).unwrap();
    assert_eq!(obj, faces);
    assert_eq!(
        (s.vertices, s.faces, s.triangles),
        (8, 6, 12),
        "corners shared"
    );
    assert!(s.normals);
    // Without normals, and with normals on some faces (the others get zero normals: flat).
    let flat: Vec<Face> = faces
        .iter()
        .cloned()
        .map(|f| Face { normals: None, ..f })
        .collect();
    for e in [Encoding::Ascii, Encoding::BinaryBigEndian] {
        let (ply, _) = read(MeshKind::Ply, &written(&faces, Some(e))).unwrap();
        assert_eq!(ply, faces, "{e:?}");
    }
    for e in [
        Encoding::Ascii,
        Encoding::BinaryLittleEndian,
        Encoding::BinaryBigEndian,
    ] {
        let (ply, _) = read(MeshKind::Ply, &written(&flat, Some(e))).unwrap();
        assert_eq!(ply, flat, "{e:?}");
        let smooth: Vec<Face> = faces[..3].to_vec();
        let (ply, s) = read(MeshKind::Ply, &written(&smooth, Some(e))).unwrap();
        assert_eq!(ply, smooth, "{e:?}");
        assert_eq!(s.bounds.min, [1.0 / 3.0, 0.0, 0.0]);
    }
}

#[test]
fn obj_indices_may_count_back_and_vertex_colours_and_texture_corners_are_read() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0 1 0 0\nvt 0 0\nvn 0 0 1\n\
                f -3/1/1 -2/1/1 -1/1/1\nf 1 2 3\n";
    let (faces, s) = read(MeshKind::Obj, text.as_bytes()).unwrap();
    assert_eq!(faces.len(), 2);
    assert_eq!(faces[0].vertices, faces[1].vertices);
    assert_eq!(faces[0].normals, Some(vec![[0.0, 0.0, 1.0]; 3]));
    assert_eq!(faces[1].normals, None);
    assert_eq!((s.vertices, s.triangles), (3, 2));
}

#[test]
fn ply_vertex_colours_become_the_face_colour_and_other_elements_are_skipped() {
    let text = "ply\nformat ascii 1.0\ncomment hi\nelement vertex 3\nproperty float x\n\
                property float y\nproperty float z\nproperty uchar red\nproperty uchar green\n\
                property uchar blue\nelement face 1\nproperty list uchar int vertex_indices\n\
                element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n\
                0 0 0 255 0 0\n1 0 0 255 0 0\n0 1 0 0 0 255\n3 0 1 2\n0 1\n";
    let (faces, _) = read(MeshKind::Ply, text.as_bytes()).unwrap();
    let Surface::Colour(c) = faces[0].surface else {
        panic!("{faces:?}")
    };
    assert!((c[0] - 2.0 / 3.0).abs() < 1e-12 && c[1] == 0.0 && (c[2] - 1.0 / 3.0).abs() < 1e-12);
}

fn error(kind: MeshKind, bytes: &[u8]) -> String {
    read(kind, bytes).unwrap_err().to_string()
}

#[test]
fn bad_obj_gets_one_line_with_the_file_and_the_line() {
    let cases: [(&str, &str); 6] = [
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
            "m.obj:4: face: vertex index 4 is out of range (the file has 3 vertices so far)",
        ),
        (
            "v 0 0 0\nv 1 0 0\nf 1 2\n",
            "m.obj:3: face has 2 corners (at least 3)",
        ),
        (
            "v 0 0 0\nv nan 0 0\n",
            "m.obj:2: v: nan is not a finite number",
        ),
        ("v 0 0\n", "m.obj:1: v needs 3 numbers"),
        (
            "v 0 0 0\nf 0 1 1\n",
            "m.obj:2: face: vertex index 0 is out of range",
        ),
        (
            "mtllib missing.mtl\n",
            "m.obj:1: cannot read its material library missing.mtl: ",
        ),
    ];
    for (text, want) in cases {
        let got = error(MeshKind::Obj, text.as_bytes());
        assert!(got.starts_with(want), "{got:?} should start {want:?}");
        assert_eq!(got.lines().count(), 1, "{got}");
    }
}

#[test]
fn bad_ply_gets_one_line_with_the_file_and_the_line_or_byte() {
    let head = |n: usize, f: usize, e: &str| {
        format!(
            "ply\nformat {e} 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n\
             property float z\nelement face {f}\nproperty list uchar int vertex_indices\n\
             end_header\n"
        )
    };
    let ascii = |body: &str| format!("{}{body}", head(3, 1, "ascii"));
    let cases = [
        (ascii("0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"), "m.ply:13: face 1: vertex index 3 is out of range (the file has 3 vertices, numbered from 0)"),
        (ascii("0 0 0\n1 0 0\n0 1 0\n2 0 1\n"), "m.ply:13: face 1 has 2 corners (at least 3)"),
        (ascii("0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n"), "m.ply:11: vertex 2: \"nan 0 0\" is not numbers for x y z"),
        (ascii("0 0 0\n1 0 0\n"), "m.ply:12: the file ends inside vertex 3 of 3 (truncated?)"),
        ("plx\n".to_string(), "m.ply:"),
    ];
    for (text, want) in cases {
        let got = error(MeshKind::Ply, text.as_bytes());
        assert!(got.starts_with(want), "{got:?} should start {want:?}");
        assert_eq!(got.lines().count(), 1, "{got}");
    }
    // Binary: a NaN coordinate, at the byte where its vertex starts (after the header and
    // one vertex of six doubles: the cube has normals on some faces).
    let mut faces = cube();
    faces[0].vertices[1][2] = f64::NAN;
    let bytes = written(&faces, Some(Encoding::BinaryBigEndian));
    let header = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    assert_eq!(
        error(MeshKind::Ply, &bytes),
        format!(
            "m.ply: byte {}: vertex 2 has a value that is not a finite number",
            header + 48
        )
    );
    // Binary, cut short inside the face: the byte offset where the face starts.
    let faces = cube();
    let mut bytes = written(&faces, Some(Encoding::BinaryLittleEndian));
    bytes.truncate(bytes.len() - 3);
    let got = error(MeshKind::Ply, &bytes);
    let face_at = bytes.len() + 3 - 17;
    assert_eq!(
        got,
        format!("m.ply: byte {face_at}: the file ends inside face 6 of 6 (truncated?)")
    );
}

#[test]
fn an_mtl_material_maps_to_the_hall_attributes_of_an_nff_fill() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "newmtl glass\nKd 0.5 0.5 0.5\nKs 0.2 0.2 0.2\nNs 50\nNi 1.5\nd 0.25\nillum 7\n\
         newmtl clay\nKd 0.8 0.4 0.2\nKs 1 1 1\nillum 2\n",
    )
    .unwrap();
    let obj = dir.path().join("m.obj");
    std::fs::write(
        &obj,
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl glass\nf 1 2 3\nusemtl clay\nf 1 2 3\n\
         usemtl nothing\nf 1 2 3\n",
    )
    .unwrap();
    let (scene, s) = parse_path(MeshKind::Obj, &obj).unwrap();
    assert_eq!(s.faces, 3);
    let fills: Vec<Surface> = {
        let mut out = Vec::new();
        let mut input = std::io::BufReader::new(std::fs::File::open(&obj).unwrap());
        read_each(MeshKind::Obj, &obj, &mut input, &mut |f| {
            out.push(f.surface)
        })
        .unwrap();
        out
    };
    assert_eq!(
        fills[0],
        Surface::Fill(Fill {
            color: [0.5; 3],
            kd: 1.0,
            ks: 0.2f32 as f64,
            shine: 50.0,
            t: 0.75,
            ior: 1.5f32 as f64,
        })
    );
    let Surface::Fill(clay) = fills[1] else {
        panic!()
    };
    assert_eq!(clay.ks, 0.0, "illum 2: a highlight colour, no mirror");
    assert_eq!(fills[2], Surface::Default);
    // Three attributes (one per surface change) and three polygons, then the framing view.
    assert_eq!(scene.body.items.len(), 6);
    assert_eq!(scene.view.len(), 5);
}

#[test]
fn a_glb_reads_back_its_triangles_as_floats_with_normals_and_a_node_transform() {
    // The cube's first three faces (normals) as six triangles.
    let faces: Vec<Face> = cube()[..3].to_vec();
    let bytes = write::glb(&faces).unwrap();
    let (tris, s) = read(MeshKind::Gltf, &bytes).unwrap();
    assert_eq!((s.faces, s.triangles, s.vertices), (6, 6, 18));
    assert_eq!(
        tris[0].vertices,
        vec![
            faces[0].vertices[0],
            faces[0].vertices[1],
            faces[0].vertices[2]
        ]
    );
    assert_eq!(
        tris[1].vertices,
        vec![
            faces[0].vertices[0],
            faces[0].vertices[2],
            faces[0].vertices[3]
        ]
    );
    assert_eq!(tris[0].normals, Some(vec![[0.0, 0.0, -1.0]; 3]));
}

#[test]
fn bad_gltf_gets_one_line() {
    let faces: Vec<Face> = cube();
    let mut bytes = write::glb(&faces).unwrap();
    bytes.truncate(bytes.len() - 40);
    // The binary chunk is cut: the crate refuses the container, or the buffer is short.
    let e = error(MeshKind::Gltf, &bytes);
    assert!(e.starts_with("m.glb: "), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    let e = error(MeshKind::Gltf, b"{\"asset\": 1}");
    assert!(e.starts_with("m.glb: not glTF 2.0"), "{e}");
}

/// A .gltf of one triangle (0,0,0), (1,0,0), (0,1,0) in a base64 buffer of `data` bytes
/// declared `declared` long, under a node moved by 10 in x whose child, scaled by 2, holds
/// the mesh; the accessor counts `count` vertices.
fn gltf_text(data: usize, declared: usize, count: usize) -> String {
    use base64::Engine;
    let mut bin = Vec::new();
    for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for x in v {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    bin.truncate(data);
    let b64 = base64::engine::general_purpose::STANDARD.encode(&bin);
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"children":[1],"translation":[10,0,0]}},{{"mesh":0,"scale":[2,2,2]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "buffers":[{{"byteLength":{declared},"uri":"data:application/octet-stream;base64,{b64}"}}],
        "bufferViews":[{{"buffer":0,"byteLength":{declared}}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":{count},"type":"VEC3",
          "min":[0,0,0],"max":[1,1,0]}}]}}"#
    )
}

#[test]
fn gltf_nodes_place_their_meshes_and_short_buffers_are_refused() {
    let (tris, _) = read(MeshKind::Gltf, gltf_text(36, 36, 3).as_bytes()).unwrap();
    assert_eq!(
        tris[0].vertices,
        vec![[10.0, 0.0, 0.0], [12.0, 0.0, 0.0], [10.0, 2.0, 0.0]]
    );
    assert_eq!(tris[0].normals, None);
    let e = error(MeshKind::Gltf, gltf_text(24, 36, 3).as_bytes());
    assert_eq!(
        e,
        "m.glb: buffer 0 holds 24 bytes, fewer than the 36 it declares (truncated?)"
    );
    let e = error(MeshKind::Gltf, gltf_text(36, 36, 4).as_bytes());
    assert!(e.starts_with("m.glb: "), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
}

/// Points and lines have no faces: they are left out, counted and said in a warning.
#[test]
fn gltf_points_and_lines_are_left_out_with_a_warning() {
    let one = r#"{"attributes":{"POSITION":0}}"#;
    let text = gltf_text(36, 36, 3).replace(
        one,
        &format!(
            r#"{one},{{"attributes":{{"POSITION":0}},"mode":0}},{{"attributes":{{"POSITION":0}},"mode":1}}"#
        ),
    );
    let (faces, summary) = read(MeshKind::Gltf, text.as_bytes()).unwrap();
    assert_eq!((faces.len(), summary.skipped_primitives), (1, 2));
    let colours = crate::colour::ColourTable::builtin();
    let loaded =
        crate::load::load_str("m.gltf", &text, crate::load::InputKind::Gltf, &colours).unwrap();
    assert_eq!(
        loaded.render_warnings(),
        "m.gltf: warning: 2 primitives of points or lines left out: only faces are rendered\n"
    );
    let (_, plain) = read(MeshKind::Gltf, gltf_text(36, 36, 3).as_bytes()).unwrap();
    assert_eq!(plain.skipped_primitives, 0);
}

#[test]
fn a_meshs_compiler_warnings_name_the_file_once_per_message() {
    let text = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\nf 1 2 4\n";
    let colours = crate::colour::ColourTable::builtin();
    let loaded =
        crate::load::load_str("m.obj", text, crate::load::InputKind::Obj, &colours).unwrap();
    assert_eq!(
        loaded.render_warnings(),
        "m.obj: warning: degenerate polygon dropped: it has no area (2 faces)\n"
    );
}
