//! modeler: the command-line successor of the thesis's "Scene" editor (section 2.4). A scene
//! is edited step by step (or rebuilt from a script) in a project file that keeps names and
//! structure, previewed in the editor's four views, and exported as plain YARI.
//!
//! # Layout
//! - [`project`]: the project (settings, skeletons, object tree), saved atomically as JSON.
//! - `error`: typed errors and name rules.
//! - `skeleton`: points, line segments and Bézier curves in a principal plane.
//! - [`mesh`]: polygon meshes and the closed/oriented checks.
//! - [`mesh_files`]: where a project's mesh files are (relative to the project's folder).
//! - `sweep`: revolve (surfaces of revolution) and extrude.
//! - `tree`: the object tree; combine, explode, copy, world-space transformations.
//! - [`export`]: project to YARI (names as comments).
//! - `import`: YARI to project (names from comments).
//! - [`cli`]: the `modeler` command: subcommands, script mode, listing.
//! - [`preview`]: the four views as one PNG, wireframe or flat shaded (z-buffer).

pub mod cli;
mod error;
pub mod export;
mod import;
pub mod mesh;
pub mod mesh_files;
pub mod preview;
pub mod project;
mod skeleton;
mod sweep;
mod tree;
