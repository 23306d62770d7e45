//! Body statements: `attribute`, `sphere`, `polygon`, `quadric`, `mesh`, and the
//! transformations `translate`, `scale`, `rotate`, `motion`, `transform`.

use super::{PResult, Parser};
use crate::ast::{
    AttrField, BodyItem, Clip, MeshMaterials, MeshStmt, Primitive, Spanned, Transform, Vec3,
};
use crate::lexer::TokenKind;
use crate::span::Span;

impl Parser<'_> {
    /// One body statement; the current token is a name other than `begin`/`end`.
    pub(super) fn body_statement(&mut self) -> Option<Spanned<BodyItem>> {
        let word = self.text(self.tok);
        let (item, span) = match word {
            "attribute" => self.statement(|p, _| Ok(BodyItem::Attribute(p.attribute_fields()?)))?,
            "sphere" => self.statement(|p, name| p.sphere(name))?,
            "polygon" => self.statement(|p, _| p.polygon())?,
            "quadric" => self.statement(|p, _| p.quadric())?,
            "mesh" => self.statement(|p, name| p.mesh(name))?,
            "translate" => {
                self.statement(|p, _| Ok(BodyItem::Transform(Transform::Translate(p.vector()?))))?
            }
            "scale" => {
                self.statement(|p, _| Ok(BodyItem::Transform(Transform::Scale(p.vector()?))))?
            }
            "rotate" => {
                self.statement(|p, _| Ok(BodyItem::Transform(Transform::Rotate(p.vector()?))))?
            }
            "motion" => {
                self.statement(|p, _| Ok(BodyItem::Transform(Transform::Motion(p.vector()?))))?
            }
            "transform" => self.statement(|p, _| {
                Ok(BodyItem::Transform(Transform::Matrix(
                    p.numbers::<12>("a matrix entry")?,
                )))
            })?,
            _ => {
                let at = self.tok.span;
                let msg = if super::VIEW_COMMANDS.contains(&word) {
                    format!("`{word}` belongs in the preamble, before the world block's `begin`")
                } else {
                    format!("unknown command `{word}`")
                };
                self.error(at, msg);
                self.bump();
                self.recover(0);
                return None;
            }
        };
        Some(Spanned::new(item, span))
    }

    fn attribute_fields(&mut self) -> PResult<Vec<Spanned<AttrField>>> {
        let mut out: Vec<Spanned<AttrField>> = Vec::new();
        self.fields(|p, name, span| {
            let field = match name {
                "color" | "colour" => AttrField::Color(p.colour()?),
                "kdr" => AttrField::Kdr(p.number("a value for `kdr`")?.0),
                "kdt" => AttrField::Kdt(p.number("a value for `kdt`")?.0),
                "ka" => AttrField::Ka(p.number("a value for `ka`")?.0),
                "phong" => AttrField::Phong(p.number("a value for `phong`")?.0),
                "refract" => AttrField::Refract(p.number("a value for `refract`")?.0),
                "gloss" => AttrField::Gloss(p.number("a value for `gloss`")?.0),
                "translucency" => AttrField::Translucency(p.number("a value for `translucency`")?.0),
                "transmissivity" => AttrField::Transmissivity(p.number("a value for `transmissivity`")?.0),
                "texture" => {
                    let v = p.numbers::<7>("`texture = id r,g,b sx,sy,sz`")?;
                    AttrField::Texture { id: v[0], color: [v[1], v[2], v[3]], scale: [v[4], v[5], v[6]] }
                }
                "texture_space" => AttrField::TextureSpace(p.numbers::<12>("a matrix entry")?),
                _ => {
                    return Err(p.error(
                        span,
                        format!(
                            "unknown attribute `{name}`; expected one of color, kdr, kdt, ka, phong, refract, \
                             texture, gloss, translucency, transmissivity, texture_space"
                        ),
                    ))
                }
            };
            if out.iter().any(|f| std::mem::discriminant(&f.node) == std::mem::discriminant(&field)) {
                return Err(p.error(span, format!("`{name}` is given twice")));
            }
            out.push(Spanned::new(field, p.span_from(span)));
            Ok(())
        })?;
        Ok(out)
    }

    fn sphere(&mut self, stmt: Span) -> PResult<BodyItem> {
        let (mut center, mut radius) = (None, None);
        self.fields(|p, name, span| match name {
            "center" | "centre" => {
                let v = p.vector()?;
                p.set(&mut center, v, name, span)
            }
            "radius" => {
                let v = p.number("the radius")?.0;
                p.set(&mut radius, v, name, span)
            }
            _ => Err(p.error(
                span,
                format!("unknown field `{name}` in `sphere`; expected `center` or `radius`"),
            )),
        })?;
        let center = self.require(center, "center", stmt)?;
        let radius = self.require(radius, "radius", stmt)?;
        Ok(BodyItem::Primitive(Primitive::Sphere { center, radius }))
    }

    /// `vertices = n ; x1,y1,z1 ... xn,yn,zn` (commas between numbers optional), then the
    /// optional `; normals = nx1,ny1,nz1 ... nxn,nyn,nzn` (extension: one per vertex).
    fn polygon(&mut self) -> PResult<BodyItem> {
        if !self.at_word("vertices") {
            return Err(self.unexpected("`vertices = n`"));
        }
        self.bump();
        self.expect(TokenKind::Equals, "`=`")?;
        let (n, n_span) = self.number("the number of vertices")?;
        if n.fract() != 0.0 || n < 0.0 {
            return Err(self.error(
                n_span,
                format!("the number of vertices must be a whole number, not {n}"),
            ));
        }
        self.expect(TokenKind::Semi, "`;` after the number of vertices")?;
        let (vertices, _) = self.vector_list((n as usize).min(64), "vertex")?;
        if vertices.len() as f64 != n {
            return Err(self.error(
                n_span,
                format!("polygon declares {n} vertices but lists {}", vertices.len()),
            ));
        }
        let vertices: Vec<Vec3> = vertices.into_iter().map(|(v, _)| v).collect();
        let mut normals = None;
        if self.eat(TokenKind::Semi) && !self.at(TokenKind::RParen) {
            if !self.at_word("normals") {
                return Err(if self.at(TokenKind::Ident) {
                    let (at, name) = (self.tok.span, self.text(self.tok));
                    self.error(
                        at,
                        format!("unknown field `{name}` in `polygon`; expected `normals`"),
                    )
                } else {
                    self.unexpected("`normals = ...` or `)`")
                });
            }
            let field = self.bump().span;
            self.expect(TokenKind::Equals, "`=`")?;
            normals = Some(self.normals(vertices.len(), field)?);
            if self.eat(TokenKind::Semi) && !self.at(TokenKind::RParen) {
                return Err(self.unexpected("`)` after the normals"));
            }
        }
        Ok(BodyItem::Primitive(Primitive::Polygon {
            vertices,
            normals,
        }))
    }

    /// The list after `normals =`: one non-zero vector per vertex (`count` of them).
    fn normals(&mut self, count: usize, field: Span) -> PResult<Vec<Vec3>> {
        let (normals, list) = self.vector_list(count.min(64), "normal")?;
        if normals.len() != count {
            let at = if list.start == list.end { field } else { list };
            return Err(self.error(
                at,
                format!(
                    "polygon has {count} vertices but {} normals; give one normal per vertex",
                    normals.len()
                ),
            ));
        }
        for (k, (v, span)) in normals.iter().enumerate() {
            let why = if v.iter().all(|c| *c == 0.0) {
                "is zero; a normal needs a direction"
            } else if !crate::ast::has_direction(v) {
                "cannot be normalised: its length is out of range"
            } else {
                continue;
            };
            return Err(self.error(*span, format!("the normal of vertex {} {why}", k + 1)));
        }
        Ok(normals.into_iter().map(|(v, _)| v).collect())
    }

    /// Numbers up to the next `;` or `)`, three by three: the vectors with their spans, and
    /// the span of the whole list (empty when there are no numbers). `what` names one item.
    fn vector_list(&mut self, capacity: usize, what: &str) -> PResult<(Vec<(Vec3, Span)>, Span)> {
        let list_start = self.tok.span;
        let mut out: Vec<(Vec3, Span)> = Vec::with_capacity(capacity);
        let mut partial = [0.0; 3];
        let mut first = list_start;
        let mut count = 0usize;
        while self.at(TokenKind::Number) {
            if count.is_multiple_of(3) {
                first = self.tok.span;
            }
            partial[count % 3] = self.bump().value;
            count += 1;
            if count.is_multiple_of(3) {
                out.push((partial, self.span_from(first)));
            }
            self.eat(TokenKind::Comma);
        }
        if !self.at(TokenKind::RParen) && !self.at(TokenKind::Semi) {
            return Err(self.unexpected("a number or `)`"));
        }
        let list = if count == 0 {
            Span::new(list_start.start as usize, list_start.start as usize)
        } else {
            self.span_from(list_start)
        };
        if !count.is_multiple_of(3) {
            return Err(self.error(
                list,
                format!("each {what} needs 3 coordinates, but {count} numbers are listed"),
            ));
        }
        Ok((out, list))
    }

    /// `a b c d e f g h i j` then optional `; clip = min max` and `; plane = a,b,c d` fields.
    fn quadric(&mut self) -> PResult<BodyItem> {
        let coeffs = self.numbers::<10>("a quadric coefficient")?;
        let mut clip = Vec::new();
        if self.eat(TokenKind::Semi) {
            self.fields(|p, name, span| match name {
                "clip" => {
                    let min = p.vector()?;
                    p.eat(TokenKind::Comma);
                    let max = p.vector()?;
                    if (0..3).any(|i| min[i] > max[i]) {
                        return Err(p.error(
                            p.span_from(span),
                            "clip box has a minimum corner above its maximum",
                        ));
                    }
                    clip.push(Clip::Box { min, max });
                    Ok(())
                }
                "plane" => {
                    let normal = p.vector()?;
                    p.eat(TokenKind::Comma);
                    let offset = p.number("the plane's offset d")?.0;
                    clip.push(Clip::Plane { normal, offset });
                    Ok(())
                }
                _ => Err(p.error(
                    span,
                    format!("unknown field `{name}` in `quadric`; expected `clip` or `plane`"),
                )),
            })?;
        }
        Ok(BodyItem::Primitive(Primitive::Quadric { coeffs, clip }))
    }

    /// `file = "name"` then the optional `; materials = file` (or `current`).
    fn mesh(&mut self, stmt: Span) -> PResult<BodyItem> {
        let (mut file, mut materials) = (None, None);
        self.fields(|p, name, span| match name {
            "file" => {
                let t = p.expect(TokenKind::String, "the file's name in quotes")?;
                let text = p.lex.string(t.span).to_string();
                if text.is_empty() {
                    return Err(p.error(t.span, "the mesh's file name is empty"));
                }
                p.set(&mut file, Spanned::new(text, t.span), name, span)
            }
            "materials" => {
                let t = p.expect(TokenKind::Ident, "`file` or `current`")?;
                let m = match p.text(t) {
                    "file" => MeshMaterials::File,
                    "current" => MeshMaterials::Current,
                    other => {
                        let msg = format!(
                            "unknown materials `{other}`; expected `file` (the mesh's own) or \
                             `current` (the current attribute)"
                        );
                        return Err(p.error(t.span, msg));
                    }
                };
                p.set(&mut materials, m, name, span)
            }
            _ => Err(p.error(
                span,
                format!("unknown field `{name}` in `mesh`; expected `file` or `materials`"),
            )),
        })?;
        let file = self.require(file, "file", stmt)?;
        Ok(BodyItem::Mesh(MeshStmt {
            file,
            materials: materials.unwrap_or_default(),
        }))
    }
}
