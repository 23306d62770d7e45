//! A compiled world printed as a flat YARI file: every primitive in world space, each
//! surface written out in full, so that compiling the text gives the same world back.
//!
//! Two extensions carry what the thesis's syntax cannot say exactly: an ellipsoid is
//! `begin transform(m00 ... m23); sphere(center = 0,0,0; radius = 1); end`, and a textured
//! surface gives its world-to-texture map with `texture_space = m00 ... m23`. A moving object
//! sits in its own block after `motion(dx,dy,dz)`.

use super::write_scene;
use crate::ast::{
    AttrField, Block, BodyItem, CameraDef, Clip, ColorSpec, LightDef, Primitive, Scene, Spanned,
    Transform, ViewStmt,
};
use crate::model::{Shape, Surface, World};
use crate::span::Span;
use glam::{DAffine3, DVec3};

/// Prints a compiled world as YARI text (see the module docs).
pub fn write_world(world: &World) -> String {
    write_scene(&world_to_scene(world))
}

/// The 3x4 matrix of an affine map, row by row.
pub fn affine_to_rows(m: &DAffine3) -> [f64; 12] {
    let (x, y, z, t) = (
        m.matrix3.x_axis,
        m.matrix3.y_axis,
        m.matrix3.z_axis,
        m.translation,
    );
    [x.x, y.x, z.x, t.x, x.y, y.y, z.y, t.y, x.z, y.z, z.z, t.z]
}

fn sp<T>(node: T) -> Spanned<T> {
    Spanned::new(node, Span::default())
}

fn v3(v: DVec3) -> [f64; 3] {
    v.to_array()
}

/// A compiled world as a syntax tree whose compilation is that world.
pub fn world_to_scene(world: &World) -> Scene {
    let c = &world.camera;
    let mut view = vec![
        sp(ViewStmt::Resolution(
            world.resolution[0],
            world.resolution[1],
        )),
        sp(ViewStmt::Samples(world.samples)),
        sp(ViewStmt::Background(sp(ColorSpec::Rgb(v3(
            world.background
        ))))),
        sp(ViewStmt::Ambient(sp(ColorSpec::Rgb(v3(world.ambient))))),
        sp(ViewStmt::Camera(CameraDef {
            position: v3(c.position),
            at: v3(c.at),
            up: v3(c.up),
            angle: c.half_angle_deg,
            aperture: (c.aperture != 0.0).then_some(c.aperture),
            focus: Some(c.focus_distance),
        })),
    ];
    if let Some(e) = world.target_error {
        view.push(sp(ViewStmt::TargetError(e)));
    }
    for l in &world.lights {
        view.push(sp(ViewStmt::Light(LightDef {
            position: v3(l.position),
            color: sp(ColorSpec::Rgb(v3(l.color))),
            radius: (l.radius != 0.0).then_some(l.radius),
        })));
    }
    let mut items = Vec::with_capacity(world.objects.len() + world.surfaces.len());
    let mut current: Option<u32> = None;
    for obj in &world.objects {
        if current != Some(obj.surface) {
            if let Some(s) = world.surfaces.get(obj.surface as usize) {
                items.push(sp(BodyItem::Attribute(surface_fields(s))));
            }
            current = Some(obj.surface);
        }
        let mut wrap: Vec<Spanned<BodyItem>> = Vec::new();
        if obj.motion != DVec3::ZERO {
            wrap.push(sp(BodyItem::Transform(Transform::Motion(v3(obj.motion)))));
        }
        let prim = match &obj.shape {
            Shape::Sphere { center, radius } => Primitive::Sphere {
                center: v3(*center),
                radius: *radius,
            },
            Shape::Ellipsoid { to_world } => {
                wrap.push(sp(BodyItem::Transform(Transform::Matrix(affine_to_rows(
                    to_world,
                )))));
                Primitive::Sphere {
                    center: [0.0; 3],
                    radius: 1.0,
                }
            }
            Shape::Polygon { vertices } => Primitive::Polygon {
                vertices: vertices.iter().map(|v| v3(*v)).collect(),
                normals: None,
            },
            Shape::SmoothPolygon { vertices, normals } => Primitive::Polygon {
                vertices: vertices.iter().map(|v| v3(*v)).collect(),
                normals: Some(normals.iter().map(|n| v3(*n)).collect()),
            },
            Shape::Quadric(q) => Primitive::Quadric {
                coeffs: q.q,
                clip: q
                    .clip
                    .iter()
                    .map(|h| Clip::Plane {
                        normal: v3(h.normal),
                        offset: h.offset,
                    })
                    .collect(),
            },
        };
        if wrap.is_empty() {
            items.push(sp(BodyItem::Primitive(prim)));
        } else {
            wrap.push(sp(BodyItem::Primitive(prim)));
            items.push(sp(BodyItem::Block(Block {
                items: wrap,
                span: Span::default(),
            })));
        }
    }
    Scene {
        view,
        body: Block {
            items,
            span: Span::default(),
        },
    }
}

/// Every field of a surface, so the attribute reproduces it whatever came before.
fn surface_fields(s: &Surface) -> Vec<Spanned<AttrField>> {
    let mut f = vec![
        sp(AttrField::Color(sp(ColorSpec::Rgb(v3(s.color))))),
        sp(AttrField::Kdr(s.kdr)),
        sp(AttrField::Kdt(s.kdt)),
        sp(AttrField::Ka(s.ka)),
        sp(AttrField::Phong(s.phong)),
        sp(AttrField::Refract(s.refract)),
        sp(AttrField::Gloss(s.gloss)),
        sp(AttrField::Translucency(s.translucency)),
        sp(AttrField::Transmissivity(s.transmissivity)),
    ];
    if let Some(t) = &s.texture {
        f.push(sp(AttrField::Texture {
            id: t.kind as u32 as f64,
            color: v3(t.color),
            scale: v3(t.scale),
        }));
        f.push(sp(AttrField::TextureSpace(affine_to_rows(
            &t.world_to_texture,
        ))));
    }
    f
}
