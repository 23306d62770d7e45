//! Attributes to surfaces, and the table that stores each distinct surface once.
//!
//! `attribute(...)` starts from [`Surface::default`] (diffuse, solid, white) and sets the
//! fields it names. A texture (`texture = id r,g,b sx,sy,sz`; id 0 = none, ids from
//! [`TextureKind::from_id`]) maps world space to texture space with the inverse of the
//! transformation in effect where each primitive is defined, so the texture moves with the
//! object; `texture_space = m00 ... m23` gives that map explicitly instead.

use super::stack::{rows_to_affine, State};
use super::Compiler;
use crate::ast::AttrField;
use crate::ast::Spanned;
use crate::model::{Surface, Texture, TextureKind};
use crate::span::Span;
use glam::{DAffine3, DVec3};
use std::collections::HashMap;

/// Distinct surfaces seen so far, keyed by the bits of every field.
#[derive(Default)]
pub(crate) struct Dedup {
    index: HashMap<Vec<u64>, u32>,
}

fn key(s: &Surface) -> Vec<u64> {
    let mut k: Vec<u64> = [
        s.color.x, s.color.y, s.color.z, s.kdr, s.kdt, s.ka, s.phong, s.refract,
    ]
    .iter()
    .chain([s.gloss, s.translucency, s.transmissivity].iter())
    .map(|v| v.to_bits())
    .collect();
    if let Some(t) = &s.texture {
        k.push(t.kind as u64);
        k.extend(
            t.color
                .to_array()
                .iter()
                .chain(t.scale.to_array().iter())
                .map(|v| v.to_bits()),
        );
        k.extend(
            crate::writer::affine_to_rows(&t.world_to_texture)
                .iter()
                .map(|v| v.to_bits()),
        );
    }
    k
}

impl State {
    /// `attribute(...)`: a whole new current surface.
    pub(crate) fn set_attribute(
        &mut self,
        c: &mut Compiler<'_>,
        fields: &[Spanned<AttrField>],
        span: Span,
    ) {
        let mut s = Surface::default();
        let mut texture_space = None;
        let mut space_span = span;
        for f in fields {
            let fs = f.span;
            match &f.node {
                AttrField::Color(spec) => s.color = c.colour(spec),
                AttrField::Kdr(v) => s.kdr = unit(c, *v, "kdr", fs),
                AttrField::Kdt(v) => s.kdt = unit(c, *v, "kdt", fs),
                AttrField::Ka(v) => s.ka = nonneg(c, *v, "ka", fs),
                AttrField::Phong(v) => s.phong = nonneg(c, *v, "phong", fs),
                AttrField::Refract(v) => s.refract = nonneg(c, *v, "refract", fs),
                AttrField::Gloss(v) => s.gloss = angle(c, *v, "gloss", fs),
                AttrField::Translucency(v) => s.translucency = angle(c, *v, "translucency", fs),
                AttrField::Transmissivity(v) => {
                    s.transmissivity = unit(c, *v, "transmissivity", fs)
                }
                AttrField::Texture { id, color, scale } => {
                    s.texture = texture(c, *id, *color, *scale, fs)
                }
                AttrField::TextureSpace(m) => {
                    let a = rows_to_affine(m);
                    if !a.is_finite() || a.matrix3.determinant() == 0.0 {
                        c.error(fs, "texture_space matrix is singular");
                    }
                    texture_space = Some(a);
                    space_span = fs;
                }
            }
        }
        if s.gloss > 0.0 && s.ksr() == 0.0 {
            c.warn(
                span,
                "`gloss` has no effect on a surface that does not reflect (kdr = 1)",
            );
        }
        if s.translucency > 0.0 && s.kst() == 0.0 {
            c.warn(
                span,
                "`translucency` has no effect on a surface that does not transmit (kdt = 1)",
            );
        }
        if s.transmissivity != 1.0 && s.kst() == 0.0 {
            c.warn(
                span,
                "`transmissivity` has no effect on a surface that does not transmit (kdt = 1)",
            );
        }
        if s.kst() > 0.0 && s.refract <= 0.0 {
            c.error(
                span,
                format!(
                    "a transparent surface (kdt < 1) needs `refract` > 0, not {}",
                    s.refract
                ),
            );
        }
        if texture_space.is_some() && s.texture.is_none() {
            c.warn(
                space_span,
                "`texture_space` without a texture has no effect",
            );
        }
        self.surface = s;
        self.texture_space = texture_space;
        self.cached_surface = None;
    }

    /// The index in `surfaces` of the current surface as used by a primitive here.
    pub(crate) fn surface_index(
        &mut self,
        c: &mut Compiler<'_>,
        surfaces: &mut Vec<Surface>,
        span: Span,
    ) -> u32 {
        if let Some(i) = self.cached_surface {
            return i;
        }
        let mut s = self.surface.clone();
        if let Some(t) = &mut s.texture {
            t.world_to_texture = match (self.texture_space, self.inverse()) {
                (Some(explicit), _) => explicit,
                (None, Some(inv)) => inv,
                (None, None) => {
                    c.error(
                        span,
                        "the current transformation cannot be inverted to place the texture",
                    );
                    DAffine3::IDENTITY
                }
            };
        }
        let k = key(&s);
        let i = *c.surfaces.index.entry(k).or_insert_with(|| {
            surfaces.push(s);
            (surfaces.len() - 1) as u32
        });
        self.cached_surface = Some(i);
        i
    }
}

fn unit(c: &mut Compiler<'_>, v: f64, name: &str, span: Span) -> f64 {
    if !v.is_finite() {
        c.error(span, format!("`{name}` is not a finite number"));
    } else if !(0.0..=1.0).contains(&v) {
        c.warn(span, format!("`{name} = {v}` is outside 0..1"));
    }
    v
}

fn nonneg(c: &mut Compiler<'_>, v: f64, name: &str, span: Span) -> f64 {
    if !v.is_finite() {
        c.error(span, format!("`{name}` is not a finite number"));
    } else if v < 0.0 {
        c.warn(span, format!("`{name} = {v}` is negative"));
    }
    v
}

fn angle(c: &mut Compiler<'_>, v: f64, name: &str, span: Span) -> f64 {
    if !(0.0..90.0).contains(&v) {
        c.error(
            span,
            format!("`{name}` is a spread angle in degrees and must be in 0..90, not {v}"),
        );
    }
    v
}

fn texture(
    c: &mut Compiler<'_>,
    id: f64,
    color: [f64; 3],
    scale: [f64; 3],
    span: Span,
) -> Option<Texture> {
    if id == 0.0 {
        return None;
    }
    let kind = if id.fract() == 0.0 && (1.0..=u32::MAX as f64).contains(&id) {
        TextureKind::from_id(id as u32)
    } else {
        None
    };
    let Some(kind) = kind else {
        c.warn(span, format!("unknown texture id {id} is ignored (known: 1 wood, 2 marble, 3 bumps, 4 turbulence, 5 checker)"));
        return None;
    };
    if scale.contains(&0.0) {
        c.error(span, "texture scale factors must not be zero");
    }
    if !color.iter().chain(scale.iter()).all(|v| v.is_finite()) {
        c.error(span, "texture colour and scale must be finite numbers");
    }
    Some(Texture {
        kind,
        color: DVec3::from_array(color),
        scale: DVec3::from_array(scale),
        world_to_texture: DAffine3::IDENTITY,
    })
}
