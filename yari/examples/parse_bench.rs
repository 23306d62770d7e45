//! Parse benchmark: generates a YARI file of N primitives (triangles and spheres, 3 to 1, in
//! blocks of 100 with their own attribute and transformation), writes it to a temporary
//! directory, and times reading, parsing, and parsing plus compiling it.
//!
//! ```text
//! cargo run --release -p yari --example parse_bench -- [PRIMITIVES]   (default 1000000)
//! ```
#![allow(clippy::unwrap_used, clippy::expect_used)] // a measurement tool: a failure ends it with a message

#[path = "support/scene_gen.rs"]
mod scene_gen;

use std::process::ExitCode;
use std::time::Instant;
use yari::colour::ColourTable;
use yari::span::Source;

fn main() -> ExitCode {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1_000_000);
    let text = scene_gen::big_scene(&mut scene_gen::Rng(42), n);
    let dir = std::env::temp_dir().join(format!("yari-bench-{}", std::process::id()));
    let path = dir.join("big.yari");
    if let Err(e) = std::fs::create_dir_all(&dir).and_then(|_| std::fs::write(&path, &text)) {
        eprintln!("cannot write {}: {e}", path.display());
        return ExitCode::FAILURE;
    }
    drop(text);
    let t = Instant::now();
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("cannot read {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    };
    let read = t.elapsed();
    println!(
        "{}: {n} primitives, {:.1} MB, read in {:.3} s",
        path.display(),
        text.len() as f64 / 1e6,
        read.as_secs_f64()
    );
    let t = Instant::now();
    let src = Source::new("big.yari", text);
    let lines = t.elapsed();
    let t = Instant::now();
    let mut lexer = yari::lexer::Lexer::new(&src.text);
    let mut tokens = 0usize;
    while lexer.next_token().kind != yari::lexer::TokenKind::Eof {
        tokens += 1;
    }
    println!(
        "lex only {:.3} s ({tokens} tokens)",
        t.elapsed().as_secs_f64()
    );
    let t = Instant::now();
    let scene = match yari::parse::parse(&src) {
        Ok(s) => s,
        Err(d) => {
            eprint!("{}", d.render(&src));
            return ExitCode::FAILURE;
        }
    };
    let parse = t.elapsed();
    let t = Instant::now();
    let compiled = match yari::compile::compile(&scene, &ColourTable::builtin()) {
        Ok(c) => c,
        Err(d) => {
            eprint!("{}", d.render(&src));
            return ExitCode::FAILURE;
        }
    };
    let compile = t.elapsed();
    let f = &compiled.world.features;
    println!("line index {:.3} s", lines.as_secs_f64());
    println!(
        "parse {:.3} s ({:.1} MB/s)",
        parse.as_secs_f64(),
        src.text.len() as f64 / 1e6 / parse.as_secs_f64()
    );
    println!(
        "compile {:.3} s; parse + compile {:.3} s -> {} polygons, {} spheres, {} surfaces, {} warnings",
        compile.as_secs_f64(),
        (parse + compile).as_secs_f64(),
        f.polygons,
        f.spheres,
        compiled.world.surfaces.len(),
        compiled.warnings.items.len()
    );
    let t = Instant::now();
    let bytes = match yari::modelfile::to_bytes(&compiled.world) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::FAILURE;
        }
    };
    let save = t.elapsed();
    let t = Instant::now();
    let ok = yari::modelfile::from_bytes(&bytes)
        .map(|w| w == compiled.world)
        .unwrap_or(false);
    println!(
        "model file {:.1} MB: encode {:.3} s, decode {:.3} s{}",
        bytes.len() as f64 / 1e6,
        save.as_secs_f64(),
        t.elapsed().as_secs_f64(),
        if ok { "" } else { " (MISMATCH)" }
    );
    let _ = std::fs::remove_dir_all(&dir);
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
