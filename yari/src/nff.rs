//! NFF (Haines's Neutral File Format) to YARI: the thesis's `nff2gfx`.
//!
//! Reading is split from mapping so the SPD generators ([`crate::spd`]) can build the same
//! [`NffScene`] in code, print it in Haines's format ([`write()`]) or map it to YARI
//! ([`to_yari()`]). The mapping rules are in `docs/nff-mapping.md`.
//!
//! # Layout
//! - [`scene`]: the NFF entities as written ([`NffScene`], [`Entity`], [`Fill`], [`View`]).
//! - [`read`](mod@read): text to entities as a stream, with spanned diagnostics.
//! - `tokens`: the blank-separated words of a text as it is read.
//! - [`to_yari`](mod@to_yari): entities to the YARI syntax tree (the Hall-model mapping),
//!   whole or entity by entity ([`Mapping`]).
//! - [`cone`]: NFF cones and cylinders as clipped world-space quadrics.
//! - [`write`](mod@write): entities back to NFF text with C's `%g` number format.

pub mod cone;
pub mod read;
pub mod scene;
pub mod to_yari;
mod tokens;
pub mod write;

pub use read::{read, read_each};
pub use scene::{Entity, Fill, NffScene, View};
pub use to_yari::{to_yari, Mapping};
pub use write::write;

use crate::ast::Scene;
use crate::diag::Diagnostics;
use crate::span::Source;

/// Reads an NFF file into a YARI syntax tree (warnings are dropped; see [`parse_with_warnings`]).
pub fn parse(src: &Source) -> Result<Scene, Diagnostics> {
    parse_with_warnings(src).map(|(scene, _)| scene)
}

/// Reads an NFF file into a YARI syntax tree, returning the warnings with it.
pub fn parse_with_warnings(src: &Source) -> Result<(Scene, Diagnostics), Diagnostics> {
    let (nff, warnings) = read(src)?;
    Ok((to_yari(&nff), warnings))
}
