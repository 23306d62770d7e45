//! Reading OFF text as a stream: the header (with its `N`, `C` and `ST` prefixes), the
//! counts, the vertex lines (kept: faces refer to them) and the face lines (each handed
//! over as soon as it is read), each error with its location.

use crate::ast::{has_direction, Vec3};
use crate::diag::{Diagnostic, Diagnostics};
use crate::lines::TextLines;
use crate::span::Span;
use std::io::BufRead;

/// Largest vertex or face count accepted (a guard against absurd headers).
const MAX_COUNT: u64 = 50_000_000;
/// The reader stops after this many errors.
const MAX_ERRORS: usize = 50;

/// What each vertex line holds besides x y z, from the header's prefixes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Layout {
    /// `N`: a normal nx ny nz.
    normals: bool,
    /// `C`: a colour r g b [a].
    colours: bool,
    /// `ST`: texture coordinates s t.
    texture: bool,
}

/// The vertices: their positions, and with `NOFF` their normals; which of them a face uses.
#[derive(Default)]
pub(super) struct VertexTable {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    used: Vec<bool>,
}

impl VertexTable {
    /// The positions of the vertices some face uses, or of all when none does.
    pub(super) fn framed(&self) -> impl Iterator<Item = &Vec3> + Clone {
        let any = self.used.contains(&true);
        self.positions
            .iter()
            .zip(&self.used)
            .filter(move |(_, used)| **used || !any)
            .map(|(p, _)| p)
    }
}

/// Reads the whole text, handing each face to `each` as it is read (none after the first
/// error); the vertices. Errors in face lines are collected in `diags` (the reader goes on);
/// the first error elsewhere is returned.
pub(super) fn read_off<R: BufRead>(
    text: &mut TextLines<R>,
    diags: &mut Diagnostics,
    each: &mut dyn FnMut(Face),
) -> Result<VertexTable, Diagnostic> {
    let mut lines = Lines::new(text);
    let (layout, counts) = header(&mut lines)?;
    if counts.len() < 2 || counts.len() > 3 {
        let span = counts[0].span.to(counts[counts.len() - 1].span);
        return Err(Diagnostic::error(
            span,
            "expected the counts line `nv nf ne`",
        ));
    }
    let nv = count(&counts[0], "the vertex count")?;
    let nf = count(&counts[1], "the face count")?;
    if let Some(ne) = counts.get(2) {
        count(ne, "the edge count")?;
    }

    let mut table = VertexTable::default();
    let reserve = nv.min(1 << 20) as usize;
    table.positions.reserve(reserve);
    for i in 0..nv {
        let what = format!("vertex {i} of {nv}");
        let line = lines.next_line().ok_or_else(|| lines.eof(&what))?;
        let (position, normal) = vertex(&line, layout, &what)?;
        table.positions.push(position);
        table.normals.extend(normal);
    }
    table.used = vec![false; table.positions.len()];

    for f in 0..nf {
        let what = format!("face {f} of {nf}");
        let line = lines.next_line().ok_or_else(|| lines.eof(&what))?;
        match face(&line, &mut table, &what) {
            Ok((face, flat)) => {
                if let Some(k) = flat {
                    diags.push(Diagnostic::warning(
                        line[1 + k].span,
                        format!(
                            "the normal of vertex {} has no direction; {what} is shaded flat",
                            line[1 + k].text
                        ),
                    ));
                }
                if !diags.has_errors() {
                    each(face);
                }
            }
            Err(d) => {
                diags.push(d);
                if diags.errors().count() >= MAX_ERRORS {
                    return Err(Diagnostic::error(
                        line[0].span,
                        "too many errors; giving up",
                    ));
                }
            }
        }
    }
    if let Some(extra) = lines.next_line() {
        diags.push(Diagnostic::warning(
            extra[0].span,
            format!("text after the {nf} faces is ignored"),
        ));
    }
    Ok(table)
}

/// The header keyword's layout and the tokens of the counts line.
fn header<R: BufRead>(lines: &mut Lines<'_, R>) -> Result<(Layout, Vec<Token>), Diagnostic> {
    let mut header = lines
        .next_line()
        .ok_or_else(|| lines.eof("the `OFF` header"))?;
    let Some(first) = header.first().cloned() else {
        return Err(lines.eof("the `OFF` header"));
    };
    let layout = keyword(first)?;
    header.remove(0);
    let counts = if header.is_empty() {
        lines
            .next_line()
            .ok_or_else(|| lines.eof("the counts `nv nf ne`"))?
    } else {
        header
    };
    Ok((layout, counts))
}

/// `[ST][C][N]OFF` to its layout.
fn keyword(t: Token) -> Result<Layout, Diagnostic> {
    let bad = || {
        Diagnostic::error(
            t.span,
            format!("expected the `OFF` header, found `{}`", t.text),
        )
    };
    let Some(mut rest) = t.text.strip_suffix("OFF") else {
        return Err(bad());
    };
    let mut layout = Layout::default();
    for (prefix, flag) in [("ST", 0), ("C", 1), ("N", 2)] {
        if let Some(r) = rest.strip_prefix(prefix) {
            rest = r;
            match flag {
                0 => layout.texture = true,
                1 => layout.colours = true,
                _ => layout.normals = true,
            }
        }
    }
    match rest {
        "" => Ok(layout),
        "4" | "n" | "4n" => Err(Diagnostic::error(
            t.span,
            format!("`{}`: only 3-dimensional OFF is supported", t.text),
        )),
        _ => Err(bad()),
    }
}

/// One vertex line laid out as `layout` says: its position and, with `N`, its normal.
fn vertex(line: &[Token], layout: Layout, what: &str) -> Result<(Vec3, Option<Vec3>), Diagnostic> {
    let fixed = 3 + if layout.normals { 3 } else { 0 } + if layout.texture { 2 } else { 0 };
    let colour = line.len().saturating_sub(fixed);
    let ok = if layout.colours {
        line.len() >= fixed && (colour == 3 || colour == 4)
    } else {
        line.len() == fixed
    };
    if !ok {
        let span = line[0].span.to(line[line.len() - 1].span);
        let expected = match (layout.colours, layout.normals) {
            (false, false) => "3 coordinates".to_string(),
            (false, true) => "3 coordinates and a normal (6 numbers)".to_string(),
            (true, _) => format!("{fixed} numbers and a colour of 3 or 4"),
        };
        return Err(Diagnostic::error(
            span,
            format!("{what} must have {expected}, found {}", line.len()),
        ));
    }
    let mut nums = [0.0; 6];
    for (k, t) in line.iter().enumerate() {
        let x = number(t, what)?;
        if k < 6 {
            nums[k] = x;
        }
    }
    Ok((
        [nums[0], nums[1], nums[2]],
        layout.normals.then_some([nums[3], nums[4], nums[5]]),
    ))
}

/// One face: vertex positions (and normals) already looked up, optional colour, the line's
/// span.
pub(super) struct Face {
    pub(super) vertices: Vec<Vec3>,
    /// The vertices' normals (`NOFF`), when every one of them has a direction.
    pub(super) normals: Option<Vec<Vec3>>,
    pub(super) color: Option<Vec3>,
    pub(super) span: Span,
}

/// One face line: the face, and the position in it of the first vertex whose normal has no
/// direction (the face is then flat).
fn face(
    line: &[Token],
    vertices: &mut VertexTable,
    what: &str,
) -> Result<(Face, Option<usize>), Diagnostic> {
    let span = line[0].span.to(line[line.len() - 1].span);
    let n = count(&line[0], &format!("the vertex count of {what}"))? as usize;
    if n < 3 {
        return Err(Diagnostic::error(
            line[0].span,
            format!("{what} has {n} vertices; a polygon needs at least 3"),
        ));
    }
    let rest = &line[1..];
    if rest.len() < n {
        return Err(Diagnostic::error(
            span,
            format!("{what} lists {} vertex indices, expected {n}", rest.len()),
        ));
    }
    let mut points = Vec::with_capacity(n);
    let mut normals = Vec::with_capacity(n);
    for t in &rest[..n] {
        let i = count(t, "a vertex index")?;
        let at = i as usize;
        let v = vertices.positions.get(at).ok_or_else(|| {
            Diagnostic::error(
                t.span,
                format!(
                    "vertex index {i} is out of range (the file has {} vertices)",
                    vertices.positions.len()
                ),
            )
        })?;
        points.push(*v);
        normals.extend(vertices.normals.get(at));
        vertices.used[at] = true;
    }
    let flat = normals.iter().position(|n| !has_direction(n));
    let normals = (normals.len() == n && flat.is_none()).then_some(normals);
    let extra = &rest[n..];
    let color = match extra.len() {
        0 => None,
        3 | 4 => {
            let mut c = [0.0; 3];
            for (k, t) in extra[..3].iter().enumerate() {
                c[k] = number(t, "a colour component")?;
                if c[k] < 0.0 {
                    return Err(Diagnostic::error(
                        t.span,
                        "colour components must not be negative",
                    ));
                }
            }
            if c.iter().any(|&x| x > 1.0) {
                c = c.map(|x| x / 255.0);
            }
            Some(c)
        }
        k => {
            let span = extra[0].span.to(extra[k - 1].span);
            return Err(Diagnostic::error(span, format!("{what}: expected a colour (3 or 4 numbers) after the indices, found {k} numbers")));
        }
    };
    Ok((
        Face {
            vertices: points,
            normals,
            color,
            span,
        },
        flat,
    ))
}

fn count(t: &Token, what: &str) -> Result<u64, Diagnostic> {
    match t.text.parse::<u64>() {
        Ok(n) if n <= MAX_COUNT => Ok(n),
        Ok(n) => Err(Diagnostic::error(
            t.span,
            format!("{what} {n} is larger than {MAX_COUNT}"),
        )),
        Err(_) => Err(Diagnostic::error(
            t.span,
            format!("expected {what} (a whole number), found `{}`", t.text),
        )),
    }
}

fn number(t: &Token, what: &str) -> Result<f64, Diagnostic> {
    match t.text.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(Diagnostic::error(
            t.span,
            format!("expected a number in {what}, found `{}`", t.text),
        )),
    }
}

#[derive(Clone)]
pub(super) struct Token {
    text: String,
    span: Span,
}

/// Non-empty lines of tokens, comments removed.
struct Lines<'l, R> {
    text: &'l mut TextLines<R>,
}

impl<'l, R: BufRead> Lines<'l, R> {
    fn new(text: &'l mut TextLines<R>) -> Self {
        Lines { text }
    }

    fn eof(&self, what: &str) -> Diagnostic {
        let end = self.text.offset();
        Diagnostic::error(
            Span::new(end, end),
            format!("unexpected end of file: expected {what}"),
        )
    }

    fn next_line(&mut self) -> Option<Vec<Token>> {
        while self.text.advance() {
            let start = self.text.start();
            let line = self.text.line();
            let line = line.strip_suffix('\n').unwrap_or(line);
            let line = line.split('#').next().unwrap_or("");
            let mut tokens = Vec::new();
            let mut pos = 0;
            for piece in line.split(|c: char| c.is_ascii_whitespace()) {
                if !piece.is_empty() {
                    let s = start + pos;
                    tokens.push(Token {
                        text: piece.to_string(),
                        span: Span::new(s, s + piece.len()),
                    });
                }
                pos += piece.len() + 1;
            }
            if !tokens.is_empty() {
                return Some(tokens);
            }
        }
        None
    }
}
