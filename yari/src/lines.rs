//! A text read once, line by line, from a buffered reader: each line with the byte offset it
//! starts at, checked as UTF-8 as it goes by. The streaming readers ([`crate::nff`],
//! [`crate::off`]) tokenize it, and the YARI lexer reads it through [`LineSupply`]; an I/O error or a byte that is not UTF-8 ends it, and is
//! kept for the caller ([`TextLines::failure`]).

use std::io::BufRead;

/// Why a text stopped before its end.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TextFailure {
    /// Reading failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// A line is not UTF-8.
    #[error("not a text file (not UTF-8)")]
    NotText,
}

/// Lines handed out one at a time, appended to a buffer (the streaming lexer's supply).
pub trait LineSupply {
    /// Appends the next line (with its `\n`, if it has one) to `out`; false at the end.
    fn next_line(&mut self, out: &mut String) -> bool;
}

impl<R: BufRead> LineSupply for TextLines<R> {
    fn next_line(&mut self, out: &mut String) -> bool {
        if !self.advance() {
            return false;
        }
        out.push_str(&self.line);
        true
    }
}

/// The lines of a text as they are read.
pub struct TextLines<R> {
    input: R,
    line: String,
    start: usize,
    offset: usize,
    failure: Option<TextFailure>,
}

impl<R: BufRead> TextLines<R> {
    /// The text of `input`, before its first line.
    pub fn new(input: R) -> TextLines<R> {
        TextLines {
            input,
            line: String::new(),
            start: 0,
            offset: 0,
            failure: None,
        }
    }

    /// Reads the next line (with its `\n`, if it has one); false at the end of the text or
    /// after a failure.
    pub fn advance(&mut self) -> bool {
        if self.failure.is_some() {
            return false;
        }
        let mut bytes = std::mem::take(&mut self.line).into_bytes();
        bytes.clear();
        match self.input.read_until(b'\n', &mut bytes) {
            Ok(0) => {
                self.start = self.offset;
                false
            }
            Ok(n) => match String::from_utf8(bytes) {
                Ok(line) => {
                    self.start = self.offset;
                    self.offset += n;
                    self.line = line;
                    true
                }
                Err(_) => {
                    self.failure = Some(TextFailure::NotText);
                    false
                }
            },
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => self.advance(),
            Err(e) => {
                self.failure = Some(e.into());
                false
            }
        }
    }

    /// The current line, with its `\n` (empty before the first and after the last).
    pub fn line(&self) -> &str {
        &self.line
    }

    /// The byte offset of the current line in the text.
    pub fn start(&self) -> usize {
        self.start
    }

    /// The bytes read so far (the text's length once it has ended).
    pub fn offset(&self) -> usize {
        self.offset
    }

    /// Reads (and checks) the rest of the text, so a reader that stops early still reports
    /// a text that is not UTF-8 to the end.
    pub fn drain(&mut self) {
        while self.advance() {}
    }

    /// Why the text stopped early, if it did.
    pub fn failure(&mut self) -> Option<TextFailure> {
        self.failure.take()
    }
}
