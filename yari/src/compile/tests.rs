use super::*;
use crate::model::{Shape, TextureKind};
use crate::parse::parse;
use crate::span::Source;

const VIEW: &str = "resolution(8,8); camera(position=0,0,10; at=0,0,0; up=0,1,0; angle=20); light(position=0,10,0; color=white);\n";

fn compile_text(text: &str) -> Result<Compiled, Diagnostics> {
    let src = Source::new("t.yari", text);
    let scene = parse(&src).unwrap_or_else(|d| panic!("{}", d.render(&src)));
    compile(&scene, &ColourTable::builtin())
}

fn world(body: &str) -> World {
    let text = format!("{VIEW}begin\n{body}\nend\n");
    match compile_text(&text) {
        Ok(c) => c.world,
        Err(d) => panic!("{}", d.render(&Source::new("t.yari", text))),
    }
}

fn errors(text: &str) -> Vec<String> {
    compile_text(text)
        .expect_err("expected errors")
        .errors()
        .map(|d| d.message.clone())
        .collect()
}

fn warnings(body: &str) -> Vec<String> {
    compile_text(&format!("{VIEW}begin\n{body}\nend\n"))
        .unwrap()
        .warnings
        .items
        .into_iter()
        .map(|d| d.message)
        .collect()
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-9
}

fn thesis(name: &str) -> World {
    let text = crate::test_support::thesis_example(name);
    let src = Source::new(name, text);
    compile(&parse(&src).unwrap(), &ColourTable::builtin())
        .unwrap()
        .world
}

#[test]
fn tetrahedron_compiles() {
    let w = thesis("tetra16.yari");
    assert_eq!(w.features.polygons, 16);
    assert_eq!(w.lights.len(), 1);
    assert_eq!(w.resolution, [512, 512]);
    assert_eq!(w.background, DVec3::new(0.078, 0.361, 0.753));
    assert_eq!(w.surfaces.len(), 1);
    assert_eq!(w.surfaces[0].color, DVec3::new(1.0, 0.0, 0.0));
    assert_eq!(w.camera.half_angle_deg, 22.5);
    assert_eq!(
        w.camera.focus_distance,
        (w.camera.at - w.camera.position).length()
    );
}

#[test]
fn cubes_apply_transformations_in_written_order() {
    let w = thesis("cubes.yari");
    assert_eq!((w.features.polygons, w.features.spheres), (19, 7));
    // The floor and the big sphere come before `translate(0,-15,0)`: untouched.
    assert!(
        matches!(&w.objects[0].shape, Shape::Polygon { vertices } if vertices[0] == DVec3::new(-160.0, 0.0, -324.0))
    );
    assert!(
        matches!(w.objects[1].shape, Shape::Sphere { center, radius } if center == DVec3::new(-160.0, 100.0, -324.0) && radius == 100.0)
    );
    // The blob is translated by (0,50,-200).
    assert!(
        matches!(w.objects[2].shape, Shape::Sphere { center, .. } if close(center, DVec3::new(0.0, 60.0, -200.0)))
    );
    // First cube, vertex (0,0,0): translate(0,-15,0), then rotate 45 about x, 45 about y,
    // then scale 1.5, then translate(-30,60,0) -- worked by hand.
    let (s, c) = (45f64.to_radians().sin(), 45f64.to_radians().cos());
    let p = DVec3::new(0.0, -15.0, 0.0);
    let p = DVec3::new(p.x, p.y * c - p.z * s, p.y * s + p.z * c);
    let p = DVec3::new(p.x * c + p.z * s, p.y, -p.x * s + p.z * c);
    let expected = p * 1.5 + DVec3::new(-30.0, 60.0, 0.0);
    assert!(close(
        expected,
        DVec3::new(-41.25, 60.0 - 22.5 / 2f64.sqrt(), -11.25)
    ));
    match &w.objects[8].shape {
        Shape::Polygon { vertices } => assert!(
            close(vertices[3], expected),
            "{:?} vs {expected:?}",
            vertices[3]
        ),
        other => panic!("{other:?}"),
    }
    // The textured floor: wood, texture space = world space (no transformation).
    let floor = &w.surfaces[w.objects[0].surface as usize];
    let t = floor.texture.as_ref().unwrap();
    assert_eq!(t.kind, TextureKind::Wood);
    assert_eq!(t.world_to_texture, glam::DAffine3::IDENTITY);
    assert!(w.features.textures && w.features.reflection && !w.features.transparency);
}

#[test]
fn end_restores_transformation_attribute_and_motion() {
    let w = world(
        "attribute(color = red);
         begin attribute(color = blue); translate(1,0,0); motion(0,1,0); sphere(center=0,0,0; radius=1); end
         sphere(center=0,0,0; radius=1);",
    );
    let surf = |o: &Object| w.surfaces[o.surface as usize].color;
    assert_eq!(surf(&w.objects[0]), DVec3::new(0.0, 0.0, 1.0));
    assert_eq!(surf(&w.objects[1]), DVec3::new(1.0, 0.0, 0.0));
    assert!(matches!(w.objects[0].shape, Shape::Sphere { center, .. } if center == DVec3::X));
    assert!(matches!(w.objects[1].shape, Shape::Sphere { center, .. } if center == DVec3::ZERO));
    assert_eq!(
        (w.objects[0].motion, w.objects[1].motion),
        (DVec3::Y, DVec3::ZERO)
    );
    assert!(w.features.motion_blur);
}

#[test]
fn attribute_replaces_the_whole_surface_and_surfaces_are_shared() {
    let w = world(
        "attribute(color = red; kdr = 0.5); sphere(center=0,0,0; radius=1);
         attribute(phong = 3); sphere(center=0,0,0; radius=1);
         attribute(color = 1,0,0; kdr = 0.5); sphere(center=0,0,0; radius=1);",
    );
    assert_eq!(w.surfaces.len(), 2);
    assert_eq!(
        w.surfaces[1],
        Surface {
            phong: 3.0,
            ..Surface::default()
        }
    );
    assert_eq!(w.objects[2].surface, 0);
}

#[test]
fn spheres_stay_exact() {
    let w = world(
        "begin rotate(10,20,30); scale(2,2,2); translate(1,2,3); sphere(center=1,0,0; radius=1.5); end
         begin scale(1,2,3); sphere(center=1,0,0; radius=2); end",
    );
    match w.objects[0].shape {
        Shape::Sphere { radius, center } => {
            assert!((radius - 3.0).abs() < 1e-12);
            assert!(((center - DVec3::new(1.0, 2.0, 3.0)).length() - 2.0).abs() < 1e-12);
        }
        ref other => panic!("{other:?}"),
    }
    match w.objects[1].shape {
        Shape::Ellipsoid { to_world } => {
            assert!(close(
                to_world.transform_point3(DVec3::X),
                DVec3::new(3.0, 0.0, 0.0)
            ));
            assert!(close(
                to_world.transform_point3(DVec3::Y),
                DVec3::new(1.0, 4.0, 0.0)
            ));
            assert!(close(
                to_world.transform_point3(DVec3::Z),
                DVec3::new(1.0, 0.0, 6.0)
            ));
        }
        ref other => panic!("{other:?}"),
    }
    assert_eq!((w.features.spheres, w.features.ellipsoids), (1, 1));
}

#[test]
fn quadrics_transform_exactly() {
    let w = world(
        "begin translate(2,0,0); quadric(1 0 0 0 1 0 0 1 0 -1; clip = -1,-1,-1 1,1,1; plane = 0,0,1 0.5); end
         begin scale(2,1,1); quadric(1 0 0 0 1 0 0 1 0 -1); end",
    );
    let Shape::Quadric(q) = &w.objects[0].shape else {
        panic!()
    };
    let expect = [1.0, 0.0, 0.0, -2.0, 1.0, 0.0, 0.0, 1.0, 0.0, 3.0];
    assert!(
        q.q.iter().zip(expect).all(|(a, b)| (a - b).abs() < 1e-12),
        "{:?}",
        q.q
    );
    assert_eq!(q.clip.len(), 7);
    // x <= 1 in object space is x <= 3 in world space; z <= 0.5 stays.
    assert!(q
        .clip
        .iter()
        .any(|h| h.normal == DVec3::X && (h.offset - 3.0).abs() < 1e-12));
    assert!(q
        .clip
        .iter()
        .any(|h| h.normal == DVec3::Z && (h.offset - 0.5).abs() < 1e-12));
    let Shape::Quadric(q) = &w.objects[1].shape else {
        panic!()
    };
    assert!((q.q[0] - 0.25).abs() < 1e-12 && (q.q[4] - 1.0).abs() < 1e-12);
}

#[test]
fn textures_follow_their_object() {
    let w = world("attribute(texture = 2 0,0,0 1,1,1); begin translate(5,0,0); sphere(center=0,0,0; radius=1); end
                   attribute(texture = 9 0,0,0 1,1,1); sphere(center=0,0,0; radius=1);");
    let t = w.surfaces[0].texture.as_ref().unwrap();
    assert_eq!(t.kind, TextureKind::Marble);
    assert!(close(
        t.world_to_texture
            .transform_point3(DVec3::new(5.0, 0.0, 0.0)),
        DVec3::ZERO
    ));
    assert!(w.surfaces[1].texture.is_none());
    assert!(warnings("attribute(texture = 9 0,0,0 1,1,1);")[0].contains("unknown texture id 9"));
}

#[test]
fn degenerate_input_warns() {
    let w = warnings(
        "polygon(vertices=3; 0,0,0 1,1,1 2,2,2);
         polygon(vertices=4; 0,0,0 0,0,0 1,0,0 1,0,0);
         polygon(vertices=4; 0,0,0 1,0,0 1,0,0 0,1,0);
         quadric(1 0 0 0 1 0 0 0 0 -1);
         attribute(gloss = 5);",
    );
    assert_eq!(w.len(), 5, "{w:?}");
    assert!(w[0].contains("no area") && w[1].contains("fewer than 3") && w[2].contains("repeated"));
    assert!(w[3].contains("unbounded") && w[4].contains("no effect"));
    let missing = compile_text("begin end").unwrap().warnings;
    let text: Vec<&str> = missing.items.iter().map(|d| d.message.as_str()).collect();
    assert_eq!(text.len(), 3, "{text:?}");
    assert!(
        text[0].starts_with("no `resolution`")
            && text[1].starts_with("no `camera`")
            && text[2].starts_with("no `light`")
    );
}

#[test]
fn errors_with_spans() {
    let cam = |c: &str| errors(&format!("camera({c}); begin end"));
    assert!(cam("position=0,0,1; at=0,0,0; up=0,0,0; angle=20")[0].contains("zero vector"));
    assert!(cam("position=0,0,1; at=0,0,1; up=0,1,0; angle=20")[0].contains("differ"));
    assert!(cam("position=0,0,1; at=0,0,0; up=0,0,3; angle=20")[0].contains("parallel"));
    assert!(cam("position=0,0,1; at=0,0,0; up=0,1,0; angle=90")[0].contains("between 0 and 90"));
    assert!(cam("position=0,0,1; at=0,0,0; up=0,1,0; angle=0")[0].contains("between 0 and 90"));
    let body = |b: &str| errors(&format!("{VIEW} begin {b} end"));
    assert!(body("sphere(center=0,0,0; radius=0);")[0].contains("radius"));
    assert!(body("sphere(center=0,0,0; radius=-1);")[0].contains("radius"));
    assert!(body("polygon(vertices=2; 0,0,0 1,1,1);")[0].contains("at least 3"));
    assert!(body("attribute(color = reed);")[0]
        .contains("unknown colour name `reed`; did you mean `red`?"));
    assert!(
        body("scale(1e200,1,1); scale(1e200,1,1); sphere(center=0,0,0; radius=1);")[0]
            .contains("overflows")
    );
    assert!(body("scale(0,1,1);")[0].contains("zero"));
    assert!(
        body("scale(1,1,1e300); quadric(1 1 1 0 0 0 0 0 0 -1; plane = 0,0,1e-30 0);")[0]
            .contains("normal vanishes")
    );
    let text = format!("{VIEW}begin\n  sphere(center=0,0,0; radius=0);\nend\n");
    let d = compile_text(&text).unwrap_err();
    assert!(d
        .render(&Source::new("t.yari", text.as_str()))
        .contains("t.yari:3:3: error: sphere radius must be more than 0"));
}

#[test]
fn preamble_last_wins_and_lights_accumulate() {
    let c = compile_text(
        "resolution(10,10); resolution(20,30); samples(4); background(color=red); background(color=blue);
         light(position=0,1,0; color=white); light(position=0,2,0; color=0.5,0.5,0.5; radius=0.1);
         camera(position=0,0,1; at=0,0,0; up=0,1,0; angle=10; aperture=0.2);
         begin end",
    )
    .unwrap();
    let w = c.world;
    assert_eq!(w.resolution, [20, 30]);
    assert_eq!(w.background, DVec3::new(0.0, 0.0, 1.0));
    assert_eq!(w.lights.len(), 2);
    assert!(w.features.area_lights && w.features.depth_of_field && w.features.antialiasing);
    assert_eq!(w.samples, 4);
}

#[test]
fn non_finite_numbers_from_other_front_ends_are_errors() {
    // The parser cannot produce NaN or infinity, but a tree built by a converter might.
    use crate::ast::{AttrField, BodyItem, Primitive, Spanned};
    let nan = f64::NAN;
    let items = vec![
        BodyItem::Primitive(Primitive::Sphere {
            center: [nan, 0.0, 0.0],
            radius: 1.0,
        }),
        BodyItem::Primitive(Primitive::Polygon {
            vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, f64::INFINITY, 0.0]],
            normals: None,
        }),
        BodyItem::Primitive(Primitive::Polygon {
            vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            normals: Some(vec![[0.0, 0.0, 1.0], [nan, 0.0, 1.0], [0.0, 0.0, 1.0]]),
        }),
        BodyItem::Primitive(Primitive::Quadric {
            coeffs: [nan; 10],
            clip: vec![],
        }),
        BodyItem::Attribute(vec![Spanned::new(AttrField::Kdr(nan), Span::default())]),
        BodyItem::Attribute(vec![Spanned::new(
            AttrField::Color(Spanned::new(ColorSpec::Rgb([nan; 3]), Span::default())),
            Span::default(),
        )]),
    ];
    for item in items {
        let mut scene = parse(&Source::new("t", format!("{VIEW} begin end"))).unwrap();
        scene
            .body
            .items
            .push(Spanned::new(item.clone(), Span::default()));
        assert!(
            compile(&scene, &ColourTable::builtin()).is_err(),
            "{item:?}"
        );
    }
}

/// The normals of the only object, which must be a smooth polygon.
fn normals_of(w: &World) -> Vec<DVec3> {
    match &w.objects[0].shape {
        Shape::SmoothPolygon { vertices, normals } => {
            assert_eq!(vertices.len(), normals.len());
            normals.clone()
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn normals_follow_the_inverse_transpose_and_are_renormalised() {
    let tri = "polygon(vertices=3; 0,0,0 1,0,0 0,1,0; normals = 1,1,0 0,0,2 1,0,1);";
    // With no transformation the normals are kept as written (no arithmetic).
    let n = normals_of(&world(tri));
    assert_eq!(n[1], DVec3::new(0.0, 0.0, 2.0));
    // scale(2,1,1): L^-T = diag(1/2, 1, 1), then unit length.
    let n = normals_of(&world(&format!("scale(2,1,1); {tri}")));
    let s = 1.25f64.sqrt();
    assert!(close(n[0], DVec3::new(0.5 / s, 1.0 / s, 0.0)), "{n:?}");
    assert!(close(n[1], DVec3::Z), "{n:?}");
    assert!(close(n[2], DVec3::new(0.5 / s, 0.0, 1.0 / s)), "{n:?}");
    // Then a quarter turn about z: (x, y) -> (-y, x).
    let n = normals_of(&world(&format!("scale(2,1,1); rotate(0,0,90); {tri}")));
    assert!(close(n[0], DVec3::new(-1.0 / s, 0.5 / s, 0.0)), "{n:?}");
    // A normal stays perpendicular to the surface's tangents under a shear.
    let w = world(&format!(
        "transform(1 0.7 0 3  0 1 0.2 0  0.4 0 1 0); {tri}"
    ));
    let m = crate::compile::stack::rows_to_affine(&[
        1.0, 0.7, 0.0, 3.0, 0.0, 1.0, 0.2, 0.0, 0.4, 0.0, 1.0, 0.0,
    ]);
    let n = normals_of(&w);
    // The object-space normal (1,1,0) is perpendicular to the tangent (1,-1,0).
    let t = m.transform_vector3(DVec3::new(1.0, -1.0, 0.0));
    assert!(n[0].dot(t).abs() < 1e-12 && (n[0].length() - 1.0).abs() < 1e-12);
}

#[test]
fn normals_stay_with_their_vertices_when_repeats_are_removed() {
    let w = world(
        "polygon(vertices=5; 0,0,0 0,0,0 1,0,0 0,1,0 0,0,0; normals = 0,0,1 9,9,9 0,1,1 1,0,1 7,7,7);",
    );
    assert_eq!(
        normals_of(&w),
        vec![
            DVec3::Z,
            DVec3::new(0.0, 1.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0)
        ]
    );
    assert_eq!(w.features.polygons, 1);
}
