//! Values inside statements: numbers, vectors, counts, colours, and `name = value` lists.

use super::{PResult, Parser};
use crate::ast;
use crate::ast::Spanned;
use crate::lexer::TokenKind;
use crate::span::Span;

impl<'a> Parser<'a> {
    pub(crate) fn number(&mut self, what: &str) -> PResult<(f64, Span)> {
        let t = self.expect(TokenKind::Number, what)?;
        Ok((t.value, t.span))
    }

    /// `x, y, z` or `x y z`.
    pub(crate) fn vector(&mut self) -> PResult<ast::Vec3> {
        let (x, _) = self.number("a number (x)")?;
        self.eat(TokenKind::Comma);
        let (y, _) = self.number("a number (y)")?;
        self.eat(TokenKind::Comma);
        let (z, _) = self.number("a number (z)")?;
        Ok([x, y, z])
    }

    /// `n` numbers separated by commas or blanks.
    pub(crate) fn numbers<const N: usize>(&mut self, what: &str) -> PResult<[f64; N]> {
        let mut out = [0.0; N];
        for (i, v) in out.iter_mut().enumerate() {
            if i > 0 {
                self.eat(TokenKind::Comma);
            }
            if !self.at(TokenKind::Number) {
                return Err(self.unexpected(&format!("{what} (value {} of {N})", i + 1)));
            }
            *v = self.bump().value;
        }
        Ok(out)
    }

    /// A whole number in `1..=max`.
    pub(crate) fn count(&mut self, what: &str, max: u32) -> PResult<(u32, Span)> {
        let (v, span) = self.number(what)?;
        if v.fract() != 0.0 || v < 1.0 || v > max as f64 {
            return Err(self.error(
                span,
                format!("{what} must be a whole number from 1 to {max}, not {v}"),
            ));
        }
        Ok((v as u32, span))
    }

    /// `name` or `r, g, b`.
    pub(crate) fn colour(&mut self) -> PResult<Spanned<ast::ColorSpec>> {
        if self.at(TokenKind::Ident) {
            let t = self.bump();
            return Ok(Spanned::new(
                ast::ColorSpec::Named(self.text(t).to_string()),
                t.span,
            ));
        }
        let start = self.tok.span;
        if !self.at(TokenKind::Number) {
            return Err(self.unexpected("a colour (a name or r,g,b)"));
        }
        let v = self.vector()?;
        Ok(Spanned::new(ast::ColorSpec::Rgb(v), self.span_from(start)))
    }

    /// A `name = value ; name = value ...` list up to (not including) `)`. `field` parses
    /// the value of each name and reports unknown names.
    pub(crate) fn fields(
        &mut self,
        mut field: impl FnMut(&mut Self, &str, Span) -> PResult<()>,
    ) -> PResult<()> {
        while !self.at(TokenKind::RParen) {
            if self.at(TokenKind::Ident) && super::COMMANDS.contains(&self.text(self.tok)) {
                // A command where a field should be: the `)` was forgotten.
                let at = Span::new(self.prev_end, self.prev_end);
                let msg = format!("expected `)`, found `{}`", self.text(self.tok));
                return Err(self.error(at, msg));
            }
            let name = self.expect(TokenKind::Ident, "a field name")?;
            self.expect(TokenKind::Equals, "`=`")?;
            // The name is copied out of the lexer's window, which the value's parse moves.
            let word = FieldName::of(self.text(name));
            field(self, word.as_str(), name.span)?;
            if !self.eat(TokenKind::Semi) && !self.at(TokenKind::RParen) {
                return Err(self.unexpected("`;` or `)`"));
            }
        }
        Ok(())
    }

    /// Stores a field's value, reporting a field given twice.
    pub(crate) fn set<T>(
        &mut self,
        slot: &mut Option<T>,
        value: T,
        name: &str,
        span: Span,
    ) -> PResult<()> {
        if slot.is_some() {
            return Err(self.error(span, format!("`{name}` is given twice")));
        }
        *slot = Some(value);
        Ok(())
    }

    /// A required field's value, or an error at the command name (`stmt`) naming the field.
    pub(crate) fn require<T>(&mut self, slot: Option<T>, name: &str, stmt: Span) -> PResult<T> {
        match slot {
            Some(v) => Ok(v),
            None => {
                let cmd = self.lex.slice(stmt);
                Err(self.error(stmt, format!("`{cmd}` is missing `{name} = ...`")))
            }
        }
    }
}

/// A field's name copied out of the source: on the stack when it is short, as every known
/// field's name is, so a field costs no allocation.
enum FieldName {
    Short([u8; 16], usize),
    Long(String),
}

impl FieldName {
    fn of(text: &str) -> FieldName {
        let mut bytes = [0u8; 16];
        match bytes.get_mut(..text.len()) {
            Some(head) => {
                head.copy_from_slice(text.as_bytes());
                FieldName::Short(bytes, text.len())
            }
            None => FieldName::Long(text.to_owned()),
        }
    }

    fn as_str(&self) -> &str {
        match self {
            // A copy of a whole `str`, so always UTF-8.
            FieldName::Short(bytes, len) => std::str::from_utf8(&bytes[..*len]).unwrap_or(""),
            FieldName::Long(s) => s,
        }
    }
}
