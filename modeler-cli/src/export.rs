//! Project to YARI: builds a [`yari::ast::Scene`] (each object a nested `begin ... end`
//! block) and prints it with [`yari::writer::write_scene`], then writes each object's name
//! as a `/* name */` comment on the line before its `begin` and each light's name as a
//! comment in front of its `light(...)`. Comments are plain YARI, so every reader accepts
//! the file; `import` reads the names back.

use crate::project::{Clip, Color, Object, Primitive, Project, Surface, Transform};
use yari::ast::{self, AttrField, Block, BodyItem, ColorSpec, Spanned, ViewStmt};
use yari::span::Span;

fn sp<T>(node: T) -> Spanned<T> {
    Spanned::new(node, Span::default())
}

/// The project as a YARI syntax tree (skeletons and the preview viewpoint are the
/// modeler's own and are not part of it).
pub fn to_scene(project: &Project) -> ast::Scene {
    let s = &project.settings;
    let mut view = Vec::new();
    if let Some([w, h]) = s.resolution {
        view.push(sp(ViewStmt::Resolution(w, h)));
    }
    if let Some(n) = s.samples {
        view.push(sp(ViewStmt::Samples(n)));
    }
    if let Some(e) = s.target_error {
        view.push(sp(ViewStmt::TargetError(e)));
    }
    if let Some(c) = &s.background {
        view.push(sp(ViewStmt::Background(sp(color(c)))));
    }
    if let Some(c) = &s.ambient {
        view.push(sp(ViewStmt::Ambient(sp(color(c)))));
    }
    for l in &s.lights {
        view.push(sp(ViewStmt::Light(ast::LightDef {
            position: l.position,
            color: sp(color(&l.color)),
            radius: l.radius,
        })));
    }
    if let Some(c) = &s.camera {
        view.push(sp(ViewStmt::Camera(ast::CameraDef {
            position: c.position,
            at: c.at,
            up: c.up,
            angle: c.angle,
            aperture: c.aperture,
            focus: c.focus,
        })));
    }
    let items = project
        .objects
        .iter()
        .map(|o| sp(BodyItem::Block(block(o))))
        .collect();
    ast::Scene {
        view,
        body: Block {
            items,
            span: Span::default(),
        },
    }
}

/// The project as YARI text with the names as comments.
pub fn to_yari(project: &Project) -> String {
    let text = yari::writer::write_scene(&to_scene(project));
    let mut names = Vec::new();
    for o in &project.objects {
        o.walk(&mut |o, _| names.push(o.name.as_str()), 0);
    }
    let mut names = names.into_iter();
    let mut lights = project.settings.lights.iter().map(|l| l.name.as_str());
    let mut out = String::with_capacity(text.len() + 64 * project.objects.len());
    out.push_str("/* Written by modeler. Each object's name is the comment before its block. */\n");
    let mut seen_world = false;
    for line in text.lines() {
        let trimmed = line.trim_start();
        if trimmed == "begin" {
            if seen_world {
                if let Some(name) = names.next() {
                    let indent = &line[..line.len() - trimmed.len()];
                    out.push_str(&format!("{indent}/* {name} */\n"));
                }
            }
            seen_world = true;
        } else if trimmed.starts_with("light(") {
            if let Some(name) = lights.next() {
                out.push_str(&format!("/* {name} */ "));
            }
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

fn block(o: &Object) -> Block {
    let mut items = Vec::new();
    if let Some(s) = &o.surface {
        items.push(sp(BodyItem::Attribute(attribute(s))));
    }
    items.extend(
        o.transforms
            .iter()
            .map(|t| sp(BodyItem::Transform(transform(t)))),
    );
    items.extend(o.primitives.iter().map(|p| sp(primitive(p))));
    items.extend(o.children.iter().map(|c| sp(BodyItem::Block(block(c)))));
    Block {
        items,
        span: Span::default(),
    }
}

fn color(c: &Color) -> ColorSpec {
    match c {
        Color::Named(n) => ColorSpec::Named(n.clone()),
        Color::Rgb(v) => ColorSpec::Rgb(*v),
    }
}

/// An optional number and the attribute field it makes.
type Field = (Option<f64>, fn(f64) -> AttrField);

fn attribute(s: &Surface) -> Vec<Spanned<AttrField>> {
    let mut f = Vec::new();
    if let Some(c) = &s.color {
        f.push(AttrField::Color(sp(color(c))));
    }
    let scalars: [Field; 5] = [
        (s.kdr, AttrField::Kdr),
        (s.kdt, AttrField::Kdt),
        (s.ka, AttrField::Ka),
        (s.phong, AttrField::Phong),
        (s.refract, AttrField::Refract),
    ];
    f.extend(scalars.iter().filter_map(|(v, make)| v.map(make)));
    if let Some(t) = &s.texture {
        f.push(AttrField::Texture {
            id: t.id,
            color: t.color,
            scale: t.scale,
        });
    }
    let extensions: [Field; 3] = [
        (s.gloss, AttrField::Gloss),
        (s.translucency, AttrField::Translucency),
        (s.transmissivity, AttrField::Transmissivity),
    ];
    f.extend(extensions.iter().filter_map(|(v, make)| v.map(make)));
    if let Some(m) = s.texture_space {
        f.push(AttrField::TextureSpace(m));
    }
    f.into_iter().map(sp).collect()
}

fn transform(t: &Transform) -> ast::Transform {
    match t {
        Transform::Translate(v) => ast::Transform::Translate(*v),
        Transform::Scale(v) => ast::Transform::Scale(*v),
        Transform::Rotate(v) => ast::Transform::Rotate(*v),
        Transform::Motion(v) => ast::Transform::Motion(*v),
        Transform::Matrix(m) => ast::Transform::Matrix(*m),
    }
}

/// A primitive as the statement that writes it: a mesh is a statement of its own.
fn primitive(p: &Primitive) -> BodyItem {
    let prim = match p {
        Primitive::Sphere { center, radius } => ast::Primitive::Sphere {
            center: *center,
            radius: *radius,
        },
        Primitive::Polygon { vertices, normals } => ast::Primitive::Polygon {
            vertices: vertices.clone(),
            normals: normals.clone(),
        },
        Primitive::Quadric { coeffs, clip } => ast::Primitive::Quadric {
            coeffs: *coeffs,
            clip: clip
                .iter()
                .map(|c| match c {
                    Clip::Box { min, max } => ast::Clip::Box {
                        min: *min,
                        max: *max,
                    },
                    Clip::Plane { normal, offset } => ast::Clip::Plane {
                        normal: *normal,
                        offset: *offset,
                    },
                })
                .collect(),
        },
        Primitive::Mesh {
            file,
            materials_file,
        } => {
            return BodyItem::Mesh(ast::MeshStmt {
                file: sp(file.clone()),
                materials: if *materials_file {
                    ast::MeshMaterials::File
                } else {
                    ast::MeshMaterials::Current
                },
            })
        }
    };
    BodyItem::Primitive(prim)
}
