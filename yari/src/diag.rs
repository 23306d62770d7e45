//! Diagnostics: typed errors and warnings with a span, rendered as
//! `file:line:col: error: message`, the source line, and a caret under the span.

use crate::span::{Source, Span};
use std::fmt::Write;

/// How bad a diagnostic is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Severity {
    /// The input is rejected: no syntax tree or world is produced.
    Error,
    /// Reported, but the input is still used (as written or with a default).
    Warning,
}

/// One message about one place in a source text.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// The bytes it is about; the caret goes under them.
    pub span: Span,
    /// What is wrong, one line (printed after `error: ` or `warning: `).
    pub message: String,
}

impl Diagnostic {
    /// An error about `span`.
    pub fn error(span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Error,
            span,
            message: message.into(),
        }
    }
    /// A warning about `span`.
    pub fn warning(span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Warning,
            span,
            message: message.into(),
        }
    }

    /// `file:line:col: error: message`, then the line and a caret (`^~~~`) under the span.
    pub fn render(&self, src: &Source) -> String {
        let (line, col) = src.line_col(self.span.start);
        let kind = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        let mut out = format!(
            "{}:{}:{}: {}: {}\n",
            src.name, line, col, kind, self.message
        );
        let text = src.line_text(line);
        let _ = writeln!(out, "  {text}");
        let width = {
            let (end_line, end_col) = src.line_col(self.span.end);
            if end_line == line && end_col > col {
                end_col - col
            } else {
                1
            }
        };
        let pad: String = text
            .chars()
            .take(col - 1)
            .map(|c| if c == '\t' { '\t' } else { ' ' })
            .collect();
        let _ = writeln!(out, "  {pad}^{}", "~".repeat(width.saturating_sub(1)));
        out
    }
}

/// Diagnostics collected while reading one source: the error type of the parser and compiler.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Diagnostics {
    /// Errors and warnings in the order they were found.
    pub items: Vec<Diagnostic>,
}

impl Diagnostics {
    /// Adds one at the end.
    pub fn push(&mut self, d: Diagnostic) {
        self.items.push(d);
    }
    /// Whether any of them is an error (the input is rejected).
    pub fn has_errors(&self) -> bool {
        self.items.iter().any(|d| d.severity == Severity::Error)
    }
    /// The errors, in order.
    pub fn errors(&self) -> impl Iterator<Item = &Diagnostic> {
        self.items.iter().filter(|d| d.severity == Severity::Error)
    }
    /// The warnings, in order.
    pub fn warnings(&self) -> impl Iterator<Item = &Diagnostic> {
        self.items
            .iter()
            .filter(|d| d.severity == Severity::Warning)
    }
    /// All diagnostics rendered against their source, in order.
    pub fn render(&self, src: &Source) -> String {
        self.items.iter().map(|d| d.render(src)).collect()
    }
}

/// A failed read of a scene: the diagnostics, with the source they point into.
#[derive(Debug, thiserror::Error)]
#[error("{}", .diagnostics.render(.source_text))]
pub struct SceneError {
    /// The text the diagnostics point into, with its file name.
    pub source_text: Source,
    /// Everything found, at least one error among them.
    pub diagnostics: Diagnostics,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caret_under_span() {
        let src = Source::new("s.yari", "begin\n  sphre(center=0,0,0);\nend\n");
        let d = Diagnostic::error(Span::new(8, 13), "unknown command `sphre`");
        assert_eq!(
            d.render(&src),
            "s.yari:2:3: error: unknown command `sphre`\n    sphre(center=0,0,0);\n    ^~~~~\n"
        );
    }
}
