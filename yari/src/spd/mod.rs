//! Haines's Standard Procedural Databases (the thesis's test images) and the thesis's `check`
//! checkerboards, generated as [`NffScene`]s: print them with [`crate::nff::write()`] or map
//! them to YARI with [`crate::nff::to_yari()`].
//!
//! The generators follow Haines's C programs step for step (his matrix conventions, recursion
//! order and random numbers), so `tetra(6)`, `mount(6)` and `balls(4)` reproduce the
//! reference files `tetra6.nff`, `mount6.nff` and `balls4.nff`.
//!
//! # Layout
//! - [`haines_lib`]: the matrix routines and Gaussian random numbers of Haines's `libvec.c`.
//! - [`tetra`]: the recursive tetrahedron.
//! - [`mount`]: the fractal mountain and its four glass spheres.
//! - [`balls`]: the sphereflake on a floor polygon.
//! - [`checkerboard`](mod@checkerboard): checkerboards of polygons (`check`).

pub mod balls;
pub mod checkerboard;
pub mod haines_lib;
pub mod mount;
pub mod tetra;

pub use checkerboard::{checkerboard, CheckerboardError, CheckerboardOptions};

use crate::ast::Vec3;
use crate::nff::NffScene;

/// The SPD background, "UNC sky blue" (thesis Fig. 2.1's `UNC_Blue`).
pub const UNC_SKY_BLUE: Vec3 = [0.078, 0.361, 0.753];

/// One of the SPD scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Database {
    /// The recursive tetrahedron of triangles (thesis Fig. 2.1 is its YARI form).
    Tetra,
    /// The fractal mountain with four glass spheres.
    Mount,
    /// The sphereflake on a floor polygon.
    Balls,
}

impl Database {
    /// Haines's default size factor (the reference files' sizes).
    pub fn default_size(self) -> u32 {
        match self {
            Database::Tetra | Database::Mount => 6,
            Database::Balls => 4,
        }
    }

    /// The sizes accepted: bounded by Haines's hash (mount) and by output size.
    pub fn sizes(self) -> std::ops::RangeInclusive<u32> {
        match self {
            Database::Tetra => 1..=12,
            Database::Mount => 0..=mount::MAX_SIZE,
            Database::Balls => 0..=6,
        }
    }

    /// The command-line and file name: `tetra`, `mount` or `balls`.
    pub fn name(self) -> &'static str {
        match self {
            Database::Tetra => "tetra",
            Database::Mount => "mount",
            Database::Balls => "balls",
        }
    }
}

/// A size outside [`Database::sizes`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("size {size} is out of range for `{name}` (allowed {min} to {max})")]
pub struct SizeError {
    /// The database, as [`Database::name`].
    pub name: &'static str,
    /// The size asked for.
    pub size: u32,
    /// The smallest size allowed.
    pub min: u32,
    /// The largest size allowed.
    pub max: u32,
}

/// Generates `db` at `size`.
pub fn generate(db: Database, size: u32) -> Result<NffScene, SizeError> {
    let range = db.sizes();
    if !range.contains(&size) {
        return Err(SizeError {
            name: db.name(),
            size,
            min: *range.start(),
            max: *range.end(),
        });
    }
    Ok(match db {
        Database::Tetra => tetra::tetra(size),
        Database::Mount => mount::mount(size),
        Database::Balls => balls::balls(size),
    })
}

/// Haines's reference files: every database at its default size.
pub const REFERENCE_SET: [Database; 3] = [Database::Tetra, Database::Mount, Database::Balls];

/// The name of `db`'s reference file: `tetra6.nff`, `mount6.nff`, `balls4.nff`.
pub fn reference_file_name(db: Database) -> String {
    format!("{}{}.nff", db.name(), db.default_size())
}

/// Writes Haines's reference files (the [`REFERENCE_SET`] as NFF, byte for byte what his
/// generators write) into `dir`, each under a temporary name and then renamed, so processes
/// doing the same at once never see half a file.
pub fn write_reference_files(dir: &std::path::Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    for db in REFERENCE_SET {
        let scene = generate(db, db.default_size()).map_err(std::io::Error::other)?;
        let name = reference_file_name(db);
        let tmp = dir.join(format!("{name}.{}", std::process::id()));
        std::fs::write(&tmp, crate::nff::write(&scene))?;
        std::fs::rename(&tmp, dir.join(name))?;
    }
    Ok(())
}

#[cfg(test)]
mod reference_tests;
