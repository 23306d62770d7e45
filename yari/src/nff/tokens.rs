//! NFF's tokens, read from a text as it goes by: blank-separated words, `#` starting a
//! comment to the end of the line (Haines's own reader uses `fscanf`, so line breaks carry
//! no meaning). One token can be looked at before it is taken, and one taken back.

use crate::lines::TextLines;
use crate::span::Span;
use std::io::BufRead;

/// One word of the text and where it is.
#[derive(Clone, Debug)]
pub(super) struct Token {
    pub(super) text: Text,
    pub(super) span: Span,
}

/// The longest word kept inline in a [`Text`]: every number and keyword of the usual NFF
/// file (`-0.123456789012345678` has 21 characters).
const INLINE: usize = 30;

/// A word's text: inline when it is short, so that reading a number allocates nothing (a
/// `String` each word was a heap allocation and a free for every number of the file: with
/// the text inline, `sunray render tetra6.nff` at 512x512 runs 1.9% fewer instructions,
/// malloc and free 16M -> 4M of them); on the heap when longer (arrayvec's `ArrayString`,
/// already the renderer's, for the inline text).
#[derive(Clone, Debug)]
pub(super) enum Text {
    Short(arrayvec::ArrayString<INLINE>),
    Long(String),
}

impl Text {
    fn new(word: &str) -> Text {
        match arrayvec::ArrayString::from(word) {
            Ok(short) => Text::Short(short),
            Err(_) => Text::Long(word.to_string()),
        }
    }

    /// The word.
    pub(super) fn as_str(&self) -> &str {
        match self {
            Text::Short(s) => s.as_str(),
            Text::Long(s) => s.as_str(),
        }
    }
}

impl std::fmt::Display for Text {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
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
                        text: Text::new(&line[start..i]),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_short_and_long_keep_their_text_and_place() {
        let long = "x".repeat(INLINE + 5);
        let text = format!("v 1.5 # a comment\n  {long}\t-2e3\n");
        let mut lines = TextLines::new(text.as_bytes());
        let mut tokens = Tokens::new(&mut lines);
        let mut got = Vec::new();
        while let Some(t) = tokens.next() {
            let inline = matches!(t.text, Text::Short(_));
            let (start, end) = (t.span.start as usize, t.span.end as usize);
            got.push((t.text.to_string(), start, end, inline));
        }
        let at = text.find(&long).unwrap();
        let want = vec![
            ("v".to_string(), 0, 1, true),
            ("1.5".to_string(), 2, 5, true),
            (long.clone(), at, at + long.len(), false),
            (
                "-2e3".to_string(),
                at + long.len() + 1,
                at + long.len() + 5,
                true,
            ),
        ];
        assert_eq!(got, want);
    }
}
