//! NFF reader: text to entities, with a spanned diagnostic for every malformed entity.
//!
//! The text is read once, as a stream ([`read_each`] hands each entity over as soon as it is
//! read); [`read()`] collects them into an [`NffScene`]. After an error the reader skips to
//! the next entity letter and goes on, so one run reports every broken entity (up to
//! [`MAX_ERRORS`]).

use super::scene::{Entity, Fill, NffScene, View};
use super::tokens::{Token, Tokens};
use crate::ast::{has_direction, Spanned, Vec3};
use crate::diag::{Diagnostic, Diagnostics};
use crate::lines::TextLines;
use crate::span::{Source, Span};
use std::fmt::Display;
use std::io::BufRead;

/// The reader stops after this many errors.
pub const MAX_ERRORS: usize = 50;
/// Largest vertex count accepted for one polygon.
const MAX_POLYGON_VERTICES: u64 = 1_000_000;
/// Largest image side accepted in `resolution`.
const MAX_RESOLUTION: u64 = 65_536;

const ENTITY_KEYWORDS: [&str; 8] = ["b", "v", "l", "f", "c", "s", "p", "pp"];

/// Reads NFF text into its entities. Warnings (values outside their usual range) are returned
/// with the scene; any error fails the read.
pub fn read(src: &Source) -> Result<(NffScene, Diagnostics), Diagnostics> {
    let mut scene = NffScene::default();
    let mut lines = TextLines::new(src.text.as_bytes());
    let warnings = read_each(&mut lines, &mut |e| scene.entities.push(e))?;
    Ok((scene, warnings))
}

/// Reads NFF text from `lines` to its end, handing each entity to `each` as soon as it is
/// read (none after the first error). The warnings, or every diagnostic when there is an
/// error; a text that stops early (an I/O error, not UTF-8) ends as if it ended there, and
/// `lines` keeps why.
pub fn read_each<R: BufRead>(
    lines: &mut TextLines<R>,
    each: &mut dyn FnMut(Spanned<Entity>),
) -> Result<Diagnostics, Diagnostics> {
    let mut reader = Reader {
        tokens: Tokens::new(lines),
        diags: Diagnostics::default(),
    };
    while let Some(tok) = reader.tokens.next() {
        match reader.entity(&tok) {
            Ok(entity) => {
                if !reader.diags.has_errors() {
                    let span = tok.span.to(reader.tokens.last_span());
                    each(Spanned::new(entity, span));
                }
            }
            Err(d) => {
                reader.diags.push(d);
                if reader.diags.errors().count() >= MAX_ERRORS {
                    let here = reader.tokens.last_span();
                    reader
                        .diags
                        .push(Diagnostic::error(here, "too many errors; giving up"));
                    break;
                }
                reader.skip_to_entity();
            }
        }
    }
    reader.tokens.drain();
    if reader.diags.has_errors() {
        Err(reader.diags)
    } else {
        Ok(reader.diags)
    }
}

struct Reader<'l, R> {
    tokens: Tokens<'l, R>,
    diags: Diagnostics,
}

type Parsed<T> = Result<T, Diagnostic>;

impl<R: BufRead> Reader<'_, R> {
    fn skip_to_entity(&mut self) {
        while let Some(t) = self.tokens.peek() {
            if ENTITY_KEYWORDS.contains(&t.text.as_str()) {
                return;
            }
            self.tokens.next();
        }
    }

    fn expect_token(&mut self, what: impl Display + Copy) -> Parsed<Token> {
        let end = self.tokens.end();
        self.tokens.next().ok_or_else(|| {
            Diagnostic::error(
                Span::new(end, end),
                format!("unexpected end of file: expected {what}"),
            )
        })
    }

    fn number(&mut self, what: impl Display + Copy) -> Parsed<(f64, Span)> {
        let t = self.expect_token(what)?;
        match t.text.as_str().parse::<f64>() {
            Ok(x) if x.is_finite() => Ok((x, t.span)),
            Ok(_) => Err(Diagnostic::error(
                t.span,
                format!("{what} must be a finite number"),
            )),
            Err(_) => {
                let error =
                    Diagnostic::error(t.span, format!("expected {what}, found `{}`", t.text));
                if ENTITY_KEYWORDS.contains(&t.text.as_str()) {
                    // Leave the next entity for the recovery to start from.
                    self.tokens.put_back(t);
                }
                Err(error)
            }
        }
    }

    fn num(&mut self, what: impl Display + Copy) -> Parsed<f64> {
        self.number(what).map(|(x, _)| x)
    }

    fn vec3(&mut self, what: impl Display + Copy) -> Parsed<Vec3> {
        Ok([
            self.num(format_args!("the x coordinate of {what}"))?,
            self.num(format_args!("the y coordinate of {what}"))?,
            self.num(format_args!("the z coordinate of {what}"))?,
        ])
    }

    fn color(&mut self, what: impl Display + Copy) -> Parsed<Vec3> {
        Ok([
            self.num(format_args!("the red component of {what}"))?,
            self.num(format_args!("the green component of {what}"))?,
            self.num(format_args!("the blue component of {what}"))?,
        ])
    }

    fn count(&mut self, what: impl Display + Copy, min: u64, max: u64) -> Parsed<(u64, Span)> {
        let t = self.expect_token(what)?;
        let n: u64 = t.text.as_str().parse().map_err(|_| {
            Diagnostic::error(
                t.span,
                format!("expected {what} (a whole number), found `{}`", t.text),
            )
        })?;
        if n < min || n > max {
            return Err(Diagnostic::error(
                t.span,
                format!("{what} must be between {min} and {max}, not {n}"),
            ));
        }
        Ok((n, t.span))
    }

    fn next_is_number(&mut self) -> bool {
        self.tokens
            .peek()
            .is_some_and(|t| t.text.as_str().parse::<f64>().is_ok())
    }

    fn warn(&mut self, span: Span, message: impl Into<String>) {
        self.diags.push(Diagnostic::warning(span, message));
    }

    fn entity(&mut self, tok: &Token) -> Parsed<Entity> {
        match tok.text.as_str() {
            "b" => Ok(Entity::Background(self.color("the background colour")?)),
            "v" => self.view(tok.span).map(Entity::View),
            "l" => {
                let position = self.vec3("the light position")?;
                let color = if self.next_is_number() {
                    Some(self.color("the light colour")?)
                } else {
                    None
                };
                Ok(Entity::Light { position, color })
            }
            "f" => self.fill().map(Entity::Fill),
            "s" => {
                let center = self.vec3("the sphere centre")?;
                let (radius, span) = self.number("the sphere radius")?;
                if radius <= 0.0 {
                    return Err(Diagnostic::error(
                        span,
                        format!("sphere radius must be positive, not {radius}"),
                    ));
                }
                Ok(Entity::Sphere { center, radius })
            }
            "p" | "pp" => self.polygon(tok.text.as_str() == "pp"),
            "c" => self.cone(tok.span),
            other => Err(Diagnostic::error(
                tok.span,
                format!("unknown NFF entity `{other}` (expected one of b, v, l, f, c, s, p, pp)"),
            )),
        }
    }

    fn view(&mut self, v_span: Span) -> Parsed<View> {
        let (mut from, mut at, mut up, mut angle, mut hither, mut resolution) =
            (None, None, None, None, None, None);
        while let Some(t) = self.tokens.peek() {
            let slot_taken = match t.text.as_str() {
                "from" | "at" | "up" | "angle" | "hither" | "resolution" => match t.text.as_str() {
                    "from" => from.is_some(),
                    "at" => at.is_some(),
                    "up" => up.is_some(),
                    "angle" => angle.is_some(),
                    "hither" => hither.is_some(),
                    _ => resolution.is_some(),
                },
                _ => break,
            };
            let Some(t) = self.tokens.next() else { break };
            if slot_taken {
                return Err(Diagnostic::error(
                    t.span,
                    format!("`{}` given twice in one view", t.text),
                ));
            }
            match t.text.as_str() {
                "from" => from = Some(self.vec3("`from`")?),
                "at" => at = Some(self.vec3("`at`")?),
                "up" => up = Some(self.vec3("`up`")?),
                "angle" => {
                    let (a, span) = self.number("the view angle in degrees")?;
                    if !(a > 0.0 && a < 180.0) {
                        return Err(Diagnostic::error(
                            span,
                            format!("view angle must be between 0 and 180 degrees, not {a}"),
                        ));
                    }
                    angle = Some(a);
                }
                "hither" => hither = Some(self.num("the hither distance")?),
                _ => {
                    let (x, _) = self.count("the horizontal resolution", 1, MAX_RESOLUTION)?;
                    let (y, _) = self.count("the vertical resolution", 1, MAX_RESOLUTION)?;
                    resolution = Some([x as u32, y as u32]);
                }
            }
        }
        let missing = |name: &str| Diagnostic::error(v_span, format!("view is missing `{name}`"));
        let view = View {
            from: from.ok_or_else(|| missing("from"))?,
            at: at.ok_or_else(|| missing("at"))?,
            up: up.ok_or_else(|| missing("up"))?,
            angle: angle.ok_or_else(|| missing("angle"))?,
            hither: hither.unwrap_or(0.0),
            resolution,
        };
        let dir = sub(view.at, view.from);
        if dot(dir, dir) == 0.0 {
            return Err(Diagnostic::error(
                v_span,
                "view `from` and `at` are the same point",
            ));
        }
        let c = cross(dir, view.up);
        if dot(c, c) <= 1e-24 * dot(dir, dir) * dot(view.up, view.up) {
            return Err(Diagnostic::error(
                v_span,
                "view `up` is zero or parallel to the line of sight",
            ));
        }
        Ok(view)
    }

    fn fill(&mut self) -> Parsed<Fill> {
        let color = self.color("the fill colour")?;
        let kd = self.number("Kd (diffuse)")?;
        let ks = self.number("Ks (specular)")?;
        let shine = self.num("Shine (the Phong exponent)")?;
        let t = self.number("T (transmittance)")?;
        let ior = self.num("the index of refraction")?;
        for ((value, span), name) in [(kd, "Kd"), (ks, "Ks"), (t, "T")] {
            if !(0.0..=1.0).contains(&value) {
                self.warn(
                    span,
                    format!("{name} = {value} is outside [0, 1]; the YARI mapping clamps it"),
                );
            }
        }
        Ok(Fill {
            color,
            kd: kd.0,
            ks: ks.0,
            shine,
            t: t.0,
            ior,
        })
    }

    fn polygon(&mut self, with_normals: bool) -> Parsed<Entity> {
        let (n, _) = self.count("the vertex count", 3, MAX_POLYGON_VERTICES)?;
        let mut vertices = Vec::with_capacity(n.min(1024) as usize);
        let mut normals = Vec::new();
        for i in 0..n {
            vertices.push(self.vec3(format_args!("vertex {}", i + 1))?);
            if with_normals {
                let first = self.tokens.peek().map(|t| t.span).unwrap_or_default();
                let normal = self.vec3(format_args!("the normal of vertex {}", i + 1))?;
                if !has_direction(&normal) && normals.iter().all(has_direction) {
                    let span = first.to(self.tokens.last_span());
                    let why = "has no direction (zero or out of range); this `pp` is shaded flat";
                    self.warn(span, format!("the normal of vertex {} {why}", i + 1));
                }
                normals.push(normal);
            }
        }
        Ok(Entity::Polygon {
            vertices,
            normals: with_normals.then_some(normals),
        })
    }

    fn cone(&mut self, c_span: Span) -> Parsed<Entity> {
        let base = self.vec3("the cone base")?;
        let (base_radius, base_span) = self.number("the base radius")?;
        let apex = self.vec3("the cone apex")?;
        let (apex_radius, apex_span) = self.number("the apex radius")?;
        for (r, span) in [(base_radius, base_span), (apex_radius, apex_span)] {
            if r < 0.0 {
                return Err(Diagnostic::error(
                    span,
                    format!("cone radius must not be negative, not {r}"),
                ));
            }
        }
        if base_radius == 0.0 && apex_radius == 0.0 {
            return Err(Diagnostic::error(
                c_span.to(apex_span),
                "cone has both radii zero",
            ));
        }
        let axis = sub(apex, base);
        if dot(axis, axis) == 0.0 {
            return Err(Diagnostic::error(
                c_span.to(apex_span),
                "cone base and apex are the same point",
            ));
        }
        Ok(Entity::Cone {
            base,
            base_radius,
            apex,
            apex_radius,
        })
    }
}

pub(crate) fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests;
