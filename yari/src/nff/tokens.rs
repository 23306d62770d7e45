//! NFF's tokens, read from a text as it goes by: blank-separated words, `#` starting a
//! comment to the end of the line (Haines's own reader uses `fscanf`, so line breaks carry
//! no meaning). One token can be looked at before it is taken, and one taken back.

use crate::lines::TextLines;
use crate::span::Span;
use std::io::BufRead;

/// One word of the text and where it is.
#[derive(Clone, Debug)]
pub(super) struct Token {
    pub(super) text: String,
    pub(super) span: Span,
}

/// The tokens of a text, in order.
pub(super) struct Tokens<'l, R> {
    lines: &'l mut TextLines<R>,
    /// Where the next token starts the search in the current line.
    pos: usize,
    ahead: Option<Token>,
    last: Span,
    before_last: Span,
}

impl<'l, R: BufRead> Tokens<'l, R> {
    pub(super) fn new(lines: &'l mut TextLines<R>) -> Tokens<'l, R> {
        Tokens {
            lines,
            pos: 0,
            ahead: None,
            last: Span::default(),
            before_last: Span::default(),
        }
    }

    fn scan(&mut self) -> Option<Token> {
        loop {
            let line = self.lines.line();
            let bytes = line.as_bytes();
            let mut i = self.pos;
            while i < bytes.len() {
                if bytes[i].is_ascii_whitespace() {
                    i += 1;
                } else if bytes[i] == b'#' {
                    i = bytes.len();
                } else {
                    let start = i;
                    while i < bytes.len() && !bytes[i].is_ascii_whitespace() {
                        i += 1;
                    }
                    let base = self.lines.start();
                    let token = Token {
                        text: line[start..i].to_string(),
                        span: Span::new(base + start, base + i),
                    };
                    self.pos = i;
                    return Some(token);
                }
            }
            if !self.lines.advance() {
                self.pos = 0;
                return None;
            }
            self.pos = 0;
        }
    }

    /// Takes the next token.
    pub(super) fn next(&mut self) -> Option<Token> {
        let t = match self.ahead.take() {
            Some(t) => Some(t),
            None => self.scan(),
        };
        if let Some(t) = &t {
            self.before_last = self.last;
            self.last = t.span;
        }
        t
    }

    /// The next token, left in place.
    pub(super) fn peek(&mut self) -> Option<&Token> {
        if self.ahead.is_none() {
            self.ahead = self.scan();
        }
        self.ahead.as_ref()
    }

    /// Puts back the token just taken.
    pub(super) fn put_back(&mut self, t: Token) {
        self.last = self.before_last;
        self.ahead = Some(t);
    }

    /// The span of the last token taken (empty before the first).
    pub(super) fn last_span(&self) -> Span {
        self.last
    }

    /// The offset of the end of the text, once it has been reached.
    pub(super) fn end(&self) -> usize {
        self.lines.offset()
    }

    /// Reads the rest of the text (see [`TextLines::drain`]).
    pub(super) fn drain(&mut self) {
        self.lines.drain();
    }
}
