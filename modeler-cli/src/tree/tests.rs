use crate::project::{Color, Object, Primitive, Project, Surface, Transform};

fn part(name: &str, x: f64) -> Object {
    Object {
        name: name.into(),
        primitives: vec![Primitive::Sphere {
            center: [x, 0.0, 0.0],
            radius: 1.0,
        }],
        ..Object::default()
    }
}

fn project() -> Project {
    let mut p = Project::new_default();
    for (n, x) in [("a", 0.0), ("b", 1.0), ("c", 2.0)] {
        p.add_object(part(n, x)).unwrap();
    }
    p
}

#[test]
fn combine_puts_the_group_where_the_first_member_was() {
    let mut p = project();
    p.combine("g", &["b".into(), "a".into()]).unwrap();
    let top: Vec<&str> = p.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(top, ["g", "c"]);
    let g = p.object("g").unwrap();
    assert_eq!(
        g.children
            .iter()
            .map(|o| o.name.as_str())
            .collect::<Vec<_>>(),
        ["b", "a"]
    );
    // Groups nest, and names stay unique.
    p.combine("h", &["g".into(), "c".into()]).unwrap();
    assert_eq!(p.object_names(), ["h", "g", "b", "a", "c"]);
    assert!(p.combine("h", &["a".into()]).is_err());
}

#[test]
fn combine_refuses_unknown_repeated_and_nested_members_without_changing_anything() {
    let mut p = project();
    p.combine("g", &["a".into(), "b".into()]).unwrap();
    let before = p.clone();
    assert!(p
        .combine("x", &["a".into(), "zzz".into()])
        .unwrap_err()
        .to_string()
        .contains("zzz"));
    assert!(p.combine("x", &["c".into(), "c".into()]).is_err());
    assert!(p
        .combine("x", &["g".into(), "a".into()])
        .unwrap_err()
        .to_string()
        .contains("inside"));
    assert_eq!(p, before);
}

#[test]
fn explode_undoes_combine_and_keeps_the_group_surface() {
    let mut p = project();
    p.combine("g", &["a".into(), "b".into()]).unwrap();
    let red = Surface {
        color: Some(Color::Named("red".into())),
        ..Surface::default()
    };
    p.object_mut("g").unwrap().surface = Some(red.clone());
    let names = p.explode("g").unwrap();
    assert_eq!(names, ["a", "b"]);
    assert_eq!(p.object_names(), ["a", "b", "c"]);
    assert_eq!(p.object("a").unwrap().surface, Some(red));
}

#[test]
fn explode_splits_a_part_into_one_part_per_primitive() {
    let mut p = project();
    let mut two = part("two", 5.0);
    two.primitives.push(Primitive::Sphere {
        center: [6.0, 0.0, 0.0],
        radius: 1.0,
    });
    two.transforms.push(Transform::Scale([2.0, 2.0, 2.0]));
    p.add_object(two).unwrap();
    assert_eq!(p.explode("two").unwrap(), ["two.1", "two.2"]);
    assert_eq!(
        p.object("two.2").unwrap().transforms,
        [Transform::Scale([2.0, 2.0, 2.0])]
    );
    assert!(p.explode("a").is_err());
}

#[test]
fn transforms_go_to_every_part_in_world_order_with_a_pivot() {
    let mut p = project();
    p.combine("g", &["a".into(), "b".into()]).unwrap();
    p.transform_object("b", Transform::Rotate([0.0, 90.0, 0.0]), None)
        .unwrap();
    p.transform_object(
        "g",
        Transform::Scale([2.0, 2.0, 2.0]),
        Some([1.0, 0.0, 0.0]),
    )
    .unwrap();
    assert!(p.object("g").unwrap().transforms.is_empty());
    assert_eq!(
        p.object("b").unwrap().transforms,
        [
            Transform::Rotate([0.0, 90.0, 0.0]),
            Transform::Translate([-1.0, 0.0, 0.0]),
            Transform::Scale([2.0, 2.0, 2.0]),
            Transform::Translate([1.0, 0.0, 0.0]),
        ]
    );
    assert_eq!(p.object("a").unwrap().transforms.len(), 3);
    assert!(p.object("c").unwrap().transforms.is_empty());
}

#[test]
fn copy_renames_the_copies_inside() {
    let mut p = project();
    p.rename_object("a", "k.body").unwrap();
    p.combine("k", &["k.body".into(), "b".into()]).unwrap();
    p.copy_object("k", "q").unwrap();
    assert_eq!(
        p.object_names(),
        ["k", "k.body", "b", "c", "q", "q.body", "q.b"]
    );
    assert!(p.rename_object("q", "k").is_err());
    assert!(p.rename_object("q", "bad name").is_err());
}

/// Every point of every shape in the compiled world, in order.
fn world_points(p: &Project) -> Vec<glam::DVec3> {
    let scene = crate::export::to_scene(p);
    let world = yari::compile::compile(&scene, &yari::colour::ColourTable::builtin())
        .unwrap()
        .world;
    world
        .objects
        .iter()
        .flat_map(|o| match &o.shape {
            yari::model::Shape::Polygon { vertices } => vertices.clone(),
            yari::model::Shape::Sphere { center, .. } => vec![*center],
            yari::model::Shape::Ellipsoid { to_world } => vec![to_world.translation],
            other => panic!("unexpected {other:?}"),
        })
        .collect()
}

#[test]
fn a_composite_moves_and_turns_as_one_body_in_world_space() {
    let mut p = project();
    let tri = Object {
        name: "tri".into(),
        primitives: vec![Primitive::Polygon {
            vertices: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.5]],
            normals: None,
        }],
        ..Object::default()
    };
    p.add_object(tri).unwrap();
    // Parts with their own, different transformations inside a composite.
    p.transform_object(
        "a",
        Transform::Rotate([30.0, 60.0, 10.0]),
        Some([0.5, 0.0, 0.0]),
    )
    .unwrap();
    p.transform_object("tri", Transform::Scale([2.0, 1.0, 3.0]), None)
        .unwrap();
    p.transform_object("b", Transform::Translate([0.0, 4.0, 0.0]), None)
        .unwrap();
    p.combine("g", &["a".into(), "tri".into(), "b".into()])
        .unwrap();
    let before = world_points(&p);

    p.transform_object("g", Transform::Translate([1.0, 2.0, 3.0]), None)
        .unwrap();
    let moved = world_points(&p);
    // g holds 1 + 3 + 1 points; `c`, outside g, stays where it was.
    assert_eq!((before.len(), before[5]), (6, moved[5]));
    for (a, b) in before[..5].iter().zip(&moved) {
        assert!(
            (*b - *a - glam::DVec3::new(1.0, 2.0, 3.0)).length() < 1e-9,
            "{a} -> {b}"
        );
    }

    let pivot = glam::DVec3::new(1.0, 2.0, 3.0);
    p.transform_object(
        "g",
        Transform::Rotate([0.0, 90.0, 0.0]),
        Some(pivot.to_array()),
    )
    .unwrap();
    let turned = world_points(&p);
    // 90 degrees about y through the pivot: (x, y, z) - pivot -> (z, y, -x).
    assert_eq!(moved[5], turned[5]);
    for (a, b) in moved[..5].iter().zip(&turned) {
        let d = *a - pivot;
        let expected = pivot + glam::DVec3::new(d.z, d.y, -d.x);
        assert!(
            (*b - expected).length() < 1e-9,
            "{a} -> {b}, expected {expected}"
        );
    }
}

#[test]
fn objects_moved_by_combine_or_copy_keep_their_look() {
    let mut p = project();
    let red = Surface {
        color: Some(Color::Named("red".into())),
        ..Surface::default()
    };
    p.combine("g", &["a".into()]).unwrap();
    p.object_mut("g").unwrap().surface = Some(red.clone());
    // b (default surface) joins a inside the red group: it must not turn red.
    p.combine("h", &["a".into(), "b".into()]).unwrap();
    assert_eq!(p.object_names(), ["g", "h", "a", "b", "c"]);
    assert_eq!(p.effective_surface("a"), Some(red.clone()));
    assert_eq!(p.effective_surface("b"), Some(Surface::default()));
    assert_eq!(p.object("b").unwrap().surface, Some(Surface::default()));
    // a leaves the red group for the top level: it takes red along.
    p.combine("k", &["c".into(), "a".into()]).unwrap();
    assert_eq!(p.effective_surface("a"), Some(red.clone()));
    assert_eq!(p.object("c").unwrap().surface, None);
    // A copy of a part of the red group is red on its own.
    p.copy_object("b", "b2").unwrap();
    p.copy_object("h", "h2").unwrap();
    assert_eq!(p.object("h2").unwrap().surface, Some(red));
}
