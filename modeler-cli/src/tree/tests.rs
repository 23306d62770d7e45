use crate::project::{Color, Object, Primitive, Project, Surface, Transform};

fn part(name: &str, x: f64) -> Object {
    Object { name: name.into(), primitives: vec![Primitive::Sphere { center: [x, 0.0, 0.0], radius: 1.0 }], ..Object::default() }
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
    assert_eq!(g.children.iter().map(|o| o.name.as_str()).collect::<Vec<_>>(), ["b", "a"]);
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
    assert!(p.combine("x", &["a".into(), "zzz".into()]).unwrap_err().to_string().contains("zzz"));
    assert!(p.combine("x", &["c".into(), "c".into()]).is_err());
    assert!(p.combine("x", &["g".into(), "a".into()]).unwrap_err().to_string().contains("inside"));
    assert_eq!(p, before);
}

#[test]
fn explode_undoes_combine_and_keeps_the_group_surface() {
    let mut p = project();
    p.combine("g", &["a".into(), "b".into()]).unwrap();
    let red = Surface { color: Some(Color::Named("red".into())), ..Surface::default() };
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
    two.primitives.push(Primitive::Sphere { center: [6.0, 0.0, 0.0], radius: 1.0 });
    two.transforms.push(Transform::Scale([2.0, 2.0, 2.0]));
    p.add_object(two).unwrap();
    assert_eq!(p.explode("two").unwrap(), ["two.1", "two.2"]);
    assert_eq!(p.object("two.2").unwrap().transforms, [Transform::Scale([2.0, 2.0, 2.0])]);
    assert!(p.explode("a").is_err());
}

#[test]
fn transforms_go_to_every_part_in_world_order_with_a_pivot() {
    let mut p = project();
    p.combine("g", &["a".into(), "b".into()]).unwrap();
    p.transform_object("b", Transform::Rotate([0.0, 90.0, 0.0]), None).unwrap();
    p.transform_object("g", Transform::Scale([2.0, 2.0, 2.0]), Some([1.0, 0.0, 0.0])).unwrap();
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
    assert_eq!(p.object_names(), ["k", "k.body", "b", "c", "q", "q.body", "q.b"]);
    assert!(p.rename_object("q", "k").is_err());
    assert!(p.rename_object("q", "bad name").is_err());
}
