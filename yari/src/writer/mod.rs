//! The YARI writer: prints a syntax tree (or a compiled world) back as YARI text that the
//! parser reads to the same tree.
//!
//! Numbers are printed in Rust's shortest form that reads back to the same `f64` (`{}`, or
//! `{:e}` when that is much shorter), so `parse(write_scene(s))` equals `s` up to spans.
//!
//! # Layout
//! - this file: [`write_scene`] and [`erase_spans`].
//! - `world`: [`write_world`], a compiled [`crate::model::World`] as a flat YARI file.

mod world;

pub use world::{affine_to_rows, world_to_scene, write_world};

use crate::ast::{
    AttrField, Block, BodyItem, Clip, ColorSpec, MeshMaterials, MeshStmt, Primitive, Scene,
    Spanned, Transform, ViewStmt,
};
use crate::span::Span;
use std::fmt::{self, Display, Write};

/// Prints a scene as YARI text: the preamble, then the world block, two blanks per level.
pub fn write_scene(scene: &Scene) -> String {
    let mut out = String::new();
    for stmt in &scene.view {
        write_view(&mut out, &stmt.node);
    }
    write_block(&mut out, &scene.body, 0);
    out
}

/// A number in its shortest round-trip form.
pub struct Num(pub f64);

impl Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let plain = format!("{}", self.0);
        if plain.len() > 20 {
            let exp = format!("{:e}", self.0);
            if exp.len() < plain.len() {
                return f.write_str(&exp);
            }
        }
        f.write_str(&plain)
    }
}

struct V<'a>(&'a [f64; 3]);

impl Display for V<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{},{},{}",
            Num(self.0[0]),
            Num(self.0[1]),
            Num(self.0[2])
        )
    }
}

struct C<'a>(&'a ColorSpec);

impl Display for C<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            ColorSpec::Rgb(v) => V(v).fmt(f),
            ColorSpec::Named(n) => f.write_str(n),
        }
    }
}

fn list(out: &mut String, values: &[f64]) {
    for (i, v) in values.iter().enumerate() {
        if i > 0 {
            out.push(' ');
        }
        let _ = write!(out, "{}", Num(*v));
    }
}

fn write_view(out: &mut String, stmt: &ViewStmt) {
    let _ = match stmt {
        ViewStmt::Resolution(x, y) => writeln!(out, "resolution({x}, {y});"),
        ViewStmt::Samples(n) => writeln!(out, "samples({n});"),
        ViewStmt::TargetError(e) => writeln!(out, "target_error({});", Num(*e)),
        ViewStmt::Background(c) => writeln!(out, "background(color = {});", C(&c.node)),
        ViewStmt::Ambient(c) => writeln!(out, "ambient(color = {});", C(&c.node)),
        ViewStmt::Light(l) => {
            let _ = write!(
                out,
                "light(position = {}; color = {}",
                V(&l.position),
                C(&l.color.node)
            );
            if let Some(r) = l.radius {
                let _ = write!(out, "; radius = {}", Num(r));
            }
            writeln!(out, ");")
        }
        ViewStmt::Camera(c) => {
            let _ = write!(
                out,
                "camera(position = {}; at = {}; up = {}; angle = {}",
                V(&c.position),
                V(&c.at),
                V(&c.up),
                Num(c.angle)
            );
            if let Some(a) = c.aperture {
                let _ = write!(out, "; aperture = {}", Num(a));
            }
            if let Some(d) = c.focus {
                let _ = write!(out, "; focus = {}", Num(d));
            }
            writeln!(out, ");")
        }
    };
}

fn indent(out: &mut String, depth: usize) {
    for _ in 0..depth {
        out.push_str("  ");
    }
}

fn write_block(out: &mut String, block: &Block, depth: usize) {
    indent(out, depth);
    out.push_str("begin\n");
    for item in &block.items {
        if let BodyItem::Block(inner) = &item.node {
            write_block(out, inner, depth + 1);
            continue;
        }
        indent(out, depth + 1);
        match &item.node {
            BodyItem::Attribute(fields) => write_attribute(out, fields),
            BodyItem::Primitive(p) => write_primitive(out, p),
            BodyItem::Transform(t) => write_transform(out, t),
            BodyItem::Mesh(m) => write_mesh(out, m),
            BodyItem::Block(_) => {}
        }
        out.push_str(";\n");
    }
    indent(out, depth);
    out.push_str("end\n");
}

/// `mesh(file = "NAME")`, with `; materials = file` when the file's own are asked for. A
/// name is written as it was read (the lexer takes no escapes, and none has a `"`).
fn write_mesh(out: &mut String, m: &MeshStmt) {
    let _ = write!(out, "mesh(file = \"{}\"", m.file.node);
    if m.materials == MeshMaterials::File {
        out.push_str("; materials = file");
    }
    out.push(')');
}

fn write_attribute(out: &mut String, fields: &[Spanned<AttrField>]) {
    out.push_str("attribute(");
    for (i, f) in fields.iter().enumerate() {
        if i > 0 {
            out.push_str("; ");
        }
        let _ = match &f.node {
            AttrField::Color(c) => write!(out, "color = {}", C(&c.node)),
            AttrField::Kdr(v) => write!(out, "kdr = {}", Num(*v)),
            AttrField::Kdt(v) => write!(out, "kdt = {}", Num(*v)),
            AttrField::Ka(v) => write!(out, "ka = {}", Num(*v)),
            AttrField::Phong(v) => write!(out, "phong = {}", Num(*v)),
            AttrField::Refract(v) => write!(out, "refract = {}", Num(*v)),
            AttrField::Gloss(v) => write!(out, "gloss = {}", Num(*v)),
            AttrField::Translucency(v) => write!(out, "translucency = {}", Num(*v)),
            AttrField::Transmissivity(v) => write!(out, "transmissivity = {}", Num(*v)),
            AttrField::Texture { id, color, scale } => {
                write!(out, "texture = {} {} {}", Num(*id), V(color), V(scale))
            }
            AttrField::TextureSpace(m) => {
                out.push_str("texture_space = ");
                list(out, m);
                Ok(())
            }
        };
    }
    out.push(')');
}

fn write_primitive(out: &mut String, p: &Primitive) {
    match p {
        Primitive::Sphere { center, radius } => {
            let _ = write!(
                out,
                "sphere(center = {}; radius = {})",
                V(center),
                Num(*radius)
            );
        }
        Primitive::Polygon { vertices, normals } => {
            let _ = write!(out, "polygon(vertices = {};", vertices.len());
            for v in vertices {
                let _ = write!(out, "  {}", V(v));
            }
            if let Some(normals) = normals {
                out.push_str("; normals =");
                for n in normals {
                    let _ = write!(out, "  {}", V(n));
                }
            }
            out.push(')');
        }
        Primitive::Quadric { coeffs, clip } => {
            out.push_str("quadric(");
            list(out, coeffs);
            for c in clip {
                let _ = match c {
                    Clip::Box { min, max } => write!(out, "; clip = {} {}", V(min), V(max)),
                    Clip::Plane { normal, offset } => {
                        write!(out, "; plane = {} {}", V(normal), Num(*offset))
                    }
                };
            }
            out.push(')');
        }
    }
}

fn write_transform(out: &mut String, t: &Transform) {
    let _ = match t {
        Transform::Translate(v) => write!(out, "translate({})", V(v)),
        Transform::Scale(v) => write!(out, "scale({})", V(v)),
        Transform::Rotate(v) => write!(out, "rotate({})", V(v)),
        Transform::Motion(v) => write!(out, "motion({})", V(v)),
        Transform::Matrix(m) => {
            out.push_str("transform(");
            list(out, m);
            out.push(')');
            Ok(())
        }
    };
}

/// Sets every span in the scene to the empty span at 0, so that trees parsed from different
/// texts compare by content alone.
pub fn erase_spans(scene: &mut Scene) {
    for stmt in &mut scene.view {
        stmt.span = Span::default();
        match &mut stmt.node {
            ViewStmt::Background(c) | ViewStmt::Ambient(c) => c.span = Span::default(),
            ViewStmt::Light(l) => l.color.span = Span::default(),
            _ => {}
        }
    }
    erase_block(&mut scene.body);
}

fn erase_block(block: &mut Block) {
    block.span = Span::default();
    for item in &mut block.items {
        item.span = Span::default();
        match &mut item.node {
            BodyItem::Block(inner) => erase_block(inner),
            BodyItem::Mesh(m) => m.file.span = Span::default(),
            BodyItem::Attribute(fields) => {
                for f in fields {
                    f.span = Span::default();
                    if let AttrField::Color(c) = &mut f.node {
                        c.span = Span::default();
                    }
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests;
