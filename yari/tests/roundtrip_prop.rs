//! Property tests: any syntax tree prints and parses back to itself; any text parses or
//! fails without a panic; any compiled world prints and compiles back to itself.

use proptest::prelude::*;
use yari::ast::*;
use yari::colour::ColourTable;
use yari::span::{Source, Span};
use yari::writer::{erase_spans, write_scene, write_world};

fn sp<T>(node: T) -> Spanned<T> {
    Spanned::new(node, Span::default())
}

fn num() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => -100.0..100.0f64,
        1 => prop::num::f64::NORMAL | prop::num::f64::ZERO | prop::num::f64::SUBNORMAL,
        1 => (-3i32..4).prop_map(f64::from),
    ]
}

fn vec3() -> impl Strategy<Value = Vec3> {
    [num(), num(), num()]
}

fn name() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("red".to_string()),
        Just("UNC_Blue".to_string()),
        "[A-Za-z_][A-Za-z0-9_]{0,8}"
    ]
}

fn colour() -> impl Strategy<Value = Spanned<ColorSpec>> {
    prop_oneof![
        vec3().prop_map(ColorSpec::Rgb),
        name().prop_map(ColorSpec::Named)
    ]
    .prop_map(sp)
}

fn view() -> impl Strategy<Value = ViewStmt> {
    prop_oneof![
        (1u32..=65536, 1u32..=65536).prop_map(|(x, y)| ViewStmt::Resolution(x, y)),
        (1u32..=65536).prop_map(ViewStmt::Samples),
        num().prop_map(ViewStmt::TargetError),
        colour().prop_map(ViewStmt::Background),
        colour().prop_map(ViewStmt::Ambient),
        (vec3(), colour(), prop::option::of(0.0..10.0f64)).prop_map(|(position, color, radius)| {
            ViewStmt::Light(LightDef {
                position,
                color,
                radius,
            })
        }),
        (
            vec3(),
            vec3(),
            vec3(),
            num(),
            prop::option::of(num()),
            prop::option::of(num())
        )
            .prop_map(
                |(position, at, up, angle, aperture, focus)| ViewStmt::Camera(CameraDef {
                    position,
                    at,
                    up,
                    angle,
                    aperture,
                    focus
                })
            ),
    ]
}

fn attr_field() -> impl Strategy<Value = AttrField> {
    prop_oneof![
        colour().prop_map(AttrField::Color),
        num().prop_map(AttrField::Kdr),
        num().prop_map(AttrField::Phong),
        num().prop_map(AttrField::Gloss),
        (num(), vec3(), vec3()).prop_map(|(id, color, scale)| AttrField::Texture {
            id,
            color,
            scale
        }),
        prop::array::uniform12(num()).prop_map(AttrField::TextureSpace),
    ]
}

fn leaf() -> impl Strategy<Value = BodyItem> {
    prop_oneof![
        prop::collection::vec(attr_field(), 0..4).prop_map(|fields| {
            // One field of each kind, as the parser requires.
            let mut seen = Vec::new();
            let fields = fields
                .into_iter()
                .filter(|f| {
                    let d = std::mem::discriminant(f);
                    let new = !seen.contains(&d);
                    seen.push(d);
                    new
                })
                .map(sp)
                .collect();
            BodyItem::Attribute(fields)
        }),
        (vec3(), num())
            .prop_map(|(center, radius)| BodyItem::Primitive(Primitive::Sphere { center, radius })),
        prop::collection::vec(
            (
                vec3(),
                vec3().prop_filter("a normal has a direction", has_direction)
            ),
            0..6
        )
        .prop_flat_map(|corners| (Just(corners), any::<bool>()))
        .prop_map(|(corners, smooth)| {
            let (vertices, normals): (Vec<Vec3>, Vec<Vec3>) = corners.into_iter().unzip();
            let normals = smooth.then_some(normals);
            BodyItem::Primitive(Primitive::Polygon { vertices, normals })
        }),
        (
            prop::array::uniform10(num()),
            prop::collection::vec((vec3(), num()), 0..3)
        )
            .prop_map(|(coeffs, planes)| {
                let clip = planes
                    .into_iter()
                    .map(|(normal, offset)| Clip::Plane { normal, offset })
                    .collect();
                BodyItem::Primitive(Primitive::Quadric { coeffs, clip })
            }),
        vec3().prop_map(|v| BodyItem::Transform(Transform::Translate(v))),
        vec3().prop_map(|v| BodyItem::Transform(Transform::Scale(v))),
        vec3().prop_map(|v| BodyItem::Transform(Transform::Rotate(v))),
        vec3().prop_map(|v| BodyItem::Transform(Transform::Motion(v))),
        prop::array::uniform12(num()).prop_map(|m| BodyItem::Transform(Transform::Matrix(m))),
        ("[a-zA-Z0-9_ ./-]{1,16}", any::<bool>()).prop_map(|(file, own)| {
            BodyItem::Mesh(MeshStmt {
                file: sp(file),
                materials: if own {
                    MeshMaterials::File
                } else {
                    MeshMaterials::Current
                },
            })
        }),
    ]
}

fn block() -> impl Strategy<Value = Block> {
    let item = leaf().prop_recursive(4, 32, 6, |inner| {
        prop::collection::vec(inner, 0..6).prop_map(|items| {
            BodyItem::Block(Block {
                items: items.into_iter().map(sp).collect(),
                span: Span::default(),
            })
        })
    });
    prop::collection::vec(item, 0..10).prop_map(|items| Block {
        items: items.into_iter().map(sp).collect(),
        span: Span::default(),
    })
}

fn scene() -> impl Strategy<Value = Scene> {
    (prop::collection::vec(view(), 0..6), block()).prop_map(|(view, body)| Scene {
        view: view.into_iter().map(sp).collect(),
        body,
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn any_tree_prints_and_parses_back(scene in scene()) {
        let text = write_scene(&scene);
        let src = Source::new("p.yari", text.as_str());
        let mut back = yari::parse::parse(&src).map_err(|d| TestCaseError::fail(d.render(&src)))?;
        erase_spans(&mut back);
        prop_assert_eq!(back, scene);
    }

    #[test]
    fn compiled_worlds_print_and_compile_back(scene in scene()) {
        if let Ok(compiled) = yari::compile::compile(&scene, &ColourTable::builtin()) {
            prop_assert_eq!(yari::modelfile::validate(&compiled.world), Ok(()));
            let flat = write_world(&compiled.world);
            let src = Source::new("flat.yari", flat.as_str());
            let back = yari::parse::parse(&src).map_err(|d| TestCaseError::fail(d.render(&src)))?;
            let back = yari::compile::compile(&back, &ColourTable::builtin()).map_err(|d| TestCaseError::fail(d.render(&src)))?;
            prop_assert_eq!(back.world, compiled.world);
        }
    }

    #[test]
    fn any_text_parses_or_fails_without_panic(text in "[ -~\n\t]{0,300}") {
        let src = Source::new("r.yari", text.as_str());
        if let Err(d) = yari::parse::parse(&src) {
            prop_assert!(d.has_errors());
            let _ = d.render(&src);
        }
    }

    #[test]
    fn token_soup_parses_or_fails_without_panic(
        words in prop::collection::vec(prop::sample::select(vec![
            "begin", "end", "(", ")", ";", ",", "=", "sphere", "polygon", "vertices", "center", "radius", "1", "-.5",
            "1e3", "camera", "attribute", "color", "red", "quadric", "clip", "/*", "*/", "translate",
            "normals", "0",
        ]), 0..60)
    ) {
        let text = words.join(" ");
        let src = Source::new("r.yari", text.as_str());
        if let Ok(scene) = yari::parse::parse(&src) {
            let _ = yari::compile::compile(&scene, &ColourTable::builtin());
        }
    }
}
