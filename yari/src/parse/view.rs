//! Preamble statements: `resolution`, `background`, `ambient`, `light`, `camera`, `samples`,
//! `target_error`.

use super::{PResult, Parser};
use crate::ast::{CameraDef, LightDef, Spanned, ViewStmt};
use crate::lexer::TokenKind;
use crate::span::Span;

/// The largest width or height accepted by `resolution`.
pub const MAX_RESOLUTION: u32 = 65_536;
/// The largest `samples(n)` accepted.
pub const MAX_SAMPLES: u32 = 65_536;

impl Parser<'_> {
    /// One preamble statement; the current token is its (known) command name.
    pub(super) fn view_statement(&mut self) -> Option<Spanned<ViewStmt>> {
        let word = self.text(self.tok);
        let (stmt, span) = match word {
            "resolution" => self.statement(|p, _| {
                let (x, _) = p.count("the width", MAX_RESOLUTION)?;
                p.eat(TokenKind::Comma);
                let (y, _) = p.count("the height", MAX_RESOLUTION)?;
                Ok(ViewStmt::Resolution(x, y))
            })?,
            "samples" => self.statement(|p, _| {
                Ok(ViewStmt::Samples(
                    p.count("the number of samples", MAX_SAMPLES)?.0,
                ))
            })?,
            "target_error" => {
                self.statement(|p, _| Ok(ViewStmt::TargetError(p.number("the target error")?.0)))?
            }
            "background" => {
                self.statement(|p, name| Ok(ViewStmt::Background(p.colour_only(name)?)))?
            }
            "ambient" => self.statement(|p, name| Ok(ViewStmt::Ambient(p.colour_only(name)?)))?,
            "light" => self.statement(|p, name| p.light(name))?,
            "camera" => self.statement(|p, name| p.camera(name))?,
            _ => unreachable_command(self)?,
        };
        Some(Spanned::new(stmt, span))
    }

    /// `color = C`, the only field of `background` and `ambient`.
    fn colour_only(&mut self, stmt: Span) -> PResult<Spanned<crate::ast::ColorSpec>> {
        let mut color = None;
        self.fields(|p, name, span| match name {
            "color" | "colour" => {
                let c = p.colour()?;
                p.set(&mut color, c, name, span)
            }
            _ => Err(p.error(span, format!("unknown field `{name}`; expected `color`"))),
        })?;
        self.require(color, "color", stmt)
    }

    fn light(&mut self, stmt: Span) -> PResult<ViewStmt> {
        let (mut position, mut color, mut radius) = (None, None, None);
        self.fields(|p, name, span| match name {
            "position" => {
                let v = p.vector()?;
                p.set(&mut position, v, name, span)
            }
            "color" | "colour" => {
                let c = p.colour()?;
                p.set(&mut color, c, name, span)
            }
            "radius" => {
                let (r, rs) = p.number("the light's radius")?;
                if r < 0.0 {
                    return Err(p.error(
                        rs,
                        format!("a light's radius must not be negative, not {r}"),
                    ));
                }
                p.set(&mut radius, r, name, span)
            }
            _ => Err(p.error(
                span,
                format!(
                    "unknown field `{name}` in `light`; expected `position`, `color` or `radius`"
                ),
            )),
        })?;
        let position = self.require(position, "position", stmt)?;
        let color = self.require(color, "color", stmt)?;
        Ok(ViewStmt::Light(LightDef {
            position,
            color,
            radius,
        }))
    }

    fn camera(&mut self, stmt: Span) -> PResult<ViewStmt> {
        let (mut position, mut at, mut up, mut angle, mut aperture, mut focus) =
            (None, None, None, None, None, None);
        self.fields(|p, name, span| match name {
            "position" => {
                let v = p.vector()?;
                p.set(&mut position, v, name, span)
            }
            "at" => {
                let v = p.vector()?;
                p.set(&mut at, v, name, span)
            }
            "up" => {
                let v = p.vector()?;
                p.set(&mut up, v, name, span)
            }
            "angle" => {
                let v = p.number("the half angle of view in degrees")?.0;
                p.set(&mut angle, v, name, span)
            }
            "aperture" => {
                let v = p.number("the lens radius")?.0;
                p.set(&mut aperture, v, name, span)
            }
            "focus" => {
                let v = p.number("the focus distance")?.0;
                p.set(&mut focus, v, name, span)
            }
            _ => Err(p.error(
                span,
                format!(
                    "unknown field `{name}` in `camera`; expected `position`, `at`, `up`, `angle`, `aperture` or `focus`"
                ),
            )),
        })?;
        let position = self.require(position, "position", stmt)?;
        let at = self.require(at, "at", stmt)?;
        let up = self.require(up, "up", stmt)?;
        let angle = self.require(angle, "angle", stmt)?;
        Ok(ViewStmt::Camera(CameraDef {
            position,
            at,
            up,
            angle,
            aperture,
            focus,
        }))
    }
}

/// Only known preamble commands reach `view_statement`; anything else is skipped quietly.
fn unreachable_command(p: &mut Parser<'_>) -> Option<(ViewStmt, Span)> {
    p.bump();
    p.recover(0);
    None
}
