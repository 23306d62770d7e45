//! Haines's Standard Procedural Databases (the thesis's test images) and the thesis's `check`
//! checkerboards, generated as [`NffScene`]s: print them with [`crate::nff::write()`] or map
//! them to YARI with [`crate::nff::to_yari()`].
//!
//! The generators follow Haines's C programs step for step (his matrix conventions, recursion
//! order and random numbers), so `tetra(6)`, `mount(6)` and `balls(4)` reproduce the
//! reference files `tetra6.nff`, `mount6.nff` and `balls4.nff`, and every database prints,
//! at every size tested, the NFF text his program prints. [`generate_with`] also writes them
//! as his programs do with `-t` ([`CurveFormat::PATCHES`]): every sphere, cylinder and cone as
//! `pp` triangles with vertex normals, again byte for byte his text.
//!
//! # Layout
//! - [`haines_lib`]: the matrix routines and Gaussian random numbers of Haines's `libvec.c`.
//! - [`haines_output`]: his library's output routines (colour, polygon, sphere,
//!   cylinder/cone, transformation stack), NFF branch.
//! - [`haines_patches`]: his polygonal patch output: one patch (`lib_output_polypatch`), and
//!   spheres and cylinders/cones as patches (`-t`).
//! - [`tetra`]: the recursive tetrahedron.
//! - [`mount`]: the fractal mountain and its four glass spheres.
//! - [`balls`]: the sphereflake on a floor polygon.
//! - [`gears`]: the cube of meshed gears, some transparent.
//! - [`rings`]: the pyramid of six-ring objects (cylinders and spheres) before a wall.
//! - [`tree`]: Aono and Kunii's tree of cones and spheres.
//! - [`teapot`]: the Bezier teapot as `pp` triangles on a checkerboard.
//! - [`lattice`]: spheres joined by cylinders on a cubic grid.
//! - [`shells`]: Pickover's sea shell of spheres.
//! - [`jacks`]: recursive jacks (cylinders and spheres).
//! - [`sombrero`]: a height field of triangles.
//! - [`checkerboard`](mod@checkerboard): checkerboards of polygons (`check`).

pub mod balls;
pub mod checkerboard;
pub mod gears;
pub mod haines_lib;
pub mod haines_output;
pub mod haines_patches;
pub mod jacks;
pub mod lattice;
pub mod mount;
pub mod rings;
pub mod shells;
pub mod sombrero;
pub mod teapot;
pub mod tetra;
pub mod tree;

pub use checkerboard::{checkerboard, CheckerboardError, CheckerboardOptions};
pub use haines_output::{CurveFormat, DEFAULT_RESOLUTION};

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
    /// The cube of meshed gears (144-vertex faces), some transparent, on a mirror floor.
    Gears,
    /// The pyramid of objects of six pentagonal rings (cylinders and spheres).
    Rings,
    /// The tree of cones and spheres over a field.
    Tree,
    /// The teapot as `pp` triangles with normals, on a checkerboard.
    Teapot,
    /// Spheres joined by cylinders on a cubic grid.
    Lattice,
    /// The sea shell: a spiral of overlapping spheres.
    Shells,
    /// Recursive jacks of cylinders and spheres.
    Jacks,
    /// The sombrero height field, as triangles.
    Sombrero,
}

impl Database {
    /// Every database, in Haines's order (the original seven, then the extras).
    pub const ALL: [Database; 11] = [
        Database::Balls,
        Database::Gears,
        Database::Mount,
        Database::Rings,
        Database::Teapot,
        Database::Tetra,
        Database::Tree,
        Database::Lattice,
        Database::Shells,
        Database::Jacks,
        Database::Sombrero,
    ];

    /// Haines's default size factor (the size his program uses without `-s`).
    pub fn default_size(self) -> u32 {
        match self {
            Database::Tetra | Database::Mount | Database::Teapot => 6,
            Database::Balls | Database::Gears => 4,
            Database::Rings => 7,
            Database::Tree => 11,
            Database::Lattice => 12,
            Database::Shells => 5,
            Database::Jacks | Database::Sombrero => 1,
        }
    }

    /// The sizes accepted: bounded by Haines's hash (mount) and by output size. The new
    /// databases stop at about 5 million primitives or less (their NFF text then runs to a
    /// few hundred MB):
    /// - gears 1 to 25: size^3 gears of 146 polygons (2.3M polygons at 25);
    /// - rings 1 to 60: 5 size (size+1)(2 size+1) cylinders and as many spheres (4.4M at 60);
    /// - tree 1 to 20: 2^(size+1) - 1 cones and as many spheres (4.2M at 20);
    /// - teapot 1 to 200: about 65 size^2 triangles and squares (2.6M at 200);
    /// - lattice 1 to 100: (size+1)^3 spheres, 3 size (size+1)^2 cylinders (4.1M at 100);
    /// - shells 1 to 14: 180 * 2^size + 1 spheres (2.9M at 14);
    /// - jacks 1 to 7: 9 (8^size - 1) / 7 cylinders and spheres (2.7M at 7);
    /// - sombrero 1 to 6: 2 (32 * 2^(size-1) - 1)^2 triangles (2.1M at 6).
    pub fn sizes(self) -> std::ops::RangeInclusive<u32> {
        match self {
            Database::Tetra => 1..=12,
            Database::Mount => 0..=mount::MAX_SIZE,
            Database::Balls => 0..=6,
            Database::Gears => 1..=25,
            Database::Rings => 1..=60,
            Database::Tree => 1..=20,
            Database::Teapot => 1..=200,
            Database::Lattice => 1..=100,
            Database::Shells => 1..=14,
            Database::Jacks => 1..=7,
            Database::Sombrero => 1..=6,
        }
    }

    /// The command-line and file name: `tetra`, `mount`, `balls`, `gears`, `rings`, `tree`,
    /// `teapot`, `lattice`, `shells`, `jacks` or `sombrero` (Haines's program names).
    pub fn name(self) -> &'static str {
        match self {
            Database::Tetra => "tetra",
            Database::Mount => "mount",
            Database::Balls => "balls",
            Database::Gears => "gears",
            Database::Rings => "rings",
            Database::Tree => "tree",
            Database::Teapot => "teapot",
            Database::Lattice => "lattice",
            Database::Shells => "shells",
            Database::Jacks => "jacks",
            Database::Sombrero => "sombrero",
        }
    }

    /// Whether the database has spheres, cylinders or cones, so that patches
    /// ([`CurveFormat::Patches`]) change it: all but `tetra`, `gears`, `teapot` and
    /// `sombrero`.
    pub fn has_curves(self) -> bool {
        !matches!(
            self,
            Database::Tetra | Database::Gears | Database::Teapot | Database::Sombrero
        )
    }

    /// The patch resolution his program uses with `-t` ([`CurveFormat::PATCHES`]): 2 for
    /// `jacks` (it sets its own), else [`DEFAULT_RESOLUTION`] (3).
    pub fn patch_resolution(self) -> u32 {
        match self {
            Database::Jacks => jacks::RESOLUTION,
            _ => DEFAULT_RESOLUTION,
        }
    }

    /// The database called `name` (as [`Database::name`] gives it), if any.
    pub fn from_name(name: &str) -> Option<Database> {
        Database::ALL.into_iter().find(|d| d.name() == name)
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

/// Generates `db` at `size` (his default output: spheres, cylinders and cones as curves).
pub fn generate(db: Database, size: u32) -> Result<NffScene, SizeError> {
    check_size(db, size)?;
    Ok(build(db, size, CurveFormat::Curves))
}

/// The largest resolution [`generate_with`] accepts for [`CurveFormat::Patches`] (a sphere is
/// then 120,000 triangles).
pub const MAX_RESOLUTION: u32 = 100;

/// The most triangles [`generate_with`] writes in [`CurveFormat::Patches`] (about 900 MB of
/// NFF text), as the sizes keep the curved databases to about 5 million primitives.
pub const MAX_PATCH_TRIANGLES: u64 = 5_000_000;

/// Why [`generate_with`] refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GenerateError {
    /// The size is out of [`Database::sizes`].
    #[error(transparent)]
    Size(#[from] SizeError),
    /// The patch resolution is 0 or above [`MAX_RESOLUTION`].
    #[error("patch resolution {resolution} is out of range (allowed 1 to {MAX_RESOLUTION})")]
    Resolution {
        /// The resolution asked for.
        resolution: u32,
    },
    /// The database in patches would have more than [`MAX_PATCH_TRIANGLES`] polygons.
    #[error(
        "`{name}` at size {size} in patches (resolution {resolution}) would be {polygons} \
         polygons, more than the {MAX_PATCH_TRIANGLES} allowed; choose a smaller size"
    )]
    TooLarge {
        /// The database, as [`Database::name`].
        name: &'static str,
        /// The size asked for.
        size: u32,
        /// The patch resolution asked for.
        resolution: u32,
        /// The polygons it would have (triangles, plus any polygons of the database).
        polygons: u64,
    },
}

/// Generates `db` at `size` with its spheres, cylinders and cones written as `format` says:
/// [`CurveFormat::Curves`] is [`generate`]; [`CurveFormat::Patches`] is Haines's `-t [N]`
/// output (for `tetra`, `gears`, `teapot` and `sombrero`, which have no curved primitives,
/// the same as [`generate`]). Patches are refused beyond [`MAX_PATCH_TRIANGLES`] polygons.
pub fn generate_with(
    db: Database,
    size: u32,
    format: CurveFormat,
) -> Result<NffScene, GenerateError> {
    check_size(db, size)?;
    if let CurveFormat::Patches { resolution } = format {
        let resolution = resolution.unwrap_or(db.patch_resolution());
        if !(1..=MAX_RESOLUTION).contains(&resolution) {
            return Err(GenerateError::Resolution { resolution });
        }
        let (spheres, polygons, cones) = build(db, size, CurveFormat::Curves).counts();
        let r = u64::from(resolution);
        let polygons = polygons as u64 + spheres as u64 * 12 * r * r + cones as u64 * 8 * r;
        if polygons > MAX_PATCH_TRIANGLES {
            return Err(GenerateError::TooLarge {
                name: db.name(),
                size,
                resolution,
                polygons,
            });
        }
    }
    Ok(build(db, size, format))
}

/// Refuses a size outside [`Database::sizes`].
fn check_size(db: Database, size: u32) -> Result<(), SizeError> {
    let range = db.sizes();
    if range.contains(&size) {
        Ok(())
    } else {
        Err(SizeError {
            name: db.name(),
            size,
            min: *range.start(),
            max: *range.end(),
        })
    }
}

/// The generator of `db`, size already checked.
fn build(db: Database, size: u32, format: CurveFormat) -> NffScene {
    match db {
        Database::Tetra => tetra::tetra(size),
        Database::Mount => mount::mount(size, format),
        Database::Balls => balls::balls(size, format),
        Database::Gears => gears::gears(size),
        Database::Rings => rings::rings(size, format),
        Database::Tree => tree::tree(size, format),
        Database::Teapot => teapot::teapot(size),
        Database::Lattice => lattice::lattice(size, format),
        Database::Shells => shells::shells(size, format),
        Database::Jacks => jacks::jacks(size, format),
        Database::Sombrero => sombrero::sombrero(size),
    }
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
#[cfg(test)]
mod reference_tests_patches;
#[cfg(test)]
mod reference_tests_rest;
