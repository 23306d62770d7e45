//! `sunray spd tetra|mount|balls|gears|rings|tree|teapot|lattice|shells|jacks|sombrero
//! [--size N] [--patches [--patch-resolution N]] [-o OUT]`: Haines's Standard Procedural
//! Databases, generated exactly as his programs do (`tetra 6`, `mount 6` and `balls 4` equal
//! the reference files; every database prints his program's NFF text, and with `--patches`
//! the text his programs print with `-t`). `.nff` output is Haines's own text; `.obj` and
//! `.ply` a mesh of the scene's polygons (docs/meshes.md); anything else (and stdout) is YARI.

use super::convert::{output_format, render_scene, write_bytes, OutputFormat};
use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use yari::spd::{generate_with, CurveFormat, Database};

/// Generate one of Haines's SPD scenes.
#[derive(Args, Debug)]
pub struct SpdArgs {
    /// Which database.
    #[arg(value_parser = database_names())]
    pub(crate) database: Database,
    /// Haines's size factor (default: tetra 6, mount 6, balls 4, gears 4, rings 7, tree 11,
    /// teapot 6, lattice 12, shells 5, jacks 1, sombrero 1; allowed: tetra 1 to 12, which is
    /// 4^size triangles, mount 0 to 7, balls 0 to 6, gears 1 to 25, rings 1 to 60, tree 1 to
    /// 20, teapot 1 to 200, lattice 1 to 100, shells 1 to 14, jacks 1 to 7, sombrero 1 to 6).
    #[arg(short, long)]
    pub size: Option<u32>,
    /// Write every sphere, cylinder and cone as polygonal patches, as Haines's programs do
    /// with `-t`: `pp` triangles with vertex normals (rendered smooth), 12 R^2 triangles a
    /// sphere (a cube projected onto it, R x R quads a face) and 8 R a cylinder or cone side
    /// (4 R slices), R being the patch resolution (his: 3, so 108 and 24; jacks 2). Changes
    /// balls, mount, rings, tree, lattice, shells and jacks; at most 5 million triangles.
    #[arg(long)]
    pub patches: bool,
    /// The patch resolution R of `--patches`, for every database (his `-t R`; 1 to 100;
    /// default his programs' own, 3, and 2 for jacks).
    #[arg(long, value_name = "R", requires = "patches")]
    pub patch_resolution: Option<u32>,
    /// Where to write (`.nff` for NFF, `.obj` for OBJ, `.ply` for binary PLY, `.glb` for binary
    /// glTF, else YARI;
    /// default: YARI on stdout). A mesh holds the scene's polygons only.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Force the output format regardless of the extension.
    #[arg(long, value_enum)]
    pub(crate) format: Option<OutputFormat>,
}

/// The databases `sunray spd` generates, by their names in `yari::spd` (listed in the help).
fn database_names() -> impl TypedValueParser<Value = Database> {
    PossibleValuesParser::new(Database::ALL.map(Database::name))
        .try_map(|name: String| Database::from_name(&name).ok_or("not a database"))
}

/// Generates the database and writes it (or prints it on stdout).
pub fn run(args: SpdArgs) -> anyhow::Result<ExitCode> {
    let db = args.database;
    let curves = if args.patches {
        CurveFormat::Patches {
            resolution: args.patch_resolution,
        }
    } else {
        CurveFormat::Curves
    };
    let scene = generate_with(db, args.size.unwrap_or(db.default_size()), curves)?;
    let format = output_format(args.format, args.output.as_deref());
    write_bytes(args.output.as_deref(), &render_scene(&scene, format)?)?;
    Ok(ExitCode::SUCCESS)
}
