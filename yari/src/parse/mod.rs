//! The YARI parser: recursive descent over [`crate::lexer`] tokens into an [`crate::ast::Scene`].
//!
//! The grammar is Appendix C.4 of the thesis with the extensions listed in `docs/yari.md`.
//! On an error the parser reports it, skips to the end of the statement (its `)` and `;`,
//! or the next command name, `begin` or `end`) and goes on, so one run lists several errors.
//! Blocks nest at most [`MAX_NESTING`] deep; deeper input is an error, never a stack overflow.
//!
//! # Layout
//! - this file: the token cursor, error recovery and the file structure (preamble, blocks).
//! - `view`: preamble statements (`resolution`, `camera`, ...).
//! - `body`: body statements (`attribute`, primitives, transformations).
//! - `values`: numbers, vectors, colours and `name = value` field lists.

mod body;
mod values;
mod view;

use crate::ast::{Block, BodyItem, Scene, Spanned, ViewStmt};
use crate::diag::{Diagnostic, Diagnostics};
use crate::lexer::{Lexer, Token, TokenKind};
use crate::lines::LineSupply;
use crate::span::{Source, Span};

/// The deepest `begin ... end` nesting accepted (the world block is level 1).
pub const MAX_NESTING: usize = 256;
/// After this many errors the parser stops.
const MAX_ERRORS: usize = 50;

/// Parses a whole YARI scene file.
pub fn parse(src: &Source) -> Result<Scene, Diagnostics> {
    let mut p = Parser::new(Lexer::new(&src.text));
    let scene = p.scene();
    if p.diags.has_errors() {
        Err(p.diags)
    } else {
        Ok(scene)
    }
}

/// Parses `src` as [`parse`] does, but hands each item of the world block to `item` as soon
/// as it is parsed (a nested block whole) instead of keeping the tree, so a reader that
/// compiles each item at once never holds the whole tree. The preamble statements, or every
/// diagnostic when there is an error (the items handed over are then to be thrown away).
pub fn parse_each(
    src: &Source,
    item: &mut dyn FnMut(Spanned<BodyItem>),
) -> Result<Vec<Spanned<ViewStmt>>, Diagnostics> {
    each(Parser::new(Lexer::new(&src.text)), item)
}

/// [`parse_each`] over a text read line by line as the parse needs it: the text is never
/// held whole, only a window around the statement being parsed. Spans are offsets in the
/// text; the lines they point at are read again to show them ([`Source::excerpt`]).
pub fn parse_each_streamed(
    text: &mut dyn LineSupply,
    item: &mut dyn FnMut(Spanned<BodyItem>),
) -> Result<Vec<Spanned<ViewStmt>>, Diagnostics> {
    each(Parser::new(Lexer::streaming(text)), item)
}

fn each(
    mut p: Parser<'_>,
    item: &mut dyn FnMut(Spanned<BodyItem>),
) -> Result<Vec<Spanned<ViewStmt>>, Diagnostics> {
    let (view, _) = p.scene_each(item);
    if p.diags.has_errors() {
        Err(p.diags)
    } else {
        Ok(view)
    }
}

/// Commands that start a statement; recovery stops in front of them.
const COMMANDS: &[&str] = &[
    "begin",
    "end",
    "resolution",
    "background",
    "ambient",
    "light",
    "camera",
    "samples",
    "target_error",
    "attribute",
    "sphere",
    "polygon",
    "quadric",
    "mesh",
    "translate",
    "scale",
    "rotate",
    "motion",
    "transform",
];
const VIEW_COMMANDS: &[&str] = &[
    "resolution",
    "background",
    "ambient",
    "light",
    "camera",
    "samples",
    "target_error",
];

/// Marks a parse failure whose error is already reported.
pub(crate) struct Abort;
pub(crate) type PResult<T> = Result<T, Abort>;

pub(crate) struct Parser<'a> {
    lex: Lexer<'a>,
    pub(crate) tok: Token,
    pub(crate) prev_end: usize,
    pub(crate) diags: Diagnostics,
    halted: bool,
}

impl<'a> Parser<'a> {
    fn new(mut lex: Lexer<'a>) -> Parser<'a> {
        let tok = lex.next_token();
        let mut diags = Diagnostics::default();
        diags.items.extend(lex.take_errors());
        Parser {
            lex,
            tok,
            prev_end: 0,
            diags,
            halted: false,
        }
    }

    // ---- cursor -------------------------------------------------------------------------

    pub(crate) fn bump(&mut self) -> Token {
        let t = self.tok;
        self.prev_end = t.span.end as usize;
        if self.halted {
            self.tok = Token {
                kind: TokenKind::Eof,
                span: Span::new(self.prev_end, self.prev_end),
                value: 0.0,
            };
            return t;
        }
        self.tok = self.lex.next_token();
        if self.lex.has_errors() {
            let errs = self.lex.take_errors();
            for e in errs {
                self.push(e);
            }
        }
        t
    }

    /// The text of a token of the statement being parsed (see [`Parser::statement`]).
    pub(crate) fn text(&self, t: Token) -> &str {
        self.lex.slice(t.span)
    }

    pub(crate) fn at(&self, kind: TokenKind) -> bool {
        self.tok.kind == kind
    }

    pub(crate) fn at_word(&self, word: &str) -> bool {
        self.tok.kind == TokenKind::Ident && self.text(self.tok) == word
    }

    pub(crate) fn eat(&mut self, kind: TokenKind) -> bool {
        if self.tok.kind == kind {
            self.bump();
            true
        } else {
            false
        }
    }

    /// The span from `start` to the end of the last token consumed.
    pub(crate) fn span_from(&self, start: Span) -> Span {
        Span::new(start.start as usize, self.prev_end.max(start.end as usize))
    }

    // ---- errors -------------------------------------------------------------------------

    fn push(&mut self, d: Diagnostic) {
        if self.halted {
            return;
        }
        self.diags.push(d);
        if self.diags.errors().count() >= MAX_ERRORS {
            let at = self.tok.span;
            self.diags.push(Diagnostic::error(
                at,
                format!("too many errors ({MAX_ERRORS}); giving up"),
            ));
            self.halted = true;
            self.tok = Token {
                kind: TokenKind::Eof,
                span: Span::new(self.prev_end, self.prev_end),
                value: 0.0,
            };
        }
    }

    pub(crate) fn error(&mut self, span: Span, message: impl Into<String>) -> Abort {
        self.push(Diagnostic::error(span, message));
        Abort
    }

    /// How the current token is named in a message.
    fn found(&self) -> String {
        match self.tok.kind {
            TokenKind::Ident | TokenKind::Number => format!("`{}`", self.text(self.tok)),
            k => k.describe().to_string(),
        }
    }

    /// Reports "expected X, found Y" at the current token (unless it is a lexical error,
    /// which is reported already).
    pub(crate) fn unexpected(&mut self, expected: &str) -> Abort {
        if self.tok.kind == TokenKind::Error {
            return Abort;
        }
        let msg = format!("expected {expected}, found {}", self.found());
        self.error(self.tok.span, msg)
    }

    pub(crate) fn expect(&mut self, kind: TokenKind, expected: &str) -> PResult<Token> {
        if self.tok.kind == kind {
            Ok(self.bump())
        } else {
            Err(self.unexpected(expected))
        }
    }

    /// Skips the rest of a failed statement: through its closing `)` and `;`, or up to the
    /// next command name or the end. `depth` is 1 when the statement's `(` was consumed.
    pub(crate) fn recover(&mut self, mut depth: usize) {
        loop {
            match self.tok.kind {
                TokenKind::Eof => return,
                TokenKind::LParen => depth += 1,
                TokenKind::RParen => {
                    self.bump();
                    if depth <= 1 {
                        self.eat(TokenKind::Semi);
                        return;
                    }
                    depth -= 1;
                    continue;
                }
                TokenKind::Semi if depth == 0 => {
                    self.bump();
                    return;
                }
                TokenKind::Ident if COMMANDS.contains(&self.text(self.tok)) => return,
                _ => {}
            }
            self.bump();
        }
    }

    /// Parses `name ( args ) ;` with `args` parsing the inside. Returns the node and its span
    /// (name to `)`), or `None` after reporting an error and recovering.
    pub(crate) fn statement<T>(
        &mut self,
        args: impl FnOnce(&mut Self, Span) -> PResult<T>,
    ) -> Option<(T, Span)> {
        let name = self.bump();
        // The statement's text is kept from its name on: the name is read again at its end.
        self.lex.keep_from(name.span.start as usize);
        if !self.at(TokenKind::LParen) {
            let word = self.text(name).to_owned();
            self.unexpected(&format!("`(` after `{word}`"));
            self.recover(0);
            return None;
        }
        self.bump();
        let value = match args(self, name.span) {
            Ok(v) => v,
            Err(Abort) => {
                self.recover(1);
                return None;
            }
        };
        if !self.at(TokenKind::RParen) {
            self.unexpected("`)`");
            self.recover(1);
            return None;
        }
        self.bump();
        let span = self.span_from(name.span);
        if !self.eat(TokenKind::Semi) {
            let at = Span::new(self.prev_end, self.prev_end);
            let word = self.text(name);
            let msg = format!("expected `;` after `{word}(...)`, found {}", self.found());
            self.error(at, msg);
        }
        Some((value, span))
    }

    // ---- file structure ---------------------------------------------------------------

    fn scene(&mut self) -> Scene {
        let mut items = Vec::new();
        let (view, span) = self.scene_each(&mut |i| items.push(i));
        Scene {
            view,
            body: Block { items, span },
        }
    }

    /// The preamble, and the world block's span, its items handed to `item` one by one.
    fn scene_each(
        &mut self,
        item: &mut dyn FnMut(Spanned<BodyItem>),
    ) -> (Vec<Spanned<ViewStmt>>, Span) {
        let mut view = Vec::new();
        loop {
            match self.tok.kind {
                TokenKind::Eof => {
                    if !self.halted {
                        let at = self.tok.span;
                        self.error(at, "missing the world block: expected `begin`");
                    }
                    return (view, Span::default());
                }
                TokenKind::Ident if self.at_word("begin") => break,
                TokenKind::Ident => {
                    let word = self.text(self.tok);
                    if VIEW_COMMANDS.contains(&word) {
                        if let Some(stmt) = self.view_statement() {
                            view.push(stmt);
                        }
                    } else {
                        let msg = if COMMANDS.contains(&word) {
                            format!("`{word}` belongs inside the world block (`begin ... end`)")
                        } else {
                            format!("unknown command `{word}`")
                        };
                        let at = self.tok.span;
                        self.error(at, msg);
                        self.bump();
                        self.recover(0);
                    }
                }
                _ => {
                    self.unexpected("a command");
                    self.bump();
                    self.recover(0);
                }
            }
        }
        let span = self.block_each(1, item);
        if !self.at(TokenKind::Eof) {
            let at = self.tok.span;
            let found = self.found();
            self.error(
                at,
                format!("expected end of file after the world block's `end`, found {found}"),
            );
        }
        (view, span)
    }

    /// A `begin ... end` block; the current token is `begin`; `depth` counts this block.
    fn block(&mut self, depth: usize) -> Block {
        let mut items = Vec::new();
        let span = self.block_each(depth, &mut |i| items.push(i));
        Block { items, span }
    }

    /// [`block`](Self::block), its items handed to `item` one by one; its span.
    fn block_each(&mut self, depth: usize, item: &mut dyn FnMut(Spanned<BodyItem>)) -> Span {
        let begin = self.bump();
        loop {
            match self.tok.kind {
                TokenKind::Eof => {
                    if !self.halted {
                        self.error(begin.span, "`begin` has no matching `end`");
                    }
                    break;
                }
                TokenKind::Ident if self.at_word("end") => {
                    self.bump();
                    break;
                }
                TokenKind::Ident if self.at_word("begin") => {
                    if depth >= MAX_NESTING {
                        let at = self.tok.span;
                        self.error(
                            at,
                            format!("blocks are nested deeper than {MAX_NESTING} levels"),
                        );
                        self.skip_block();
                    } else {
                        let inner = self.block(depth + 1);
                        let span = inner.span;
                        item(Spanned::new(BodyItem::Block(inner), span));
                    }
                    // `end;` is accepted as well as `end`.
                    self.eat(TokenKind::Semi);
                }
                TokenKind::Ident => {
                    if let Some(statement) = self.body_statement() {
                        item(statement);
                    }
                }
                _ => {
                    self.unexpected("a command or `end`");
                    self.bump();
                    self.recover(0);
                }
            }
        }
        self.span_from(begin.span)
    }

    /// Skips a whole `begin ... end` (with everything nested in it) without recursion.
    fn skip_block(&mut self) {
        let mut depth = 0usize;
        loop {
            match self.tok.kind {
                TokenKind::Eof => return,
                TokenKind::Ident if self.at_word("begin") => depth += 1,
                TokenKind::Ident if self.at_word("end") => {
                    depth -= 1;
                    if depth == 0 {
                        self.bump();
                        return;
                    }
                }
                _ => {}
            }
            self.bump();
        }
    }
}

#[cfg(test)]
mod tests;
