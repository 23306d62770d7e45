//! YARI ("Yet Another Rendering Interface", thesis section 2.3 and Appendix C): the scene
//! description language every part of SunRay speaks, and the tools around it.
//!
//! # Layout
//! - [`span`]: byte spans and source texts (line/column lookup).
//! - [`diag`]: diagnostics rendered as `file:line:col: error: ...` with a caret.
//! - [`ast`]: the syntax tree as written.
//! - [`model`]: the compiled world-space model a renderer loads, and the camera's view frame
//!   ([`model::Camera::frame`]) that the renderer and the POV-Ray export both use.
//! - [`lexer`]: the byte scanner (numbers, names, punctuation, quoted file names, `/* */`
//!   comments).
//! - [`lines`]: a text read once, line by line, checked as UTF-8 (the streaming readers').
//! - [`parse`]: the parser from source text to [`ast::Scene`], with error recovery.
//! - [`writer`]: the syntax tree (or a compiled world) printed back as YARI text.
//! - [`colour`]: named colours, built in and from a user file.
//! - [`cpu`]: the CPU features the build assumes, checked when a binary starts.
//! - [`compile`]: the compiler (`yc`) from [`ast::Scene`] to [`model::World`].
//! - [`modelfile`]: the compiled model in binary (`.srw`), for workers.
//! - [`load`]: any scene file (YARI, NFF, OFF, OBJ, PLY, model) to a compiled world.
//! - [`nff`], [`off`]: converters from NFF and OFF to the syntax tree (`nff2gfx`, `off2gfx`).
//! - [`mesh`]: today's mesh files (OBJ with MTL, PLY, glTF) as a stream of YARI polygons,
//!   framed on their own or placed by a YARI `mesh(file = ...)` statement.
//! - [`polygon`]: polygons cut into triangles, the same way for the renderer and the writers.
//! - [`pov`]: a compiled world written as POV-Ray 3.7 SDL, to compare with POV-Ray.
//! - [`spd`]: Haines's Standard Procedural Databases (`tetra`, `mount`, `balls`) and `check`
//!   checkerboards, generated as NFF scenes.
//!
//! The language (with our extensions), the compiler's rules and the model file format are
//! described in `docs/yari.md`.
//!
//! ```
//! use yari::{colour::ColourTable, compile::compile, parse::parse, span::Source};
//! let src = Source::new("s.yari", "begin attribute(color = red); sphere(center = 0,0,0; radius = 1); end");
//! let scene = parse(&src).expect("parses");
//! let compiled = compile(&scene, &ColourTable::builtin()).expect("compiles");
//! assert_eq!(compiled.world.features.spheres, 1);
//! assert_eq!(compiled.warnings.warnings().count(), 3); // no resolution, camera or light
//! ```

pub mod ast;
pub mod colour;
pub mod compile;
pub mod cpu;
pub mod diag;
pub mod lexer;
pub mod lines;
pub mod load;
pub mod mesh;
pub mod model;
pub mod modelfile;
pub mod nff;
pub mod off;
pub mod parse;
pub mod polygon;
pub mod pov;
pub mod span;
pub mod spd;
pub mod writer;

/// What the unit tests share: the thesis's printed examples, kept in the repository.
#[cfg(test)]
pub(crate) mod test_support {
    /// The text of `examples/thesis/NAME` (`tetra16.yari` or `cubes.yari`).
    pub fn thesis_example(name: &str) -> String {
        let path = format!("{}/../examples/thesis/{name}", env!("CARGO_MANIFEST_DIR"));
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
    }
}
