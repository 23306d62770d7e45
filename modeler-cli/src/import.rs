//! YARI to project: opens any YARI file as a project, parsed by [`yari::parse::parse`].
//!
//! Names: the parser drops comments, so a block's name is read from the source text: a
//! `/* name */` comment directly before its `begin` (only blanks between), if it holds one
//! valid name (see [`crate::error::check_name`]); a light's name likewise before `light`.
//! Other blocks get `object1`, `object2`, ... at the top level and `PARENT.1`, ... inside.
//!
//! Structure: every block becomes an object. The result is brought into the tree's shape
//! (transformations only on parts, see [`crate::tree`]) without changing what renders:
//! - a block's leading `attribute`/transformations are its header; a block holding only
//!   primitives after its header is a part with those transformations;
//! - otherwise it is a group, the header transformations move down into every child (in
//!   front of the child's own, which is where YARI applies them), runs of primitives become
//!   parts of their own, and a transformation or `attribute` in mid-block applies to the
//!   parts and blocks after it, exactly as YARI's graphics stack does.

use crate::error::{check_name, ModelError};
use crate::project::{
    Camera, Clip, Color, Light, Object, Primitive, Project, SceneSettings, Surface, Texture,
    Transform, FORMAT_VERSION,
};
use std::collections::HashSet;
use yari::ast::{self, AttrField, Block, BodyItem, ColorSpec, ViewStmt};
use yari::span::Source;

/// Reads YARI text as a project. Parse errors come back rendered with file, line and caret.
pub fn from_yari(src: &Source) -> Result<Project, ModelError> {
    let scene = yari::parse::parse(src).map_err(|d| ModelError::Yari(d.render(src)))?;
    Ok(from_scene(&scene, &src.text))
}

/// A parsed scene as a project, with names read from `text` (the text it was parsed from).
pub fn from_scene(scene: &ast::Scene, text: &str) -> Project {
    let mut settings = SceneSettings::default();
    let mut light_names = Names::default();
    for stmt in &scene.view {
        if let ViewStmt::Light(_) = stmt.node {
            if let Some(n) = comment_name(text, stmt.span.start as usize) {
                light_names.reserve(n);
            }
        }
    }
    for stmt in &scene.view {
        match &stmt.node {
            ViewStmt::Resolution(w, h) => settings.resolution = Some([*w, *h]),
            ViewStmt::Samples(n) => settings.samples = Some(*n),
            ViewStmt::TargetError(e) => settings.target_error = Some(*e),
            ViewStmt::Background(c) => settings.background = Some(color(&c.node)),
            ViewStmt::Ambient(c) => settings.ambient = Some(color(&c.node)),
            ViewStmt::Light(l) => {
                let name =
                    light_names.pick(comment_name(text, stmt.span.start as usize), "light", "");
                settings.lights.push(Light {
                    name,
                    position: l.position,
                    color: color(&l.color.node),
                    radius: l.radius,
                });
            }
            ViewStmt::Camera(c) => {
                settings.camera = Some(Camera {
                    position: c.position,
                    at: c.at,
                    up: c.up,
                    angle: c.angle,
                    aperture: c.aperture,
                    focus: c.focus,
                })
            }
        }
    }
    let mut names = Names::default();
    reserve_block_names(&scene.body, text, &mut names);
    let mut conv = Converter { text, names };
    let objects = conv.contents(&scene.body.items, Vec::new(), None, None);
    Project {
        version: FORMAT_VERSION,
        settings,
        skeletons: Vec::new(),
        objects,
    }
}

/// The name in a `/* name */` comment that ends right before byte `offset`, if any.
pub fn comment_name(text: &str, offset: usize) -> Option<String> {
    let before = text.get(..offset)?.trim_end();
    let body = before.strip_suffix("*/")?;
    let start = body.rfind("/*")?;
    let name = body[start + 2..].trim();
    check_name(name).ok().map(|_| name.to_string())
}

/// Names in use; comment names are reserved first so generated ones never take them.
#[derive(Default)]
struct Names {
    reserved: HashSet<String>,
    used: HashSet<String>,
}

impl Names {
    fn reserve(&mut self, name: String) {
        self.reserved.insert(name);
    }
    /// The wanted name if still free, else one generated as `base`, `sep` and a number.
    fn pick(&mut self, wanted: Option<String>, base: &str, sep: &str) -> String {
        if let Some(w) = wanted {
            if self.used.insert(w.clone()) {
                return w;
            }
            return self.generate(&w, ".");
        }
        self.generate(base, sep)
    }
    fn generate(&mut self, base: &str, sep: &str) -> String {
        for i in 1.. {
            let n = format!("{base}{sep}{i}");
            if !self.reserved.contains(&n) && self.used.insert(n.clone()) {
                return n;
            }
        }
        unreachable!("an unbounded range always yields a free name")
    }
}

fn reserve_block_names(block: &Block, text: &str, names: &mut Names) {
    for item in &block.items {
        if let BodyItem::Block(inner) = &item.node {
            if let Some(n) = comment_name(text, inner.span.start as usize) {
                names.reserve(n);
            }
            reserve_block_names(inner, text, names);
        }
    }
}

struct Converter<'a> {
    text: &'a str,
    names: Names,
}

impl Converter<'_> {
    /// One block as an object; `pre` are the enclosing transformations pushed down.
    fn block(&mut self, block: &Block, pre: Vec<Transform>, name: String) -> Object {
        let items = &block.items;
        let mut surface = None;
        let mut transforms = pre;
        let mut i = 0;
        while let Some(item) = items.get(i) {
            match &item.node {
                BodyItem::Attribute(fields) => surface = Some(self::surface(fields)),
                BodyItem::Transform(t) => transforms.push(transform(t)),
                _ => break,
            }
            i += 1;
        }
        let rest = &items[i..];
        if rest.iter().all(|it| primitive(&it.node).is_some()) {
            let primitives = rest.iter().filter_map(|it| primitive(&it.node)).collect();
            return Object {
                name,
                surface,
                transforms,
                primitives,
                children: Vec::new(),
            };
        }
        let children = self.contents(rest, transforms, None, Some(&name));
        Object {
            name,
            surface,
            transforms: Vec::new(),
            primitives: Vec::new(),
            children,
        }
    }

    /// The items of a block after its header, as a list of objects.
    fn contents(
        &mut self,
        items: &[ast::Spanned<BodyItem>],
        mut cur: Vec<Transform>,
        mut attr: Option<Surface>,
        parent: Option<&str>,
    ) -> Vec<Object> {
        let mut out = Vec::new();
        let mut run: Vec<Primitive> = Vec::new();
        // Generated names: `part1`, `object1` at the top level, `PARENT.1` inside a group.
        let base = |kind: &'static str| match parent {
            Some(p) => (p.to_string(), "."),
            None => (kind.to_string(), ""),
        };
        for item in items {
            let prim = primitive(&item.node);
            if prim.is_none() && !run.is_empty() {
                let (b, sep) = base("part");
                let name = self.names.pick(None, &b, sep);
                out.push(Object {
                    name,
                    surface: attr.clone(),
                    transforms: cur.clone(),
                    primitives: std::mem::take(&mut run),
                    children: Vec::new(),
                });
            }
            if let Some(p) = prim {
                run.push(p);
                continue;
            }
            match &item.node {
                BodyItem::Primitive(_) | BodyItem::Mesh(_) => {}
                BodyItem::Transform(t) => cur.push(transform(t)),
                BodyItem::Attribute(fields) => attr = Some(surface(fields)),
                BodyItem::Block(inner) => {
                    let wanted = comment_name(self.text, inner.span.start as usize);
                    let (b, sep) = base("object");
                    let name = self.names.pick(wanted, &b, sep);
                    let mut obj = self.block(inner, cur.clone(), name);
                    if obj.surface.is_none() {
                        obj.surface = attr.clone();
                    }
                    out.push(obj);
                }
            }
        }
        if !run.is_empty() {
            let (b, sep) = base("part");
            let name = self.names.pick(None, &b, sep);
            out.push(Object {
                name,
                surface: attr,
                transforms: cur,
                primitives: run,
                children: Vec::new(),
            });
        }
        out
    }
}

pub fn color(c: &ColorSpec) -> Color {
    match c {
        ColorSpec::Named(n) => Color::Named(n.clone()),
        ColorSpec::Rgb(v) => Color::Rgb(*v),
    }
}

fn surface(fields: &[ast::Spanned<AttrField>]) -> Surface {
    let mut s = Surface::default();
    for f in fields {
        match &f.node {
            AttrField::Color(c) => s.color = Some(color(&c.node)),
            AttrField::Kdr(v) => s.kdr = Some(*v),
            AttrField::Kdt(v) => s.kdt = Some(*v),
            AttrField::Ka(v) => s.ka = Some(*v),
            AttrField::Phong(v) => s.phong = Some(*v),
            AttrField::Refract(v) => s.refract = Some(*v),
            AttrField::Texture { id, color, scale } => {
                s.texture = Some(Texture {
                    id: *id,
                    color: *color,
                    scale: *scale,
                })
            }
            AttrField::Gloss(v) => s.gloss = Some(*v),
            AttrField::Translucency(v) => s.translucency = Some(*v),
            AttrField::Transmissivity(v) => s.transmissivity = Some(*v),
            AttrField::TextureSpace(m) => s.texture_space = Some(*m),
        }
    }
    s
}

fn transform(t: &ast::Transform) -> Transform {
    match t {
        ast::Transform::Translate(v) => Transform::Translate(*v),
        ast::Transform::Scale(v) => Transform::Scale(*v),
        ast::Transform::Rotate(v) => Transform::Rotate(*v),
        ast::Transform::Motion(v) => Transform::Motion(*v),
        ast::Transform::Matrix(m) => Transform::Matrix(*m),
    }
}

/// The primitive a statement draws (a mesh statement's file is one), if it draws one.
fn primitive(item: &BodyItem) -> Option<Primitive> {
    let p = match item {
        BodyItem::Primitive(p) => p,
        BodyItem::Mesh(m) => {
            return Some(Primitive::Mesh {
                file: m.file.node.clone(),
                materials_file: m.materials == ast::MeshMaterials::File,
            })
        }
        _ => return None,
    };
    Some(match p {
        ast::Primitive::Sphere { center, radius } => Primitive::Sphere {
            center: *center,
            radius: *radius,
        },
        ast::Primitive::Polygon { vertices, normals } => Primitive::Polygon {
            vertices: vertices.clone(),
            normals: normals.clone(),
        },
        ast::Primitive::Quadric { coeffs, clip } => Primitive::Quadric {
            coeffs: *coeffs,
            clip: clip
                .iter()
                .map(|c| match c {
                    ast::Clip::Box { min, max } => Clip::Box {
                        min: *min,
                        max: *max,
                    },
                    ast::Clip::Plane { normal, offset } => Clip::Plane {
                        normal: *normal,
                        offset: *offset,
                    },
                })
                .collect(),
        },
    })
}

#[cfg(test)]
mod tests;
