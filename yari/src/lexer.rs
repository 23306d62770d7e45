//! The YARI lexer: a hand-written scanner over the bytes of a source text.
//!
//! Tokens are identifiers, numbers, and the punctuation `( ) ; , =`. Blanks and `/* ... */`
//! comments separate tokens. A token is a small `Copy` value (kind, span, numeric value); the
//! text of an identifier is a slice of the source, so scanning allocates nothing.
//!
//! Numbers are `[+-]? digits? (. digits?)? ([eE] [+-]? digits)?` with at least one digit
//! before the exponent: `1`, `-1`, `.5176`, `-.816497`, `5.`, `1e-3`. A number that overflows
//! to infinity is an error, and so is a number glued to letters (`3x`).

use crate::diag::Diagnostic;
use crate::span::Span;

/// What a token is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TokenKind {
    /// A name: a letter or `_`, then letters, digits and `_` (commands, fields, colours).
    Ident,
    /// A number; its value is in [`Token::value`].
    Number,
    /// `(`
    LParen,
    /// `)`
    RParen,
    /// `;`
    Semi,
    /// `,`
    Comma,
    /// `=`
    Equals,
    /// End of input.
    Eof,
    /// A lexical error, already reported in [`Lexer::take_errors`].
    Error,
}

impl TokenKind {
    /// How the kind is named in messages.
    pub fn describe(self) -> &'static str {
        match self {
            TokenKind::Ident => "a name",
            TokenKind::Number => "a number",
            TokenKind::LParen => "`(`",
            TokenKind::RParen => "`)`",
            TokenKind::Semi => "`;`",
            TokenKind::Comma => "`,`",
            TokenKind::Equals => "`=`",
            TokenKind::Eof => "end of file",
            TokenKind::Error => "an invalid token",
        }
    }
}

/// One token: its kind, where it is, and for numbers its value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Token {
    /// What it is.
    pub kind: TokenKind,
    /// Its bytes in the source (empty at end of input).
    pub span: Span,
    /// The value of a [`TokenKind::Number`]; 0 otherwise.
    pub value: f64,
}

/// Scans tokens one at a time from a source text.
pub struct Lexer<'a> {
    text: &'a str,
    bytes: &'a [u8],
    pos: usize,
    errors: Vec<Diagnostic>,
}

impl<'a> Lexer<'a> {
    /// A lexer at the start of `text` (after a byte-order mark, if any).
    pub fn new(text: &'a str) -> Lexer<'a> {
        // A leading byte-order mark (from some Windows editors) is skipped.
        let pos = if text.starts_with('\u{feff}') { 3 } else { 0 };
        Lexer {
            text,
            bytes: text.as_bytes(),
            pos,
            errors: Vec::new(),
        }
    }

    /// The source text of a span (used for identifiers).
    pub fn slice(&self, span: Span) -> &'a str {
        &self.text[span.start as usize..span.end as usize]
    }

    /// True when lexical errors are waiting in [`Lexer::take_errors`].
    pub fn has_errors(&self) -> bool {
        !self.errors.is_empty()
    }

    /// Lexical errors found so far, removed from the lexer.
    pub fn take_errors(&mut self) -> Vec<Diagnostic> {
        std::mem::take(&mut self.errors)
    }

    fn token(&self, kind: TokenKind, start: usize) -> Token {
        Token {
            kind,
            span: Span::new(start, self.pos),
            value: 0.0,
        }
    }

    fn error(&mut self, start: usize, message: String) -> Token {
        self.errors
            .push(Diagnostic::error(Span::new(start, self.pos), message));
        self.token(TokenKind::Error, start)
    }

    /// Skips blanks and comments; reports an unterminated comment.
    fn skip_trivia(&mut self) {
        let b = self.bytes;
        loop {
            while self.pos < b.len() && b[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            if self.pos + 1 < b.len() && b[self.pos] == b'/' && b[self.pos + 1] == b'*' {
                let start = self.pos;
                match find_comment_end(&b[self.pos + 2..]) {
                    Some(len) => self.pos += 2 + len + 2,
                    None => {
                        self.pos = b.len();
                        self.errors.push(Diagnostic::error(
                            Span::new(start, start + 2),
                            "unterminated comment: `/*` has no closing `*/`",
                        ));
                    }
                }
            } else {
                return;
            }
        }
    }

    /// The next token; [`TokenKind::Eof`] forever at the end.
    pub fn next_token(&mut self) -> Token {
        self.skip_trivia();
        let b = self.bytes;
        let start = self.pos;
        let Some(&c) = b.get(start) else {
            return self.token(TokenKind::Eof, start);
        };
        let single = match c {
            b'(' => Some(TokenKind::LParen),
            b')' => Some(TokenKind::RParen),
            b';' => Some(TokenKind::Semi),
            b',' => Some(TokenKind::Comma),
            b'=' => Some(TokenKind::Equals),
            _ => None,
        };
        if let Some(kind) = single {
            self.pos += 1;
            return self.token(kind, start);
        }
        if c.is_ascii_alphabetic() || c == b'_' {
            self.pos += 1;
            while self.pos < b.len() && is_ident_byte(b[self.pos]) {
                self.pos += 1;
            }
            return self.token(TokenKind::Ident, start);
        }
        if c.is_ascii_digit() || c == b'.' || c == b'-' || c == b'+' {
            return self.number(start);
        }
        // One whole (possibly multi-byte) character.
        let ch = self.text[start..].chars().next().unwrap_or('?');
        self.pos += ch.len_utf8();
        if c == b'/' && b.get(start + 1) != Some(&b'*') {
            return self.error(
                start,
                "unexpected `/`: comments are written `/* ... */`".into(),
            );
        }
        if c == b'*' && b.get(start + 1) == Some(&b'/') {
            self.pos += 1;
            return self.error(start, "`*/` without an opening `/*`".into());
        }
        self.error(
            start,
            format!("unexpected character `{}`", ch.escape_debug()),
        )
    }

    fn number(&mut self, start: usize) -> Token {
        let b = self.bytes;
        let mut p = start;
        let negative = b[p] == b'-';
        if b[p] == b'-' || b[p] == b'+' {
            p += 1;
        }
        // The digits are gathered as an integer for the exact fast path below.
        let mut mantissa: u64 = 0;
        let mut exact = true;
        let int_start = p;
        while p < b.len() && b[p].is_ascii_digit() {
            push_digit(&mut mantissa, &mut exact, b[p]);
            p += 1;
        }
        let mut digits = p - int_start;
        let mut frac_digits = 0usize;
        if p < b.len() && b[p] == b'.' {
            p += 1;
            let frac_start = p;
            while p < b.len() && b[p].is_ascii_digit() {
                push_digit(&mut mantissa, &mut exact, b[p]);
                p += 1;
            }
            frac_digits = p - frac_start;
            digits += frac_digits;
        }
        if digits == 0 {
            self.pos = p.max(start + 1);
            let what = &self.text[start..self.pos];
            return self.error(start, format!("`{what}` is not a number"));
        }
        let (exponent, p) = match self.exponent(start, p, &mut exact) {
            Ok(e) => e,
            Err(error) => return error,
        };
        self.pos = p;
        if p < b.len() && (is_ident_byte(b[p]) || b[p] == b'.') {
            while self.pos < b.len() && (is_ident_byte(b[self.pos]) || b[self.pos] == b'.') {
                self.pos += 1;
            }
            let what = &self.text[start..self.pos];
            return self.error(start, format!("malformed number `{what}`"));
        }
        // Clinger's fast path: an integer below 2^53 times or over an exact power of ten
        // (10^22 at most) is one correctly rounded operation. Anything else goes to the
        // standard library's parser.
        let scale = exponent - frac_digits as i64;
        if exact && mantissa < (1 << 53) && (-22..=22).contains(&scale) {
            let m = mantissa as f64;
            let v = if scale >= 0 {
                m * POWERS_OF_TEN[scale as usize]
            } else {
                m / POWERS_OF_TEN[(-scale) as usize]
            };
            return Token {
                kind: TokenKind::Number,
                span: Span::new(start, p),
                value: if negative { -v } else { v },
            };
        }
        let text = &self.text[start..p];
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Token {
                kind: TokenKind::Number,
                span: Span::new(start, p),
                value: v,
            },
            Ok(_) => self.error(
                start,
                format!("number `{text}` is out of range (overflows to infinity)"),
            ),
            Err(_) => self.error(start, format!("malformed number `{text}`")),
        }
    }

    /// The exponent of the number at `start` whose digits end at `p` (`e` or `E`, a sign,
    /// digits), if it has one: its value (of six digits at most; more make the number
    /// inexact for the fast path) and where the number ends; or the error for an exponent
    /// without digits.
    fn exponent(
        &mut self,
        start: usize,
        p: usize,
        exact: &mut bool,
    ) -> Result<(i64, usize), Token> {
        let b = self.bytes;
        let mut exponent: i64 = 0;
        if !(p < b.len() && (b[p] == b'e' || b[p] == b'E')) {
            return Ok((exponent, p));
        }
        let mut q = p + 1;
        let exp_negative = q < b.len() && b[q] == b'-';
        if q < b.len() && (b[q] == b'-' || b[q] == b'+') {
            q += 1;
        }
        let exp_start = q;
        while q < b.len() && b[q].is_ascii_digit() {
            if q - exp_start < 6 {
                exponent = exponent * 10 + i64::from(b[q] - b'0');
            } else {
                *exact = false;
            }
            q += 1;
        }
        if q == exp_start {
            self.pos = q;
            while self.pos < b.len() && is_ident_byte(b[self.pos]) {
                self.pos += 1;
            }
            let what = &self.text[start..self.pos];
            return Err(self.error(
                start,
                format!("malformed number `{what}`: exponent has no digits"),
            ));
        }
        if exp_negative {
            exponent = -exponent;
        }
        Ok((exponent, q))
    }
}

/// 10^0 ..= 10^22, each exact in an f64.
const POWERS_OF_TEN: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Appends a decimal digit to the mantissa; past 18 digits the fast path is abandoned.
fn push_digit(mantissa: &mut u64, exact: &mut bool, digit: u8) {
    if *mantissa < 100_000_000_000_000_000 {
        *mantissa = *mantissa * 10 + u64::from(digit - b'0');
    } else {
        *exact = false;
    }
}

fn is_ident_byte(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// Length of a comment's body up to (not including) the first `*/`.
fn find_comment_end(b: &[u8]) -> Option<usize> {
    let mut i = 0;
    while i + 1 < b.len() {
        if b[i] == b'*' {
            if b[i + 1] == b'/' {
                return Some(i);
            }
            i += 1;
        } else {
            i += 1;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lex(text: &str) -> (Vec<(TokenKind, f64)>, Vec<String>) {
        let mut l = Lexer::new(text);
        let mut out = Vec::new();
        loop {
            let t = l.next_token();
            if t.kind == TokenKind::Eof {
                break;
            }
            out.push((t.kind, t.value));
        }
        (
            out,
            l.take_errors().into_iter().map(|d| d.message).collect(),
        )
    }

    #[test]
    fn numbers_in_every_written_form() {
        let (toks, errs) = lex(".5176 -.816497 1e-3 +2 5. -1 0,0,-32 1E+2");
        assert!(errs.is_empty(), "{errs:?}");
        let values: Vec<f64> = toks
            .iter()
            .filter(|t| t.0 == TokenKind::Number)
            .map(|t| t.1)
            .collect();
        assert_eq!(
            values,
            vec![0.5176, -0.816497, 1e-3, 2.0, 5.0, -1.0, 0.0, 0.0, -32.0, 100.0]
        );
    }

    #[test]
    fn fast_path_agrees_with_the_standard_parser() {
        let mut x: u64 = 12345;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for i in 0..200_000 {
            let bits = next();
            let v = f64::from_bits(bits);
            let scaled = (bits % 2_000_000) as f64 / 997.0 - 1000.0;
            let text = match i % 6 {
                0 if v.is_finite() => format!("{v}"),
                1 if v.is_finite() => format!("{v:e}"),
                2 => format!("{scaled:.3}"),
                3 => format!("{scaled}"),
                4 => format!("{}e{}", bits % 100_000, (bits >> 20) % 60).replace("e5", "e-5"),
                _ => format!("{:.7}", scaled / 1e5).replacen("0.", ".", 1),
            };
            let mut l = Lexer::new(&text);
            let t = l.next_token();
            let expected: f64 = text.parse().unwrap();
            if expected.is_finite() {
                assert_eq!(t.kind, TokenKind::Number, "{text}");
                assert_eq!(t.value.to_bits(), expected.to_bits(), "{text}");
            }
        }
    }

    #[test]
    fn punctuation_identifiers_and_comments() {
        let (toks, errs) = lex("camera( /* a * comment */ at = UNC_Blue ;)");
        assert!(errs.is_empty());
        let kinds: Vec<TokenKind> = toks.iter().map(|t| t.0).collect();
        use TokenKind::*;
        assert_eq!(
            kinds,
            vec![Ident, LParen, Ident, Equals, Ident, Semi, RParen]
        );
    }

    #[test]
    fn byte_order_mark_and_crlf_are_blanks() {
        let (toks, errs) = lex("\u{feff}begin\r\nend\r\n");
        assert!(errs.is_empty(), "{errs:?}");
        assert_eq!(toks.len(), 2);
    }

    #[test]
    fn errors_are_reported_not_panicked() {
        for bad in [
            "1e999", "-", "1e", "3x", "@", "/* open", "é", "*/", "/", "1..2", ".",
        ] {
            let (_, errs) = lex(bad);
            assert_eq!(errs.len(), 1, "{bad}: {errs:?}");
        }
        assert!(lex("1e999").1[0].contains("out of range"));
        assert!(lex("/* open").1[0].contains("unterminated comment"));
    }
}
