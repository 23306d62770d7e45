//! Tests of the OFF converter.

use super::*;

const CUBE: &str = "OFF\n# a cube\n8 6 12\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n\
                    4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 2 3 7 6 255 0 0\n4 1 2 6 5 1 0 0 1\n4 3 0 4 7\n";

fn polygons(s: &Scene) -> Vec<&Vec<Vec3>> {
    s.body
        .items
        .iter()
        .filter_map(|i| match &i.node {
            BodyItem::Primitive(Primitive::Polygon { vertices, .. }) => Some(vertices),
            _ => None,
        })
        .collect()
}

fn attributes(s: &Scene) -> Vec<Vec3> {
    s.body
        .items
        .iter()
        .filter_map(|i| match &i.node {
            BodyItem::Attribute(f) => match &f[0].node {
                AttrField::Color(c) => match c.node {
                    ColorSpec::Rgb(c) => Some(c),
                    _ => None,
                },
                _ => None,
            },
            _ => None,
        })
        .collect()
}

#[test]
fn reads_a_cube_with_face_colours() {
    let s = parse(&Source::new("cube.off", CUBE)).unwrap();
    let p = polygons(&s);
    assert_eq!(p.len(), 6);
    assert_eq!(
        p[0],
        &vec![[0.0; 3], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]]
    );
    // white, then red (255 0 0 and 1 0 0 1 are the same colour), then white again.
    assert_eq!(attributes(&s), vec![[1.0; 3], [1.0, 0.0, 0.0], [1.0; 3]]);
    assert!(s.view.iter().any(|v| matches!(v.node, ViewStmt::Camera(_))));
}

#[test]
fn counts_on_the_header_line() {
    let s = parse(&Source::new(
        "t.off",
        "OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    ))
    .unwrap();
    assert_eq!(polygons(&s).len(), 1);
}

fn error(text: &str) -> String {
    let src = Source::new("t.off", text);
    parse(&src).unwrap_err().render(&src)
}

#[test]
fn bad_input_gets_located_errors() {
    let e = error("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    assert!(
        e.starts_with("t.off:6:7: error: vertex index 7 is out of range (the file has 3 vertices)"),
        "{e}"
    );
    let e = error("OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n");
    assert!(
        e.contains("unexpected end of file: expected vertex 3 of 4"),
        "{e}"
    );
    let e = error("PLY\n");
    assert!(
        e.starts_with("t.off:1:1: error: expected the `OFF` header, found `PLY`"),
        "{e}"
    );
    let e = error("OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n");
    assert!(
        e.starts_with("t.off:4:3: error: expected a number in vertex 1 of 3, found `x`"),
        "{e}"
    );
    let e = error("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n3 0 1\n");
    assert!(
        e.contains("t.off:6:1: error: face 0 of 2 has 2 vertices")
            && e.contains("t.off:7:1: error: face 1 of 2 lists 2"),
        "{e}"
    );
    let e = error("OFF\n-1 2 0\n");
    assert!(
        e.contains("expected the vertex count (a whole number), found `-1`"),
        "{e}"
    );
}

#[test]
fn never_panics_on_garbage() {
    for text in [
        "",
        "OFF",
        "OFF\n",
        "OFF\n1\n",
        "OFF\n99999999999 1 0\n",
        "OFF\n1 1 0\n0 0 0\n3 0 0 0 1 2\n",
        "\u{1F600}",
    ] {
        let _ = parse(&Source::new("t.off", text));
    }
}

fn normals(s: &Scene) -> Vec<Option<Vec<Vec3>>> {
    s.body
        .items
        .iter()
        .filter_map(|i| match &i.node {
            BodyItem::Primitive(Primitive::Polygon { normals, .. }) => Some(normals.clone()),
            _ => None,
        })
        .collect()
}

#[test]
fn noff_gives_each_face_its_vertices_normals() {
    // A square of two triangles bent along its diagonal, normals per vertex.
    let text = "NOFF\n4 2 0\n0 0 0  0 0 1\n1 0 0  0.5 0 1\n1 1 0 0 0 2\n0 1 0  -0.5 0 1\n\
                3 0 1 2\n3 0 2 3 1 0 0\n";
    let s = parse(&Source::new("sq.off", text)).unwrap();
    assert_eq!(
        normals(&s),
        vec![
            Some(vec![[0.0, 0.0, 1.0], [0.5, 0.0, 1.0], [0.0, 0.0, 2.0]]),
            Some(vec![[0.0, 0.0, 1.0], [0.0, 0.0, 2.0], [-0.5, 0.0, 1.0]]),
        ]
    );
    assert_eq!(polygons(&s)[1][2], [0.0, 1.0, 0.0]);
    // The scene compiles to smooth polygons.
    let w = crate::compile::compile(&s, &crate::colour::ColourTable::builtin())
        .unwrap()
        .world;
    assert!(w
        .objects
        .iter()
        .all(|o| matches!(o.shape, crate::model::Shape::SmoothPolygon { .. })));
    // Plain OFF has none.
    assert!(normals(&parse(&Source::new("cube.off", CUBE)).unwrap())
        .iter()
        .all(Option::is_none));
}

#[test]
fn off_prefixes_lay_out_the_vertex_lines() {
    // Colour per vertex (3 or 4 numbers) and texture coordinates are read and skipped.
    let text = "STCNOFF 3 1 0\n0 0 0 0 0 1 1 0 0 1 0.5 0.5\n1 0 0 0 0 1 0 1 0 0 1\n\
                0 1 0 0 0 1 0 0 1 1 1 1\n3 0 1 2\n";
    let s = parse(&Source::new("t.off", text)).unwrap();
    assert_eq!(normals(&s)[0].as_ref().map(Vec::len), Some(3));
    let s = parse(&Source::new(
        "t.off",
        "COFF 3 1 0\n0 0 0 1 0 0\n1 0 0 0 1 0 1\n0 1 0 0 0 1\n3 0 1 2\n",
    ))
    .unwrap();
    assert_eq!(normals(&s), vec![None]);
}

#[test]
fn bad_noff_input_gets_located_errors_and_warnings() {
    let e = error("NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0\n0 1 0 0 0 1\n3 0 1 2\n");
    assert!(
        e.starts_with("t.off:4:1: error: vertex 1 of 3 must have 3 coordinates and a normal (6 numbers), found 5"),
        "{e}"
    );
    let e = error("4OFF\n");
    assert!(e.contains("only 3-dimensional OFF is supported"), "{e}");
    let e = error("NOFFX\n");
    assert!(
        e.contains("expected the `OFF` header, found `NOFFX`"),
        "{e}"
    );
    // A zero normal: that face is flat, with a warning at its index.
    let src = Source::new(
        "z.off",
        "NOFF 3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 0\n0 1 0 0 0 1\n3 0 1 2\n",
    );
    let s = parse(&src).unwrap();
    assert_eq!(normals(&s), vec![None]);
    let (_, warnings) = parse_with_warnings(&src).unwrap();
    let w = warnings.render(&src);
    assert!(
        w.starts_with("z.off:5:5: warning: the normal of vertex 1 has no direction; face 0 of 1 is shaded flat"),
        "{w}"
    );
}

use proptest::strategy::Strategy;

proptest::proptest! {
    /// Any lines of small numbers after an `OFF` header convert or fail with errors, never panic.
    #[test]
    fn number_soup_never_panics(lines in proptest::collection::vec(
        proptest::collection::vec(proptest::prop_oneof![(-2i32..8).prop_map(|n| n.to_string()),
            (-1.0f64..2.0).prop_map(|x| format!("{x}")), proptest::strategy::Just("#".to_string())], 0..8),
        0..20,
    )) {
        let body: Vec<String> = lines.iter().map(|l| l.join(" ")).collect();
        let text = format!("OFF\n{}\n", body.join("\n"));
        let src = Source::new("soup.off", text);
        if let Err(d) = parse(&src) {
            proptest::prop_assert!(d.has_errors());
            let _ = d.render(&src);
        }
    }
}
