//! The arguments of the commands that build geometry: skeletons, primitives, revolve and
//! extrude, and the one-name argument that they share with the object commands (all
//! re-exported by [`super::commands`]).

use super::args::{self, Axis};
use crate::project::V3;
use crate::skeleton::{Plane, SkeletonKind};
use clap::{Args, Subcommand};

// A command's one argument: an object's or skeleton's name (no doc comment: clap would
// show it as the command's help).
#[derive(Args, Debug)]
pub(crate) struct NameArg {
    pub name: String,
}

#[derive(Subcommand, Debug)]
pub enum SkeletonCmd {
    /// Start a skeleton in a principal plane, optionally with its points.
    New(SkeletonNewArgs),
    /// Add points (at the end, or before point AT, counting from 1; options first).
    Add(SkeletonAddArgs),
    /// Move point INDEX (counting from 1) to U,V: a vertex or a Bézier control point.
    Move(SkeletonMoveArgs),
    /// Remove point INDEX (counting from 1).
    Remove(SkeletonIndexArgs),
    /// Set a Bézier skeleton's smoothness: line segments per curve piece.
    Smooth(SkeletonSmoothArgs),
    /// Change a skeleton's settings.
    Set(SkeletonSetArgs),
    /// Delete a skeleton.
    Delete(NameArg),
}

#[derive(Args, Debug)]
pub struct SkeletonNewArgs {
    pub name: String,
    /// The plane: xy (front view; points are x,y), xz (top; x,z) or yz (side; y,z).
    #[arg(long, value_enum)]
    pub plane: Plane,
    #[arg(long, value_enum, default_value = "lines")]
    pub kind: SkeletonKind,
    /// The outline returns to its first point.
    #[arg(long)]
    pub closed: bool,
    /// Position of the plane along its normal axis.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub depth: f64,
    /// Degree of each Bézier piece.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=10))]
    pub degree: u32,
    /// Line segments per Bézier piece.
    #[arg(long, default_value_t = crate::skeleton::DEFAULT_SMOOTHNESS)]
    pub smoothness: u32,
    /// Points as u,v in the plane's axes (after all options).
    #[arg(value_parser = args::vec2, allow_hyphen_values = true)]
    pub points: Vec<[f64; 2]>,
}

#[derive(Args, Debug)]
pub struct SkeletonAddArgs {
    pub name: String,
    #[arg(value_parser = args::vec2, allow_hyphen_values = true, required = true)]
    pub points: Vec<[f64; 2]>,
    /// Insert before this point (counting from 1) instead of at the end.
    #[arg(long)]
    pub at: Option<usize>,
}

#[derive(Args, Debug)]
pub struct SkeletonMoveArgs {
    pub name: String,
    pub index: usize,
    #[arg(value_parser = args::vec2, allow_hyphen_values = true)]
    pub point: [f64; 2],
}

#[derive(Args, Debug)]
pub struct SkeletonIndexArgs {
    pub name: String,
    pub index: usize,
}

#[derive(Args, Debug)]
pub struct SkeletonSmoothArgs {
    pub name: String,
    pub smoothness: u32,
}

#[derive(Args, Debug)]
pub struct SkeletonSetArgs {
    pub name: String,
    #[arg(long, value_enum)]
    pub kind: Option<SkeletonKind>,
    #[arg(long)]
    pub closed: Option<bool>,
    #[arg(long, allow_hyphen_values = true)]
    pub depth: Option<f64>,
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10))]
    pub degree: Option<u32>,
    #[arg(long, value_enum)]
    pub plane: Option<Plane>,
}

#[derive(Subcommand, Debug)]
pub enum AddCmd {
    /// A sphere: from a skeleton's first two points (centre, a point on the sphere), or
    /// from --center and --radius.
    Sphere(AddSphereArgs),
    /// A polygon: from a skeleton's outline, or from --vertices.
    Polygon(AddPolygonArgs),
    /// A quadric: ten coefficients (YARI order) clipped to a bounding box and/or planes.
    Quadric(AddQuadricArgs),
}

#[derive(Args, Debug)]
pub struct AddSphereArgs {
    pub name: String,
    #[arg(long, conflicts_with_all = ["center", "radius"], required_unless_present = "center")]
    pub from: Option<String>,
    #[arg(long, value_parser = args::vec3, allow_hyphen_values = true, requires = "radius")]
    pub center: Option<V3>,
    #[arg(long)]
    pub radius: Option<f64>,
}

#[derive(Args, Debug)]
pub struct AddPolygonArgs {
    pub name: String,
    #[arg(
        long,
        conflicts_with = "vertices",
        required_unless_present = "vertices"
    )]
    pub from: Option<String>,
    /// Bézier smoothness for --from (default: the skeleton's).
    #[arg(long)]
    pub smoothness: Option<u32>,
    /// Three or more vertices x,y,z.
    #[arg(long, num_args = 3.., value_parser = args::vec3, allow_hyphen_values = true)]
    pub vertices: Vec<V3>,
}

#[derive(Args, Debug)]
pub struct AddQuadricArgs {
    pub name: String,
    /// a b c d e f g h i j: a x^2 + 2b xy + 2c xz + 2d x + e y^2 + 2f yz + 2g y + h z^2 + 2i z + j = 0.
    #[arg(long, num_args = 10, value_parser = args::number, allow_hyphen_values = true, required = true)]
    pub coeffs: Vec<f64>,
    /// The bounding box: MIN MAX, each x,y,z.
    #[arg(long = "box", num_args = 2, value_parser = args::vec3, allow_hyphen_values = true)]
    pub bounds: Vec<V3>,
    /// A clipping plane a,b,c,d keeping a*x+b*y+c*z <= d (repeatable).
    #[arg(long, value_parser = args::plane4, allow_hyphen_values = true)]
    pub plane: Vec<(V3, f64)>,
}

#[derive(Args, Debug)]
pub struct CombineArgs {
    /// The new composite's name.
    pub name: String,
    /// The objects to put in it.
    #[arg(required = true)]
    pub objects: Vec<String>,
}

#[derive(Args, Debug)]
pub struct RevolveArgs {
    /// The new object's name.
    pub name: String,
    /// The profile skeleton (in a plane containing the axis).
    #[arg(long)]
    pub profile: String,
    #[arg(long, value_enum, default_value = "y")]
    pub axis: Axis,
    /// Degrees per step around the axis (45 is blocky, 10 is smooth).
    #[arg(long, default_value_t = 45.0)]
    pub step: f64,
    /// Line segments per Bézier piece (default: the skeleton's).
    #[arg(long)]
    pub smoothness: Option<u32>,
    /// Give the side faces vertex normals, so the renderer shades them smooth.
    #[arg(long)]
    pub smooth: bool,
    /// With --smooth: profile corners turning by more than this many degrees stay sharp.
    #[arg(long, default_value_t = 45.0, requires = "smooth")]
    pub crease: f64,
}

#[derive(Args, Debug)]
pub struct ExtrudeArgs {
    /// The new object's name.
    pub name: String,
    /// The outline skeleton (taken as closed).
    #[arg(long)]
    pub outline: String,
    /// The extrusion vector x,y,z (along one or more axes).
    #[arg(long, value_parser = args::vec3, allow_hyphen_values = true, required_unless_present = "depth", conflicts_with = "depth")]
    pub by: Option<V3>,
    /// Extrude by this length along the outline plane's normal axis.
    #[arg(long, allow_hyphen_values = true)]
    pub depth: Option<f64>,
    /// Extend half the vector to each side of the outline's plane.
    #[arg(long)]
    pub centred: bool,
    /// Leave the ends open.
    #[arg(long)]
    pub no_caps: bool,
    /// Line segments per Bézier piece (default: the skeleton's).
    #[arg(long)]
    pub smoothness: Option<u32>,
}
