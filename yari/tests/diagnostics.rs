//! The exact text of the messages a user sees for common mistakes.

use yari::colour::ColourTable;
use yari::load::{load_str, InputKind};

const VIEW: &str = "resolution(8,8); camera(position=0,0,5; at=0,0,0; up=0,1,0; angle=20); light(position=0,5,0; color=white);\n";

fn message(text: &str) -> String {
    match load_str("t.yari", text, InputKind::Yari, &ColourTable::builtin()) {
        Ok(_) => panic!("expected an error for {text:?}"),
        Err(e) => format!("{e}\n"),
    }
}

#[test]
fn unknown_command() {
    assert_eq!(
        message(&format!("{VIEW}begin\n  sphre(center=0,0,0; radius=1);\nend\n")),
        "t.yari:3:3: error: unknown command `sphre`\n    sphre(center=0,0,0; radius=1);\n    ^~~~~\n"
    );
}

#[test]
fn missing_semicolon() {
    assert_eq!(
        message(&format!("{VIEW}begin\n  sphere(center=0,0,0; radius=1)\n  sphere(center=1,0,0; radius=1);\nend\n")),
        "t.yari:3:33: error: expected `;` after `sphere(...)`, found `sphere`\n    sphere(center=0,0,0; radius=1)\n                                  ^\n"
    );
}

#[test]
fn wrong_vertex_count() {
    assert_eq!(
        message(&format!("{VIEW}begin\n  polygon(vertices=4; 0,0,0 1,0,0 0,1,0);\nend\n")),
        "t.yari:3:20: error: polygon declares 4 vertices but lists 3\n    polygon(vertices=4; 0,0,0 1,0,0 0,1,0);\n                     ^\n"
    );
}

#[test]
fn unknown_colour_name() {
    assert_eq!(
        message(&format!("{VIEW}begin\n  attribute(color = reed);\nend\n")),
        "t.yari:3:21: error: unknown colour name `reed`; did you mean `red`?\n    attribute(color = reed);\n                      ^~~~\n"
    );
}

#[test]
fn unterminated_comment() {
    assert_eq!(
        message(&format!("{VIEW}begin\n/* open\nend\n")),
        "t.yari:3:1: error: unterminated comment: `/*` has no closing `*/`\n  /* open\n  ^~\n\
         t.yari:2:1: error: `begin` has no matching `end`\n  begin\n  ^~~~~\n"
    );
}

#[test]
fn nesting_deeper_than_the_bound() {
    let depth = yari::parse::MAX_NESTING + 1;
    let text = format!("{VIEW}{}{}", "begin\n".repeat(depth), "end\n".repeat(depth));
    assert_eq!(
        message(&text),
        format!(
            "t.yari:{}:1: error: blocks are nested deeper than 256 levels\n  begin\n  ^~~~~\n",
            depth + 1
        )
    );
}
