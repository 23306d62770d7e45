//! NFF (Haines's Neutral File Format) to YARI: the thesis's `nff2gfx`. (Being written.)

use crate::ast::Scene;
use crate::diag::{Diagnostic, Diagnostics};
use crate::span::{Source, Span};

/// Reads an NFF file into a YARI syntax tree.
pub fn parse(_src: &Source) -> Result<Scene, Diagnostics> {
    let mut d = Diagnostics::default();
    d.push(Diagnostic::error(Span::default(), "NFF input is not supported yet"));
    Err(d)
}
