//! OFF (Object File Format) to YARI: the thesis's `off2gfx`.
//!
//! The format read is the common ASCII OFF:
//!
//! ```text
//! OFF                      header (optional `C`/`N` prefixes are not supported)
//! nv nf ne                 counts (may follow `OFF` on the same line; ne is ignored)
//! x y z                    nv vertex lines
//! n i1 i2 ... in [r g b [a]]   nf face lines: n zero-based vertex indices, optional colour
//! ```
//!
//! `#` starts a comment to the end of the line. Face colours are either 0-1 floats or, when
//! any component is above 1, 0-255 integers; alpha is ignored. Each polygon gets the default
//! YARI attribute (white, diffuse) unless its face has a colour, which becomes
//! `attribute(color = ...)` (repeated only when the colour changes). OFF has no view, so a
//! camera is placed to frame the object's bounding sphere (looking from +x+y+z, half angle
//! 22.5 degrees), with a white light at the camera, a black background and 512x512 pixels.

use crate::ast::{
    AttrField, BodyItem, CameraDef, ColorSpec, LightDef, Primitive, Scene, Spanned, Vec3, ViewStmt,
};
use crate::diag::{Diagnostic, Diagnostics};
use crate::span::{Source, Span};

/// Largest vertex or face count accepted (a guard against absurd headers).
const MAX_COUNT: u64 = 50_000_000;
/// The reader stops after this many errors.
const MAX_ERRORS: usize = 50;

/// Reads an OFF file into a YARI syntax tree.
pub fn parse(src: &Source) -> Result<Scene, Diagnostics> {
    let mut lines = Lines::new(&src.text);
    let mut diags = Diagnostics::default();
    let (vertices, faces) = match read_header_and_body(&mut lines, &mut diags) {
        Ok(body) => body,
        Err(d) => {
            diags.push(d);
            return Err(diags);
        }
    };
    if diags.has_errors() {
        return Err(diags);
    }
    Ok(build_scene(&vertices, &faces))
}

/// One face: vertex positions already looked up, optional colour, the line's span.
struct Face {
    vertices: Vec<Vec3>,
    color: Option<Vec3>,
    span: Span,
}

fn read_header_and_body(
    lines: &mut Lines<'_>,
    diags: &mut Diagnostics,
) -> Result<(Vec<Vec3>, Vec<Face>), Diagnostic> {
    let mut header = lines
        .next_line()
        .ok_or_else(|| lines.eof("the `OFF` header"))?;
    match header.first() {
        Some(t) if t.text == "OFF" => {
            header.remove(0);
        }
        Some(t) => {
            return Err(Diagnostic::error(
                t.span,
                format!("expected the `OFF` header, found `{}`", t.text),
            ))
        }
        None => return Err(lines.eof("the `OFF` header")),
    }
    let counts = if header.is_empty() {
        lines
            .next_line()
            .ok_or_else(|| lines.eof("the counts `nv nf ne`"))?
    } else {
        header
    };
    if counts.len() < 2 || counts.len() > 3 {
        let span = counts[0].span.to(counts[counts.len() - 1].span);
        return Err(Diagnostic::error(
            span,
            "expected the counts line `nv nf ne`",
        ));
    }
    let nv = count(&counts[0], "the vertex count")?;
    let nf = count(&counts[1], "the face count")?;
    if let Some(ne) = counts.get(2) {
        count(ne, "the edge count")?;
    }

    let mut vertices = Vec::with_capacity(nv.min(1 << 20) as usize);
    for i in 0..nv {
        let what = format!("vertex {i} of {nv}");
        let line = lines.next_line().ok_or_else(|| lines.eof(&what))?;
        if line.len() != 3 {
            let span = line[0].span.to(line[line.len() - 1].span);
            return Err(Diagnostic::error(
                span,
                format!("{what} must have 3 coordinates, found {}", line.len()),
            ));
        }
        let mut v = [0.0; 3];
        for (k, t) in line.iter().enumerate() {
            v[k] = number(t, &what)?;
        }
        vertices.push(v);
    }

    let mut faces = Vec::with_capacity(nf.min(1 << 20) as usize);
    for f in 0..nf {
        let what = format!("face {f} of {nf}");
        let line = lines.next_line().ok_or_else(|| lines.eof(&what))?;
        match face(&line, &vertices, &what) {
            Ok(face) => faces.push(face),
            Err(d) => {
                diags.push(d);
                if diags.errors().count() >= MAX_ERRORS {
                    return Err(Diagnostic::error(
                        line[0].span,
                        "too many errors; giving up",
                    ));
                }
            }
        }
    }
    if let Some(extra) = lines.next_line() {
        diags.push(Diagnostic::warning(
            extra[0].span,
            format!("text after the {nf} faces is ignored"),
        ));
    }
    Ok((vertices, faces))
}

fn face(line: &[Token<'_>], vertices: &[Vec3], what: &str) -> Result<Face, Diagnostic> {
    let span = line[0].span.to(line[line.len() - 1].span);
    let n = count(&line[0], &format!("the vertex count of {what}"))? as usize;
    if n < 3 {
        return Err(Diagnostic::error(
            line[0].span,
            format!("{what} has {n} vertices; a polygon needs at least 3"),
        ));
    }
    let rest = &line[1..];
    if rest.len() < n {
        return Err(Diagnostic::error(
            span,
            format!("{what} lists {} vertex indices, expected {n}", rest.len()),
        ));
    }
    let mut points = Vec::with_capacity(n);
    for t in &rest[..n] {
        let i = count(t, "a vertex index")?;
        let v = vertices.get(i as usize).ok_or_else(|| {
            Diagnostic::error(
                t.span,
                format!(
                    "vertex index {i} is out of range (the file has {} vertices)",
                    vertices.len()
                ),
            )
        })?;
        points.push(*v);
    }
    let extra = &rest[n..];
    let color = match extra.len() {
        0 => None,
        3 | 4 => {
            let mut c = [0.0; 3];
            for (k, t) in extra[..3].iter().enumerate() {
                c[k] = number(t, "a colour component")?;
                if c[k] < 0.0 {
                    return Err(Diagnostic::error(
                        t.span,
                        "colour components must not be negative",
                    ));
                }
            }
            if c.iter().any(|&x| x > 1.0) {
                c = c.map(|x| x / 255.0);
            }
            Some(c)
        }
        k => {
            let span = extra[0].span.to(extra[k - 1].span);
            return Err(Diagnostic::error(span, format!("{what}: expected a colour (3 or 4 numbers) after the indices, found {k} numbers")));
        }
    };
    Ok(Face {
        vertices: points,
        color,
        span,
    })
}

fn count(t: &Token<'_>, what: &str) -> Result<u64, Diagnostic> {
    match t.text.parse::<u64>() {
        Ok(n) if n <= MAX_COUNT => Ok(n),
        Ok(n) => Err(Diagnostic::error(
            t.span,
            format!("{what} {n} is larger than {MAX_COUNT}"),
        )),
        Err(_) => Err(Diagnostic::error(
            t.span,
            format!("expected {what} (a whole number), found `{}`", t.text),
        )),
    }
}

fn number(t: &Token<'_>, what: &str) -> Result<f64, Diagnostic> {
    match t.text.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(Diagnostic::error(
            t.span,
            format!("expected a number in {what}, found `{}`", t.text),
        )),
    }
}

fn build_scene(vertices: &[Vec3], faces: &[Face]) -> Scene {
    let mut scene = Scene::default();
    let used: Vec<Vec3> = faces
        .iter()
        .flat_map(|f| f.vertices.iter().copied())
        .collect();
    let (center, radius) = bounding_sphere(if used.is_empty() { vertices } else { &used });
    let distance = radius / 22.5f64.to_radians().sin() * 1.05;
    let dir = 1.0 / 3.0f64.sqrt();
    let eye = center.map(|c| c + distance * dir);
    let white = |s| Spanned::new(ColorSpec::Rgb([1.0; 3]), s);
    let at = Span::default();
    scene.view = vec![
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
    ];
    let mut current: Option<Vec3> = None;
    for f in faces {
        let color = f.color.unwrap_or([1.0; 3]);
        if current != Some(color) {
            let field = AttrField::Color(Spanned::new(ColorSpec::Rgb(color), f.span));
            scene.body.items.push(Spanned::new(
                BodyItem::Attribute(vec![Spanned::new(field, f.span)]),
                f.span,
            ));
            current = Some(color);
        }
        let polygon = Primitive::Polygon {
            vertices: f.vertices.clone(),
        };
        scene
            .body
            .items
            .push(Spanned::new(BodyItem::Primitive(polygon), f.span));
    }
    scene
}

/// Centre of the bounding box and the radius that encloses every point (1 when empty).
fn bounding_sphere(points: &[Vec3]) -> (Vec3, f64) {
    if points.is_empty() {
        return ([0.0; 3], 1.0);
    }
    let mut min = [f64::INFINITY; 3];
    let mut max = [f64::NEG_INFINITY; 3];
    for p in points {
        for i in 0..3 {
            min[i] = min[i].min(p[i]);
            max[i] = max[i].max(p[i]);
        }
    }
    let center: Vec3 = std::array::from_fn(|i| (min[i] + max[i]) / 2.0);
    let r = points
        .iter()
        .map(|p| {
            ((p[0] - center[0]).powi(2) + (p[1] - center[1]).powi(2) + (p[2] - center[2]).powi(2))
                .sqrt()
        })
        .fold(0.0, f64::max);
    (center, if r > 0.0 { r } else { 1.0 })
}

#[derive(Clone, Copy)]
struct Token<'a> {
    text: &'a str,
    span: Span,
}

/// Non-empty lines of tokens, comments removed.
struct Lines<'a> {
    text: &'a str,
    offset: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        Lines { text, offset: 0 }
    }

    fn eof(&self, what: &str) -> Diagnostic {
        let end = self.text.len();
        Diagnostic::error(
            Span::new(end, end),
            format!("unexpected end of file: expected {what}"),
        )
    }

    fn next_line(&mut self) -> Option<Vec<Token<'a>>> {
        while self.offset < self.text.len() {
            let start = self.offset;
            let end = self.text[start..]
                .find('\n')
                .map(|i| start + i)
                .unwrap_or(self.text.len());
            self.offset = end + 1;
            let line = &self.text[start..end];
            let line = line.split('#').next().unwrap_or("");
            let mut tokens = Vec::new();
            let mut pos = 0;
            for piece in line.split(|c: char| c.is_ascii_whitespace()) {
                if !piece.is_empty() {
                    let s = start + pos;
                    tokens.push(Token {
                        text: piece,
                        span: Span::new(s, s + piece.len()),
                    });
                }
                pos += piece.len() + 1;
            }
            if !tokens.is_empty() {
                return Some(tokens);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests;
