//! SunRay: a ray tracer with the Hall shading model (thesis chapter 3 and section 4.2), and
//! SunRay III, its distributed controller and workers over REM (section 4.2.4).
//!
//! # Layout
//! - [`cli`]: the `sunray` command's subcommands, each in its own module.

pub mod cli;
