//! Source positions: byte spans into a named source text, turned into line and column on demand.
//! A text read as a stream is not kept: its diagnostics are shown from an excerpt
//! ([`Source::excerpt`]), the lines they point at read again.

use crate::lines::TextLines;
use serde::{Deserialize, Serialize};
use std::io::BufRead;

/// A half-open byte range `[start, end)` into one source text.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Span {
    /// Offset of the first byte.
    pub start: u32,
    /// Offset one past the last byte (equal to `start` for an empty span).
    pub end: u32,
}

impl Span {
    /// The span `[start, end)` from byte offsets, stored as `u32` (offsets past 4 GiB do not fit).
    pub fn new(start: usize, end: usize) -> Span {
        Span {
            start: start as u32,
            end: end as u32,
        }
    }
    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        Span {
            start: self.start.min(other.start),
            end: self.end.max(other.end),
        }
    }
}

/// A source text with its name (a path, or `<stdin>`), able to map byte offsets to lines.
#[derive(Clone, Debug)]
pub struct Source {
    /// The name printed at the start of each diagnostic.
    pub name: String,
    /// The whole text; spans index its bytes. For an excerpt, only the lines it keeps.
    pub text: String,
    line_starts: Vec<usize>,
    excerpt: Option<Box<Kept>>,
}

/// For an excerpt: where each kept line starts in the whole text, and its line number.
#[derive(Clone, Debug)]
struct Kept {
    starts: Vec<usize>,
    numbers: Vec<usize>,
}

impl Source {
    /// Wraps `text` under `name`, indexing where its lines start.
    pub fn new(name: impl Into<String>, text: impl Into<String>) -> Source {
        let text = text.into();
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Source {
            name: name.into(),
            text,
            line_starts,
            excerpt: None,
        }
    }

    /// The lines of the text read from `input` that hold one of `offsets` (an offset past
    /// the end is the end), for showing diagnostics about a text that was not kept.
    pub fn excerpt(
        name: impl Into<String>,
        input: impl BufRead,
        offsets: &[u32],
    ) -> std::io::Result<Source> {
        let mut offsets: Vec<usize> = offsets.iter().map(|&o| o as usize).collect();
        offsets.sort_unstable();
        let mut lines = TextLines::new(input);
        let (mut text, mut line_starts) = (String::new(), Vec::new());
        let mut kept = Kept {
            starts: Vec::new(),
            numbers: Vec::new(),
        };
        let (mut number, mut ended) = (0, true);
        let mut next = 0;
        while next < offsets.len() && lines.advance() {
            let (start, line) = (lines.start(), lines.line());
            number += 1;
            ended = line.ends_with('\n');
            let end = if ended {
                start + line.len()
            } else {
                usize::MAX
            };
            if offsets[next] < end {
                kept.starts.push(start);
                kept.numbers.push(number);
                line_starts.push(text.len());
                text.push_str(line);
            }
            while next < offsets.len() && offsets[next] < end {
                next += 1;
            }
        }
        if let Some(e) = lines.failure() {
            return Err(match e {
                crate::lines::TextFailure::Io(e) => e,
                _ => std::io::ErrorKind::InvalidData.into(),
            });
        }
        if next < offsets.len() && ended {
            kept.starts.push(lines.offset());
            kept.numbers.push(number + 1);
            line_starts.push(text.len());
        }
        Ok(Source {
            name: name.into(),
            text,
            line_starts,
            excerpt: Some(Box::new(kept)),
        })
    }

    /// 1-based line and column (column counted in characters) of a byte offset.
    pub fn line_col(&self, offset: u32) -> (usize, usize) {
        if let Some(kept) = &self.excerpt {
            let Some(i) = kept
                .starts
                .partition_point(|&s| s <= offset as usize)
                .checked_sub(1)
            else {
                return (1, 1);
            };
            let (start, end) = self.kept_line(i);
            let at = (start + (offset as usize - kept.starts[i])).min(end);
            let col = self.text[start..floor_char_boundary(&self.text, at)]
                .chars()
                .count();
            return (kept.numbers[i], col + 1);
        }
        let offset = (offset as usize).min(self.text.len());
        let line = self.line_starts.partition_point(|&s| s <= offset) - 1;
        let start = self.line_starts[line];
        let col = self.text[start..floor_char_boundary(&self.text, offset)]
            .chars()
            .count()
            + 1;
        (line + 1, col)
    }

    /// Where the `i`th line kept of a file's excerpt starts and ends in `text`.
    fn kept_line(&self, i: usize) -> (usize, usize) {
        let start = self.line_starts[i];
        let end = self
            .line_starts
            .get(i + 1)
            .copied()
            .unwrap_or(self.text.len());
        (start, end)
    }

    /// The text of 1-based line `line`, without its newline.
    pub fn line_text(&self, line: usize) -> &str {
        if let Some(kept) = &self.excerpt {
            let Ok(i) = kept.numbers.binary_search(&line) else {
                return "";
            };
            let (start, end) = self.kept_line(i);
            let text = &self.text[start..end];
            return text
                .strip_suffix('\n')
                .unwrap_or(text)
                .trim_end_matches('\r');
        }
        let start = self.line_starts[line - 1];
        let end = self
            .line_starts
            .get(line)
            .map(|&e| e - 1)
            .unwrap_or(self.text.len());
        self.text[start..end].trim_end_matches('\r')
    }
}

fn floor_char_boundary(s: &str, mut i: usize) -> usize {
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column() {
        let s = Source::new("t", "ab\ncd\n\nef");
        assert_eq!(s.line_col(0), (1, 1));
        assert_eq!(s.line_col(4), (2, 2));
        assert_eq!(s.line_col(6), (3, 1));
        assert_eq!(s.line_col(8), (4, 2));
        assert_eq!(s.line_text(2), "cd");
        assert_eq!(s.line_text(4), "ef");
    }

    #[test]
    fn an_excerpt_places_its_offsets_as_the_whole_text_does() {
        for text in ["ab\ncd\n\nef", "ab\ncd\n\nef\n", "", "x", "é1\r\nü2\n\n"] {
            let whole = Source::new("t", text);
            for at in 0..=text.len() as u32 + 1 {
                let part = Source::excerpt("t", text.as_bytes(), &[at, 0]).unwrap();
                let (line, col) = whole.line_col(at);
                assert_eq!(part.line_col(at), (line, col), "{text:?} at {at}");
                assert_eq!(
                    part.line_text(line),
                    whole.line_text(line),
                    "{text:?} at {at}"
                );
            }
        }
    }
}
