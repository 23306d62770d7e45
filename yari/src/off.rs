//! OFF (Object File Format) to YARI: the thesis's `off2gfx`.
//!
//! The format read is the common ASCII OFF of Geomview, with its optional prefixes:
//!
//! ```text
//! [ST][C][N]OFF            header: N = a normal per vertex, C = a colour per vertex,
//!                          ST = texture coordinates per vertex (`4` and `n` are refused)
//! nv nf ne                 counts (may follow the header on the same line; ne is ignored)
//! x y z [nx ny nz] [r g b [a]] [s t]     nv vertex lines
//! n i1 i2 ... in [r g b [a]]             nf face lines: zero-based indices, optional colour
//! ```
//!
//! `#` starts a comment to the end of the line. Face colours are either 0-1 floats or, when
//! any component is above 1, 0-255 integers; alpha is ignored. Each polygon gets the default
//! YARI attribute (white, diffuse) unless its face has a colour, which becomes
//! `attribute(color = ...)` (repeated only when the colour changes). Vertex colours and
//! texture coordinates are read and checked but not used. With `N`, each face becomes a
//! `polygon` with `normals = ...` (its vertices' normals), or a flat one, with a warning, when
//! one of them has no direction. OFF has no view, so a camera is placed to frame the
//! object's bounding sphere (looking from +x+y+z, half angle 22.5 degrees), with a white
//! light at the camera, a black background and 512x512 pixels.
//!
//! The text is read once, as a stream ([`read_each`]): each face becomes world-block items
//! as soon as it is read, and the preamble, which frames every face, comes at the end.
//!
//! # Layout
//! - this file: the entry point and the scene built around the faces.
//! - `read`: the header, vertex and face lines, with located errors.

mod read;

use crate::ast::{
    AttrField, BodyItem, CameraDef, ColorSpec, LightDef, Primitive, Scene, Spanned, Vec3, ViewStmt,
};
use crate::diag::Diagnostics;
use crate::lines::TextLines;
use crate::span::{Source, Span};
use read::{read_off, Face};
use std::io::BufRead;

/// Reads an OFF file into a YARI syntax tree (warnings are dropped; see
/// [`parse_with_warnings`]).
pub fn parse(src: &Source) -> Result<Scene, Diagnostics> {
    parse_with_warnings(src).map(|(scene, _)| scene)
}

/// Reads an OFF file into a YARI syntax tree, returning the warnings with it (text after
/// the faces, `NOFF` faces shaded flat for a zero normal).
pub fn parse_with_warnings(src: &Source) -> Result<(Scene, Diagnostics), Diagnostics> {
    let mut scene = Scene::default();
    let mut lines = TextLines::new(src.text.as_bytes());
    let (view, warnings) = read_each(&mut lines, &mut |item| scene.body.items.push(item))?;
    scene.view = view;
    Ok((scene, warnings))
}

/// Reads OFF text from `lines` to its end, handing the world-block items of each face to
/// `each` as soon as it is read (none after the first error): the preamble and the
/// warnings, or every diagnostic when there is an error. A text that stops early (an I/O
/// error, not UTF-8) ends as if it ended there, and `lines` keeps why.
pub fn read_each<R: BufRead>(
    lines: &mut TextLines<R>,
    each: &mut dyn FnMut(Spanned<BodyItem>),
) -> Result<(Vec<Spanned<ViewStmt>>, Diagnostics), Diagnostics> {
    let mut diags = Diagnostics::default();
    let mut current: Option<Vec3> = None;
    let read = read_off(lines, &mut diags, &mut |f: Face| {
        let color = f.color.unwrap_or([1.0; 3]);
        if current != Some(color) {
            let field = AttrField::Color(Spanned::new(ColorSpec::Rgb(color), f.span));
            each(Spanned::new(
                BodyItem::Attribute(vec![Spanned::new(field, f.span)]),
                f.span,
            ));
            current = Some(color);
        }
        let polygon = Primitive::Polygon {
            vertices: f.vertices,
            normals: f.normals,
        };
        each(Spanned::new(BodyItem::Primitive(polygon), f.span));
    });
    lines.drain();
    let vertices = match read {
        Ok(v) => v,
        Err(d) => {
            diags.push(d);
            return Err(diags);
        }
    };
    if diags.has_errors() {
        return Err(diags);
    }
    Ok((view(vertices.framed()), diags))
}

/// The preamble framing `points`: a camera looking from +x+y+z at their bounding sphere, a
/// white light at the camera, a black background, 512x512 pixels.
fn view<'p>(points: impl Iterator<Item = &'p Vec3> + Clone) -> Vec<Spanned<ViewStmt>> {
    let (center, radius) = bounding_sphere(points);
    let distance = radius / 22.5f64.to_radians().sin() * 1.05;
    let dir = 1.0 / 3.0f64.sqrt();
    let eye = center.map(|c| c + distance * dir);
    let white = |s| Spanned::new(ColorSpec::Rgb([1.0; 3]), s);
    let at = Span::default();
    vec![
        Spanned::new(ViewStmt::Resolution(512, 512), at),
        Spanned::new(
            ViewStmt::Background(Spanned::new(ColorSpec::Rgb([0.0; 3]), at)),
            at,
        ),
        Spanned::new(
            ViewStmt::Light(LightDef {
                position: eye,
                color: white(at),
                radius: None,
            }),
            at,
        ),
        Spanned::new(
            ViewStmt::Camera(CameraDef {
                position: eye,
                at: center,
                up: [0.0, 0.0, 1.0],
                angle: 22.5,
                aperture: None,
                focus: None,
            }),
            at,
        ),
    ]
}

/// Centre of the bounding box and the radius that encloses every point (1 when empty).
fn bounding_sphere<'p>(points: impl Iterator<Item = &'p Vec3> + Clone) -> (Vec3, f64) {
    if points.clone().next().is_none() {
        return ([0.0; 3], 1.0);
    }
    let mut min = [f64::INFINITY; 3];
    let mut max = [f64::NEG_INFINITY; 3];
    for p in points.clone() {
        for i in 0..3 {
            min[i] = min[i].min(p[i]);
            max[i] = max[i].max(p[i]);
        }
    }
    let center: Vec3 = std::array::from_fn(|i| (min[i] + max[i]) / 2.0);
    let r = points
        .map(|p| {
            ((p[0] - center[0]).powi(2) + (p[1] - center[1]).powi(2) + (p[2] - center[2]).powi(2))
                .sqrt()
        })
        .fold(0.0, f64::max);
    (center, if r > 0.0 { r } else { 1.0 })
}

#[cfg(test)]
mod tests;
