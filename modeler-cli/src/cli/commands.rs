//! The command line, as clap derive types. The same `Command` parser reads the command
//! line and each line of a script.

use super::args;
use crate::preview::Style;
use crate::project::{Color, V3};
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

pub(crate) use super::shape_args::*;

/// The default project file.
pub const DEFAULT_PROJECT: &str = "scene.modeler.json";

/// The whole `modeler` command line: the project file and one command (parse it with clap's
/// [`Parser`], run it with [`super::run`]).
#[derive(Parser, Debug)]
#[command(
    name = "modeler",
    version,
    about = "Build YARI scenes step by step: skeletons, primitives, revolve, extrude, grouping, previews",
    after_help = "Every command reads and writes the project file (see --project). A failed command leaves it unchanged.\n\
                  Tutorial: docs/modeler.md"
)]
pub struct Cli {
    /// The project file (JSON).
    #[arg(short, long, global = true, env = "MODELER_PROJECT", default_value = DEFAULT_PROJECT)]
    pub(crate) project: PathBuf,
    #[command(subcommand)]
    pub(crate) command: Command,
}

/// One line of a script: a command without the program name or `--project`.
#[derive(Parser, Debug)]
#[command(name = "modeler", no_binary_name = true, disable_version_flag = true)]
pub(crate) struct ScriptLine {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub(crate) enum Command {
    /// Start a new project: 512x512, camera at 0,0,10 looking at the origin, one white light.
    New(NewArgs),
    /// Open a YARI file as a new project (object and light names from its comments).
    Import(ImportArgs),
    /// Write the scene as YARI (each object a block, its name in a comment before it).
    Export(ExportArgs),
    /// Draw the front, top, side and perspective views into one PNG.
    Preview(PreviewArgs),
    /// List the project, or describe one object or skeleton.
    Show(ShowArgs),
    /// Skeletons: points, line segments and Bézier curves in a principal plane.
    #[command(subcommand)]
    Skeleton(SkeletonCmd),
    /// Create a primitive object (sphere, polygon, quadric).
    #[command(subcommand)]
    Add(AddCmd),
    /// Combine objects into a new composite object.
    Combine(CombineArgs),
    /// Explode a composite into its parts (or a part into one object per primitive).
    Explode(NameArg),
    /// Sweep a profile skeleton around a principal axis: a closed surface of revolution.
    Revolve(RevolveArgs),
    /// Pull an outline skeleton along a vector: a closed, capped solid.
    Extrude(ExtrudeArgs),
    /// Move an object (and everything in it) by x,y,z in world space.
    Translate(TranslateArgs),
    /// Rotate an object by x,y,z degrees (about x, then y, then z), about a pivot.
    Rotate(RotateArgs),
    /// Scale an object by one factor or sx,sy,sz, about a pivot.
    Scale(ScaleArgs),
    /// Set surface properties of an object (what is not given stays as it was).
    Surface(SurfaceArgs),
    /// Rename an object.
    Rename(RenameArgs),
    /// Copy an object (and everything in it) to a new top-level object.
    Copy(RenameArgs),
    /// Delete an object (and everything in it).
    Delete(NameArg),
    /// Set the camera (fields not given stay as they were).
    Camera(CameraArgs),
    /// Set where the preview's perspective view looks from (the editor's view location).
    View(ViewArgs),
    /// Lights: create, move, colour, delete.
    #[command(subcommand)]
    Light(LightCmd),
    /// Set the background colour.
    Background(ColorArg),
    /// Set the ambient light colour.
    Ambient(ColorArg),
    /// Set the image resolution.
    Resolution(ResolutionArgs),
    /// Set the samples per pixel (a YARI extension; 1 = one ray per pixel).
    Samples(SamplesArgs),
    /// Run commands from a file (or - for standard input), one per line; all or nothing.
    Script(ScriptArgs),
}

#[derive(Args, Debug)]
pub(crate) struct NewArgs {
    /// Replace an existing project file.
    #[arg(long)]
    pub force: bool,
    /// Start with no camera, lights, background or ambient.
    #[arg(long)]
    pub empty: bool,
}

#[derive(Args, Debug)]
pub(crate) struct ImportArgs {
    /// The YARI file to open.
    pub file: PathBuf,
    /// Replace an existing project file.
    #[arg(long)]
    pub force: bool,
}

#[derive(Args, Debug)]
pub(crate) struct ExportArgs {
    /// Output file; - or nothing writes to standard output.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub(crate) struct PreviewArgs {
    /// Output PNG.
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(long, value_enum, default_value = "flat")]
    pub style: Style,
    /// Width and height of each view in pixels (the image is about twice this).
    #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u32).range(16..=4096))]
    pub size: u32,
}

#[derive(Args, Debug)]
pub(crate) struct ShowArgs {
    /// An object or skeleton to describe in full.
    pub name: Option<String>,
}

#[derive(Args, Debug)]
pub(crate) struct TranslateArgs {
    pub name: String,
    #[arg(value_parser = args::vec3, allow_hyphen_values = true)]
    pub by: V3,
}

#[derive(Args, Debug)]
pub(crate) struct RotateArgs {
    pub name: String,
    /// Degrees about x, y and z.
    #[arg(value_parser = args::vec3, allow_hyphen_values = true)]
    pub degrees: V3,
    /// The fixed point (default: the origin).
    #[arg(long, value_parser = args::vec3, allow_hyphen_values = true)]
    pub about: Option<V3>,
}

#[derive(Args, Debug)]
pub(crate) struct ScaleArgs {
    pub name: String,
    /// One factor, or sx,sy,sz.
    #[arg(value_parser = args::scale3, allow_hyphen_values = true)]
    pub factors: V3,
    /// The fixed point (default: the origin).
    #[arg(long, value_parser = args::vec3, allow_hyphen_values = true)]
    pub about: Option<V3>,
}

#[derive(Args, Debug)]
pub(crate) struct SurfaceArgs {
    pub name: String,
    /// A colour name or r,g,b.
    #[arg(long, value_parser = args::color, allow_hyphen_values = true)]
    pub color: Option<Color>,
    /// Diffuse reflection (0 = mirror, 1 = matte).
    #[arg(long)]
    pub kdr: Option<f64>,
    /// Diffuse transmission (0 = clear, 1 = opaque).
    #[arg(long)]
    pub kdt: Option<f64>,
    /// Ambient coefficient.
    #[arg(long)]
    pub ka: Option<f64>,
    /// Phong exponent of highlights.
    #[arg(long)]
    pub phong: Option<f64>,
    /// Index of refraction.
    #[arg(long)]
    pub refract: Option<f64>,
    /// "NAME-or-ID r,g,b sx,sy,sz" (colour and scale optional; names: wood, marble, bumps,
    /// turbulence, checker), or none.
    #[arg(long, value_parser = args::texture_spec)]
    pub texture: Option<args::TextureSpec>,
    /// Drop the object's own surface so it inherits its group's (before other settings).
    #[arg(long)]
    pub inherit: bool,
}

#[derive(Args, Debug)]
pub(crate) struct RenameArgs {
    pub old: String,
    pub new: String,
}

#[derive(Args, Debug)]
pub(crate) struct CameraArgs {
    #[arg(long, value_parser = args::vec3, allow_hyphen_values = true)]
    pub position: Option<V3>,
    #[arg(long, value_parser = args::vec3, allow_hyphen_values = true)]
    pub at: Option<V3>,
    #[arg(long, value_parser = args::vec3, allow_hyphen_values = true)]
    pub up: Option<V3>,
    /// Half angle of view in degrees (YARI's `angle`).
    #[arg(long)]
    pub angle: Option<f64>,
}

#[derive(Args, Debug)]
pub(crate) struct ViewArgs {
    #[arg(long, value_parser = args::vec3, allow_hyphen_values = true)]
    pub from: Option<V3>,
    #[arg(long, value_parser = args::vec3, allow_hyphen_values = true)]
    pub at: Option<V3>,
    #[arg(long, value_parser = args::vec3, allow_hyphen_values = true)]
    pub up: Option<V3>,
    /// Half angle of view in degrees.
    #[arg(long)]
    pub angle: Option<f64>,
    /// Go back to looking through the camera.
    #[arg(long, conflicts_with_all = ["from", "at", "up", "angle"])]
    pub camera: bool,
}

#[derive(Subcommand, Debug)]
pub(crate) enum LightCmd {
    /// Create a light.
    Add(LightAddArgs),
    /// Move a light.
    Move(LightMoveArgs),
    /// Set a light's colour.
    Color(LightColorArgs),
    /// Delete a light.
    Delete(NameArg),
}

#[derive(Args, Debug)]
pub(crate) struct LightAddArgs {
    pub name: String,
    #[arg(long, value_parser = args::vec3, allow_hyphen_values = true)]
    pub position: V3,
    #[arg(long, value_parser = args::color, default_value = "1,1,1")]
    pub color: Color,
    /// Radius of a spherical area light (a YARI extension).
    #[arg(long)]
    pub radius: Option<f64>,
}

#[derive(Args, Debug)]
pub(crate) struct LightMoveArgs {
    pub name: String,
    #[arg(value_parser = args::vec3, allow_hyphen_values = true)]
    pub position: V3,
}

#[derive(Args, Debug)]
pub(crate) struct LightColorArgs {
    pub name: String,
    #[arg(value_parser = args::color)]
    pub color: Color,
}

#[derive(Args, Debug)]
pub(crate) struct ColorArg {
    /// A colour name or r,g,b.
    #[arg(value_parser = args::color)]
    pub color: Color,
}

#[derive(Args, Debug)]
pub(crate) struct ResolutionArgs {
    #[arg(value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub width: u32,
    #[arg(value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub height: u32,
}

#[derive(Args, Debug)]
pub(crate) struct SamplesArgs {
    #[arg(value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub samples: u32,
}

#[derive(Args, Debug)]
pub(crate) struct ScriptArgs {
    /// The script file, or - for standard input.
    pub file: PathBuf,
}
