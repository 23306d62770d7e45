use super::*;
use crate::ast::{AttrField, ColorSpec, Primitive, Transform, ViewStmt};

fn parse_text(text: &str) -> Result<Scene, Diagnostics> {
    parse(&Source::new("t.yari", text))
}

fn errors(text: &str) -> Vec<String> {
    match parse_text(text) {
        Ok(_) => panic!("expected errors for {text:?}"),
        Err(d) => d.errors().map(|e| e.message.clone()).collect(),
    }
}

fn count_primitives(b: &Block) -> usize {
    b.items
        .iter()
        .map(|i| match &i.node {
            BodyItem::Primitive(_) => 1,
            BodyItem::Block(inner) => count_primitives(inner),
            _ => 0,
        })
        .sum()
}

#[test]
fn thesis_tetrahedron_parses_as_printed() {
    let text = crate::test_support::thesis_example("tetra16.yari");
    let scene = parse(&Source::new("tetra16.yari", text)).unwrap();
    assert_eq!(scene.view.len(), 4);
    assert_eq!(count_primitives(&scene.body), 16);
    match &scene.view[0].node {
        ViewStmt::Camera(c) => {
            assert_eq!(c.position, [1.02285, -3.17715, -2.17451]);
            assert_eq!(c.up, [-0.816497, -0.816497, 0.816497]);
            assert_eq!(c.angle, 22.5);
        }
        other => panic!("{other:?}"),
    }
    assert!(
        matches!(&scene.view[2].node, ViewStmt::Background(c) if c.node == ColorSpec::Named("UNC_Blue".into()))
    );
    match &scene.body.items[1].node {
        BodyItem::Primitive(Primitive::Polygon { vertices, .. }) => {
            assert_eq!(
                vertices,
                &vec![[-1.0, -1.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]
            )
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn thesis_cubes_parse_as_printed() {
    let text = crate::test_support::thesis_example("cubes.yari");
    let scene = parse(&Source::new("cubes.yari", text)).unwrap();
    assert_eq!(scene.view.len(), 6);
    assert_eq!(count_primitives(&scene.body), 1 + 1 + 6 + 18);
    match &scene.body.items[0].node {
        BodyItem::Attribute(fields) => {
            assert_eq!(fields.len(), 3);
            assert_eq!(
                fields[2].node,
                AttrField::Texture {
                    id: 1.0,
                    color: [0.5176, 0.4118, 0.2784],
                    scale: [1.0, 1.0, 1.0]
                }
            );
        }
        other => panic!("{other:?}"),
    }
    assert!(scene
        .body
        .items
        .iter()
        .any(|i| i.node == BodyItem::Transform(Transform::Translate([0.0, -15.0, 0.0]))));
}

#[test]
fn extensions_parse() {
    let scene = parse_text(
        "samples(16); light(position=0,1,2; color=white; radius=0.5);
         camera(position=0,0,5; at=0,0,0; up=0,1,0; angle=30; aperture=0.1; focus=5);
         begin
           attribute(gloss=5; translucency=2; transmissivity=0.9; kdt=0.2);
           motion(1,0,0);
           transform(1 0 0 0  0 1 0 0  0 0 1 0);
           quadric(1 0 0 0 1 0 0 -1 0 0 ; clip = -1,-1,-1 1,1,1 ; plane = 0,1,0 0.5);
         end",
    )
    .unwrap();
    assert!(scene.view.iter().any(|v| v.node == ViewStmt::Samples(16)));
    match &scene.body.items[3].node {
        BodyItem::Primitive(Primitive::Quadric { coeffs, clip }) => {
            assert_eq!(coeffs[7], -1.0);
            assert_eq!(clip.len(), 2);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn spans_point_at_statements() {
    let text = "begin\n  sphere(center = 1,2,3; radius = 4);\nend\n";
    let scene = parse_text(text).unwrap();
    let span = scene.body.items[0].span;
    assert_eq!(
        &text[span.start as usize..span.end as usize],
        "sphere(center = 1,2,3; radius = 4)"
    );
    assert_eq!(scene.body.span, Span::new(0, text.trim_end().len()));
}

#[test]
fn several_errors_are_listed() {
    let errs = errors("begin\n sphre(center=0,0,0);\n sphere(center=0,0; radius=1);\n polygon(vertices=3; 0 0 0 1 1 1);\nend");
    assert_eq!(errs.len(), 3, "{errs:?}");
    assert!(errs[0].contains("unknown command `sphre`"));
    assert!(errs[2].contains("declares 3 vertices but lists 2"));
}

#[test]
fn nesting_is_bounded() {
    let deep = format!(
        "{}{}",
        "begin ".repeat(MAX_NESTING + 1),
        "end ".repeat(MAX_NESTING + 1)
    );
    let errs = errors(&deep);
    assert_eq!(errs.len(), 1, "{errs:?}");
    assert!(errs[0].contains("nested deeper"));
    let ok = format!(
        "{}{}",
        "begin ".repeat(MAX_NESTING),
        "end ".repeat(MAX_NESTING)
    );
    assert!(parse_text(&ok).is_ok());
    // Far deeper input must not overflow the stack either.
    let very = format!("{}{}", "begin ".repeat(200_000), "end ".repeat(200_000));
    assert!(parse_text(&very).is_err());
}

#[test]
fn structural_errors() {
    assert!(errors("")[0].contains("missing the world block"));
    assert!(errors("begin sphere(center=0,0,0; radius=1);")[0].contains("no matching `end`"));
    assert!(errors("begin end begin end")[0].contains("end of file"));
    assert!(errors("begin resolution(1,1); end")[0].contains("belongs in the preamble"));
    assert!(
        errors("sphere(center=0,0,0; radius=1); begin end")[0].contains("inside the world block")
    );
    assert!(errors("resolution(0, 10); begin end")[0].contains("whole number"));
    assert!(
        errors("camera(position=0,0,1; at=0,0,0; angle=20); begin end")[0].contains("missing `up")
    );
    assert!(
        errors("begin sphere(center=0,0,0; radius=1; radius=2); end")[0].contains("given twice")
    );
    assert!(errors("begin translate(1e400,0,0); end")[0].contains("out of range"));
}

#[test]
fn a_forgotten_close_paren_does_not_swallow_the_next_statement() {
    let errs = errors(
        "begin\n sphere(center = 0,0,0; radius = 1;\n polygon(vertices = 3; 0,0,0 1,0,0);\nend",
    );
    assert_eq!(errs.len(), 2, "{errs:?}");
    assert_eq!(errs[0], "expected `)`, found `polygon`");
    assert!(errs[1].contains("declares 3 vertices but lists 2"));
}

#[test]
fn polygon_normals_parse_after_the_vertices() {
    let scene = parse_text(
        "begin
           polygon(vertices = 3; 0,0,0 1,0,0 0,1,0; normals = 0,0,1 0 0.1 1, 0.1,0,1);
           polygon(vertices = 3; 0,0,0 1,0,0 0,1,0;);
           polygon(vertices = 3; 0,0,0 1,0,0 0,1,0);
         end",
    )
    .unwrap();
    let normals: Vec<Option<Vec<[f64; 3]>>> = scene
        .body
        .items
        .iter()
        .map(|i| match &i.node {
            BodyItem::Primitive(Primitive::Polygon { normals, .. }) => normals.clone(),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(
        normals,
        vec![
            Some(vec![[0.0, 0.0, 1.0], [0.0, 0.1, 1.0], [0.1, 0.0, 1.0]]),
            None,
            None
        ]
    );
}

#[test]
fn bad_normals_are_located_errors_with_a_caret() {
    let rendered = |text: &str| {
        let src = Source::new("n.yari", text);
        parse(&src).unwrap_err().render(&src)
    };
    // Too few normals: the error points at the list of normals.
    let e =
        rendered("begin\n polygon(vertices = 3; 0,0,0 1,0,0 0,1,0; normals = 0,0,1 0,0,1);\nend");
    assert!(
        e.starts_with(
            "n.yari:2:53: error: polygon has 3 vertices but 2 normals; give one normal per vertex"
        ),
        "{e}"
    );
    assert!(
        e.contains(&format!("\n{}^~~~~~~~~~~", " ".repeat(54))),
        "{e:?}"
    );
    // A zero normal: the error points at its three numbers.
    let e = rendered(
        "begin\n polygon(vertices = 3; 0,0,0 1,0,0 0,1,0; normals = 0,0,1 0,0,0 0,0,1);\nend",
    );
    assert!(
        e.starts_with(
            "n.yari:2:59: error: the normal of vertex 2 is zero; a normal needs a direction"
        ),
        "{e}"
    );
    assert!(e.contains(&format!("\n{}^~~~~", " ".repeat(60))), "{e:?}");
    // A normal whose length cannot be normalised, a partial vector, an unknown field.
    assert!(errors(
        "begin polygon(vertices = 3; 0,0,0 1,0,0 0,1,0; normals = 0,0,1 1e-200,0,0 0,0,1); end"
    )[0]
    .contains("cannot be normalised"));
    assert!(errors(
        "begin polygon(vertices = 3; 0,0,0 1,0,0 0,1,0; normals = 0,0,1 0,0,1 0,0); end"
    )[0]
    .contains("each normal needs 3 coordinates, but 8 numbers are listed"));
    assert!(
        errors("begin polygon(vertices = 3; 0,0,0 1,0,0 0,1,0; colours = 1,1,1); end")[0]
            .contains("unknown field `colours` in `polygon`; expected `normals`")
    );
    assert!(errors(
        "begin polygon(vertices = 3; 0,0,0 1,0,0 0,1,0; normals = 0,0,1 0,0,1 0,0,1; x); end"
    )[0]
    .contains("expected `)` after the normals"));
    // The error does not stop the next statement from being read.
    let errs = errors("begin\n polygon(vertices = 3; 0 0 0 1 0 0 0 1 0; normals = 0 0 1);\n sphre(center=0,0,0);\nend");
    assert_eq!(errs.len(), 2, "{errs:?}");
}

#[test]
fn parse_each_hands_over_the_items_of_the_tree_and_its_diagnostics() {
    let good = "resolution(4,4);\nbegin\n  attribute(color = 1,0,0);\n  sphere(center=0,0,0; radius=1);\n  begin translate(1,0,0); sphere(center=0,0,0; radius=1); end\n  polygon(vertices = 3; 0,0,0 1,0,0 0,1,0);\nend\n";
    let src = Source::new("t", good);
    let mut items = Vec::new();
    let view = parse_each(&src, &mut |i| items.push(i)).unwrap();
    let tree = parse(&src).unwrap();
    assert_eq!(view, tree.view);
    assert_eq!(items, tree.body.items);
    assert_eq!(items.len(), 4, "a nested block is one item");
    for bad in [
        "begin\n  sphere(center=0,0,0; radius=1)\nend\n",
        "resolution(4,4);\nbegin\n  sphere(center=0,0,0; radius=1);\n",
        "begin end extra",
    ] {
        let src = Source::new("bad", bad);
        let each = parse_each(&src, &mut |_| {}).unwrap_err();
        let whole = parse(&src).unwrap_err();
        assert_eq!(each.render(&src), whole.render(&src), "{bad}");
    }
}

/// What [`parse_each`] gives for `text` (its items and preamble, or its rendered errors), and
/// the same read as a stream `step` bytes at a time.
fn each_both_ways(text: &str, step: usize) -> (String, String) {
    let src = Source::new("t.yari", text);
    let say =
        |items: Vec<Spanned<BodyItem>>, r: Result<Vec<Spanned<ViewStmt>>, Diagnostics>| match r {
            Ok(view) => format!("{view:?}\n{items:?}"),
            Err(d) => d.render(&src),
        };
    let mut items = Vec::new();
    let whole = parse_each(&src, &mut |i| items.push(i));
    let whole = say(items, whole);
    let mut lines = crate::lines::TextLines::new(text.as_bytes());
    let mut items = Vec::new();
    let parser = Parser::new(Lexer::streaming_in_steps(&mut lines, step));
    let streamed = each(parser, &mut |i| items.push(i));
    (whole, say(items, streamed))
}

#[test]
fn a_streamed_parse_equals_the_whole_one() {
    let mut texts: Vec<String> = ["tetra16.yari", "cubes.yari"]
        .iter()
        .map(|n| crate::test_support::thesis_example(n))
        .collect();
    let gears = crate::spd::generate(crate::spd::Database::Gears, 1).unwrap();
    texts.push(crate::writer::write_scene(&crate::nff::to_yari(&gears)));
    texts.push("resolution(4,4);\nbegin\n  sphere(center=0,0,0; radius=1)\nend\n".into());
    texts.push("begin\n polygon(vertices = 3; 0 0 0 1 0 0 0 1 0; normals = 0 0 1);\n sphre(center=0,0,0);\nend".into());
    texts.push("begin\n attribute(color = 1,0,0; color = 1,0,0);\n sphere(radius = 1);\n camera(at=0,0,0);\nend end".into());
    texts.push(format!(
        "begin\n{}end\n",
        "sphere(center=0,0,0 radius=1);\n".repeat(60)
    ));
    for text in &texts {
        for step in [1, 100, 1 << 16] {
            let (whole, streamed) = each_both_ways(text, step);
            assert_eq!(whole, streamed, "step {step}: {text}");
        }
    }
    // Every truncation of a scene with comments, blocks and an error.
    let cut_me = "resolution(4,4); /* a\n comment */\nbegin\n attribute(color = 1,0,0);\n \
                  begin translate(1,0,0); sphere(center=0,0,0; radius=1); end\n \
                  polygon(vertices = 3; 0,0,0 1,0,0 0,1,0);\n sphere(center=0,0,0 radius=1);\nend\n";
    for cut in 0..=cut_me.len() {
        let (whole, streamed) = each_both_ways(&cut_me[..cut], 1);
        assert_eq!(whole, streamed, "cut at {cut}");
    }
}
