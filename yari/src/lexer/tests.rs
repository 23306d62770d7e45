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

/// Every token of `text` (kind, span, value) and every error, from a streaming lexer
/// reading `step` bytes at a time that is told to keep from each token after a `;`; and
/// the widest its window grew.
fn lex_streamed(text: &str, step: usize) -> (Vec<Token>, Vec<Diagnostic>, usize) {
    let mut lines = crate::lines::TextLines::new(text.as_bytes());
    let mut l = Lexer::streaming_in_steps(&mut lines, step);
    let (mut tokens, mut widest) = (Vec::new(), 0);
    let mut after_semi = false;
    loop {
        let t = l.next_token();
        widest = widest.max(l.window());
        if after_semi {
            l.keep_from(t.span.start as usize);
        }
        after_semi = t.kind == TokenKind::Semi;
        if t.kind == TokenKind::Eof {
            break;
        }
        tokens.push(t);
    }
    (tokens, l.take_errors(), widest)
}

fn lex_whole(text: &str) -> (Vec<Token>, Vec<Diagnostic>) {
    let mut l = Lexer::new(text);
    let mut tokens = Vec::new();
    loop {
        let t = l.next_token();
        if t.kind == TokenKind::Eof {
            return (tokens, l.take_errors());
        }
        tokens.push(t);
    }
}

#[test]
fn a_streamed_text_gives_the_tokens_of_the_whole_text() {
    let text = "\u{feff}camera( /* a\n comment over\n *\n lines */ at = 1e3 ;)\r\n\
                polygon(vertices = 3; 0,0,0 1,0,0 0,1,0); /* * */ 3x @ -.5\n\
                /* open at the end\n";
    for cut in 0..=text.len() {
        if !text.is_char_boundary(cut) {
            continue;
        }
        let part = &text[..cut];
        for step in [1, 7, 1 << 16] {
            let (tokens, errors, _) = lex_streamed(part, step);
            assert_eq!((tokens, errors), lex_whole(part), "cut {cut} step {step}");
        }
    }
}

#[test]
fn a_streamed_text_is_held_in_a_small_window() {
    let line = "polygon(vertices = 3; 0,0,0 1,0,0 0,1,0); /* c */\n";
    let text = line.repeat(20_000);
    let (tokens, errors, widest) = lex_streamed(&text, 256);
    assert!(errors.is_empty());
    assert_eq!(tokens.len(), 20_000 * 23);
    assert_eq!(tokens, lex_whole(&text).0);
    assert!(widest < 4 * 256, "the window grew to {widest} bytes");
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

#[test]
fn strings_are_quoted_on_one_line() {
    let text = "mesh(file = \"models/statue 2.ply\"; x = \"\")";
    let mut l = Lexer::new(text);
    let mut strings = Vec::new();
    loop {
        let t = l.next_token();
        match t.kind {
            TokenKind::Eof => break,
            TokenKind::String => strings.push(l.string(t.span).to_string()),
            _ => {}
        }
    }
    assert!(!l.has_errors());
    assert_eq!(strings, ["models/statue 2.ply", ""]);
    // No closing quote before the line ends: one error, and the next line lexes on.
    let (toks, errs) = lex("\"statue.ply\n)");
    assert_eq!(
        errs,
        ["unterminated string: `\"` has no closing `\"` on its line"]
    );
    assert_eq!(toks.last().map(|t| t.0), Some(TokenKind::RParen));
}
