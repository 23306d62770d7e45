//! YARI ("Yet Another Rendering Interface", thesis section 2.3 and Appendix C): the scene
//! description language every part of SunRay speaks, and the tools around it.
//!
//! # Layout
//! - [`span`]: byte spans and source texts (line/column lookup).
//! - [`diag`]: diagnostics rendered as `file:line:col: error: ...` with a caret.
//! - [`ast`]: the syntax tree as written.
//! - [`model`]: the compiled world-space model a renderer loads.
//! - [`nff`], [`off`]: converters from NFF and OFF to the syntax tree (`nff2gfx`, `off2gfx`).

pub mod ast;
pub mod diag;
pub mod model;
pub mod span;
pub mod nff;
pub mod off;
