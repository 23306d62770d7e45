//! Tests of the NFF reader.

use super::*;

fn read_str(text: &str) -> Result<NffScene, String> {
    let src = Source::new("t.nff", text);
    read(&src).map(|(s, _)| s).map_err(|d| d.render(&src))
}

#[test]
fn reads_every_entity() {
    let text =
        "# a comment\nb 0.1 0.2 0.3\nv\nfrom 0 -5 0\nat 0 0 0\nup 0 0 1\nangle 40\nhither 1\n\
                resolution 64 48\nl 1 2 3\nl 4 5 6 0.5 0.5 0.5 # coloured\n\
                f 1 0 0 0.7 0.3 20 0 1\ns 0 0 0 1\np 3 0 0 0  1 0 0  0 1 0\n\
                pp 3\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\nc\n0 0 0 1\n0 0 2 0.5\n";
    let s = read_str(text).unwrap();
    let kinds: Vec<_> = s
        .entities
        .iter()
        .map(|e| std::mem::discriminant(&e.node))
        .collect();
    assert_eq!(kinds.len(), 9);
    assert_eq!(s.counts(), (1, 2, 1));
    match &s.entities[1].node {
        Entity::View(v) => {
            assert_eq!(v.angle, 40.0);
            assert_eq!(v.resolution, Some([64, 48]));
        }
        e => panic!("not a view: {e:?}"),
    }
    assert_eq!(
        s.entities[3].node,
        Entity::Light {
            position: [4.0, 5.0, 6.0],
            color: Some([0.5; 3])
        }
    );
    match &s.entities[7].node {
        Entity::Polygon {
            normals: Some(n), ..
        } => assert_eq!(n[2], [0.0, 0.0, 1.0]),
        e => panic!("not a pp: {e:?}"),
    }
}

#[test]
fn errors_point_at_the_bad_token() {
    let err = read_str("b 0 0 0\ns 0 0 zero 1\n").unwrap_err();
    assert!(
        err.starts_with(
            "t.nff:2:7: error: expected the z coordinate of the sphere centre, found `zero`"
        ),
        "{err}"
    );
    let err = read_str("p 2\n0 0 0\n1 1 1\n").unwrap_err();
    assert!(
        err.starts_with("t.nff:1:3: error: the vertex count must be between 3"),
        "{err}"
    );
    let err = read_str("s 0 0 0 -1\n").unwrap_err();
    assert!(
        err.contains("t.nff:1:9: error: sphere radius must be positive"),
        "{err}"
    );
    let err = read_str("p 3\n0 0 0\n1 0 0\n").unwrap_err();
    assert!(
        err.contains("unexpected end of file: expected the x coordinate of vertex 3"),
        "{err}"
    );
    let err = read_str("x 1 2 3\n").unwrap_err();
    assert!(
        err.starts_with("t.nff:1:1: error: unknown NFF entity `x`"),
        "{err}"
    );
    let err = read_str("c\n0 0 0 1\n0 0 0 1\n").unwrap_err();
    assert!(
        err.contains("cone base and apex are the same point"),
        "{err}"
    );
    let err = read_str("v\nfrom 0 0 0\nat 0 0 1\nup 0 0 1\nangle 45\n").unwrap_err();
    assert!(err.contains("parallel to the line of sight"), "{err}");
    let err = read_str("v\nfrom 0 0 0\nat 0 1 0\nup 0 0 1\n").unwrap_err();
    assert!(err.contains("view is missing `angle`"), "{err}");
}

#[test]
fn reports_every_broken_entity() {
    let src = Source::new(
        "t.nff",
        "s 0 0 0 x\ns 0 0 0 1\np 3 0 0\ns 1 1 1 1\nl 1 q 3\n",
    );
    let diags = read(&src).unwrap_err();
    let lines: Vec<_> = diags
        .errors()
        .map(|d| src.line_col(d.span.start).0)
        .collect();
    assert_eq!(lines, vec![1, 4, 5], "{}", diags.render(&src));
}

#[test]
fn warns_on_out_of_range_fill() {
    let src = Source::new("t.nff", "f 1 1 1 1.5 0 1 0 1\n");
    let (_, diags) = read(&src).unwrap();
    assert_eq!(diags.warnings().count(), 1);
}

#[test]
fn never_panics_on_garbage() {
    for text in [
        "",
        "p",
        "p -3",
        "p 99999999999999999999",
        "v from",
        "f 1 2",
        "l",
        "c 1 2 3",
        "b nan 0 0",
        "\u{1F600} p 3",
    ] {
        let _ = read_str(text);
    }
}

use proptest::strategy::Strategy;

proptest::proptest! {
    /// Any mix of NFF-looking tokens reads to a scene or to errors, never a panic, and every
    /// error points inside the text.
    #[test]
    fn token_soup_never_panics(tokens in proptest::collection::vec(
        proptest::prop_oneof![
            proptest::sample::select(vec!["b", "v", "l", "f", "c", "s", "p", "pp", "from", "at", "up",
                "angle", "hither", "resolution", "#", "\n", "x", "-", "1e999", "nan"]).prop_map(String::from),
            (-5i32..10).prop_map(|n| n.to_string()),
            (-2.0f64..2.0).prop_map(|x| format!("{x}")),
        ],
        0..60,
    )) {
        let text = tokens.join(" ");
        let src = Source::new("soup.nff", text.clone());
        if let Err(d) = read(&src) {
            proptest::prop_assert!(d.has_errors());
            for e in &d.items {
                proptest::prop_assert!(e.span.end as usize <= text.len());
                let _ = e.render(&src);
            }
        }
    }
}
