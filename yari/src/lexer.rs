//! The YARI lexer: a hand-written scanner over the bytes of a source text.
//!
//! Tokens are identifiers, numbers, quoted strings (file names, one line each), and the
//! punctuation `( ) ; , =`. Blanks and `/* ... */`
//! comments separate tokens. A token is a small `Copy` value (kind, span, numeric value); the
//! text of an identifier is read back from the lexer's window ([`Lexer::slice`]), so scanning
//! allocates nothing.
//!
//! The text is either whole ([`Lexer::new`]) or read line by line as the scan needs it
//! ([`Lexer::streaming`]): then the lexer holds a window of the text, from the point its
//! reader still needs ([`Lexer::keep_from`]) to a little past the current token, and a file
//! of any size is scanned in a window of tens of kilobytes. A token never spans lines, so a
//! window always ends on a line's end; only a comment is read across lines. Spans are offsets
//! in the whole text either way.
//!
//! Numbers are `[+-]? digits? (. digits?)? ([eE] [+-]? digits)?` with at least one digit
//! before the exponent: `1`, `-1`, `.5176`, `-.816497`, `5.`, `1e-3`. A number that overflows
//! to infinity is an error, and so is a number glued to letters (`3x`).

use crate::diag::Diagnostic;
use crate::lines::LineSupply;
use crate::span::Span;
use std::borrow::Cow;

/// How much text a streaming lexer reads at a time, and the dead prefix it lets grow before
/// it drops it from its window.
const WINDOW_STEP: usize = 1 << 16;

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
    /// Extension: a quoted string, `"statue.ply"`, on one line; its text without the quotes
    /// is [`Lexer::string`].
    String,
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
            TokenKind::String => "a quoted string",
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
    /// The window: the text from offset `base` on (the whole text for [`Lexer::new`]).
    text: Cow<'a, str>,
    base: usize,
    /// The scan position in the window.
    pos: usize,
    /// The offset in the whole text from which the reader may still ask for text.
    keep: usize,
    supply: Option<&'a mut dyn LineSupply>,
    /// How much a streaming lexer reads at a time ([`WINDOW_STEP`] but in tests).
    step: usize,
    errors: Vec<Diagnostic>,
}

impl<'a> Lexer<'a> {
    /// A lexer at the start of `text` (after a byte-order mark, if any).
    pub fn new(text: &'a str) -> Lexer<'a> {
        let mut lexer = Lexer {
            text: Cow::Borrowed(text),
            base: 0,
            pos: 0,
            keep: 0,
            supply: None,
            step: WINDOW_STEP,
            errors: Vec::new(),
        };
        lexer.skip_byte_order_mark();
        lexer
    }

    /// A lexer over the lines of `supply`, read as the scan needs them.
    pub fn streaming(supply: &'a mut dyn LineSupply) -> Lexer<'a> {
        Lexer::streaming_in_steps(supply, WINDOW_STEP)
    }

    /// [`Lexer::streaming`], reading `step` bytes at a time (a line at least).
    pub(crate) fn streaming_in_steps(supply: &'a mut dyn LineSupply, step: usize) -> Lexer<'a> {
        let mut lexer = Lexer {
            text: Cow::Owned(String::new()),
            base: 0,
            pos: 0,
            keep: 0,
            supply: Some(supply),
            step,
            errors: Vec::new(),
        };
        lexer.fill();
        lexer.skip_byte_order_mark();
        lexer
    }

    /// A leading byte-order mark (from some Windows editors) is skipped.
    fn skip_byte_order_mark(&mut self) {
        if self.text.starts_with('\u{feff}') {
            self.pos = 3;
        }
    }

    /// Says that the text before `offset` (in the whole text) will not be asked for again:
    /// a streaming lexer may drop it from its window.
    pub fn keep_from(&mut self, offset: usize) {
        self.keep = self.keep.max(offset);
    }

    /// The source text of a span (used for identifiers). A span that starts before the point
    /// given to [`Lexer::keep_from`] may be gone from a streaming lexer's window: its text is
    /// then empty.
    pub fn slice(&self, span: Span) -> &str {
        let (start, end) = (span.start as usize, span.end as usize);
        debug_assert!(start >= self.base, "span {start} read after it was dropped");
        match (start.checked_sub(self.base), end.checked_sub(self.base)) {
            (Some(s), Some(e)) => self.text.get(s..e).unwrap_or(""),
            _ => "",
        }
    }

    /// The text of a [`TokenKind::String`] token, without its quotes.
    pub fn string(&self, span: Span) -> &str {
        let s = self.slice(span);
        s.get(1..s.len().saturating_sub(1)).unwrap_or("")
    }

    /// True when lexical errors are waiting in [`Lexer::take_errors`].
    pub fn has_errors(&self) -> bool {
        !self.errors.is_empty()
    }

    /// Lexical errors found so far, removed from the lexer.
    pub fn take_errors(&mut self) -> Vec<Diagnostic> {
        std::mem::take(&mut self.errors)
    }

    /// Reads more lines into the window (about [`WINDOW_STEP`] bytes), first dropping the
    /// text before both the kept point and the scan position once it is long enough; false
    /// when there is nothing more to read.
    fn fill(&mut self) -> bool {
        let Some(supply) = self.supply.as_deref_mut() else {
            return false;
        };
        let dead = self.keep.saturating_sub(self.base).min(self.pos);
        let text = self.text.to_mut();
        let worth = dead >= self.step || dead * 2 >= text.len();
        if dead > 0 && worth && text.is_char_boundary(dead) {
            text.drain(..dead);
            self.base += dead;
            self.pos -= dead;
        }
        let before = text.len();
        while text.len() - before < self.step && supply.next_line(text) {}
        text.len() > before
    }

    /// The length of the window (the whole text for [`Lexer::new`]).
    #[cfg(test)]
    fn window(&self) -> usize {
        self.text.len()
    }

    /// A span from `start` to the scan position, both in the window, as offsets in the text.
    fn span_to_pos(&self, start: usize) -> Span {
        Span::new(self.base + start, self.base + self.pos)
    }

    fn token(&self, kind: TokenKind, start: usize) -> Token {
        Token {
            kind,
            span: self.span_to_pos(start),
            value: 0.0,
        }
    }

    fn error(&mut self, start: usize, message: String) -> Token {
        let span = self.span_to_pos(start);
        self.errors.push(Diagnostic::error(span, message));
        self.token(TokenKind::Error, start)
    }

    /// Skips blanks and comments, reading more of a streamed text as it goes; reports an
    /// unterminated comment.
    fn skip_trivia(&mut self) {
        loop {
            let b = self.text.as_bytes();
            while self.pos < b.len() && b[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            if self.pos == b.len() {
                if self.fill() {
                    continue;
                }
                return;
            }
            if !(self.pos + 1 < b.len() && b[self.pos] == b'/' && b[self.pos + 1] == b'*') {
                return;
            }
            self.skip_comment();
        }
    }

    /// Skips the comment at the scan position, through its `*/`, reading more of a streamed
    /// text until it is found; at the end of the text, reports the comment unterminated.
    fn skip_comment(&mut self) {
        let opened = self.base + self.pos;
        self.pos += 2;
        loop {
            let b = self.text.as_bytes();
            if let Some(len) = find_comment_end(&b[self.pos..]) {
                self.pos += len + 2;
                return;
            }
            // A `*` at the window's end may open the `*/`: scanning goes on from it.
            self.pos = b.len().saturating_sub(1).max(self.pos);
            if !self.fill() {
                self.pos = self.text.len();
                self.errors.push(Diagnostic::error(
                    Span::new(opened, opened + 2),
                    "unterminated comment: `/*` has no closing `*/`",
                ));
                return;
            }
        }
    }

    /// The next token; [`TokenKind::Eof`] forever at the end.
    pub fn next_token(&mut self) -> Token {
        self.skip_trivia();
        let b = self.text.as_bytes();
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
        if c == b'"' {
            return self.string_token(start);
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

    /// A string from its opening quote at `start` to the closing one on the same line; no
    /// escapes (a file name with a `"` in it cannot be written).
    fn string_token(&mut self, start: usize) -> Token {
        let b = self.text.as_bytes();
        let rest = &b[start + 1..];
        match rest.iter().position(|&c| c == b'"' || c == b'\n') {
            Some(n) if rest[n] == b'"' => {
                self.pos = start + n + 2;
                self.token(TokenKind::String, start)
            }
            n => {
                self.pos = start + 1 + n.unwrap_or(rest.len());
                self.error(
                    start,
                    "unterminated string: `\"` has no closing `\"` on its line".into(),
                )
            }
        }
    }

    fn number(&mut self, start: usize) -> Token {
        let b = self.text.as_bytes();
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
        let b = self.text.as_bytes();
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
                span: self.span_to_pos(start),
                value: if negative { -v } else { v },
            };
        }
        let text = &self.text[start..p];
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Token {
                kind: TokenKind::Number,
                span: self.span_to_pos(start),
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
        let b = self.text.as_bytes();
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
mod tests;
