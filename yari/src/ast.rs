//! The YARI syntax tree, as written: one node per statement, each with its span.
//!
//! The grammar is Appendix C.4 of the thesis plus the documented extensions (see the crate
//! docs and `docs/yari.md`): `samples(n)`, light `radius`, camera `aperture`/`focus`,
//! attribute `gloss`/`translucency`/`transmissivity`, quadric clipping, `motion(x,y,z)` and
//! per-vertex polygon normals.
//! The parser builds it, the compiler (`compile`) turns it into a [`crate::model::World`],
//! and the writer prints it back to YARI text.

use crate::span::Span;

/// A value with the span it was written at.
#[derive(Clone, Debug, PartialEq)]
pub struct Spanned<T> {
    /// The value itself.
    pub node: T,
    /// Where it was written: the byte range in its [`crate::span::Source`], for diagnostics.
    pub span: Span,
}

impl<T> Spanned<T> {
    /// Pairs `node` with the span it was written at.
    pub fn new(node: T, span: Span) -> Self {
        Spanned { node, span }
    }
}

/// A point, direction or `r,g,b` colour as written, in the scene's units (x, y, z).
pub type Vec3 = [f64; 3];

/// Whether a normal as written has a direction: its squared length is a normal `f64` (not
/// zero, not so small or so large that normalising it fails). The parser refuses other
/// normals; the NFF and OFF importers shade such a polygon flat.
pub fn has_direction(n: &Vec3) -> bool {
    (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).is_normal()
}

/// A colour as written: an `r,g,b` triple or a name looked up in the colour table.
#[derive(Clone, Debug, PartialEq)]
pub enum ColorSpec {
    /// `r,g,b`: linear RGB, no gamma; components normally 0..1.
    Rgb(Vec3),
    /// A colour name, matched without regard to case against [`crate::colour::ColourTable`].
    Named(String),
}

/// A whole scene file: the preamble (`<view>`) and the world block (`<body>`).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Scene {
    /// The preamble statements in order; for all but lights the last one wins.
    pub view: Vec<Spanned<ViewStmt>>,
    /// The world block, `begin ... end`.
    pub body: Block,
}

/// A preamble statement.
#[derive(Clone, Debug, PartialEq)]
pub enum ViewStmt {
    /// `background(color = C)`: the colour of rays that hit nothing.
    Background(Spanned<ColorSpec>),
    /// `ambient(color = C)`: the ambient light.
    Ambient(Spanned<ColorSpec>),
    /// `resolution(x, y)`: the image width and height in pixels, 1..65536 each.
    Resolution(u32, u32),
    /// `light(...)`: one more light (lights accumulate).
    Light(LightDef),
    /// `camera(...)`: the camera.
    Camera(CameraDef),
    /// Extension: samples per pixel (jittered, box filter). Default 1.
    Samples(u32),
    /// Extension: `target_error(E)`, render each pixel until the estimated standard error of
    /// its mean is at most E (linear radiance) instead of a fixed number of samples.
    TargetError(f64),
}

/// `light(position = x,y,z ; color = C [; radius = r])`.
#[derive(Clone, Debug, PartialEq)]
pub struct LightDef {
    /// The light's centre in world space.
    pub position: Vec3,
    /// The light's colour (its intensity per channel).
    pub color: Spanned<ColorSpec>,
    /// Extension: radius of a spherical area light; absent or 0 is a point light.
    pub radius: Option<f64>,
}

/// `camera(position = p ; at = a ; up = u ; angle = deg [; aperture = A] [; focus = F])`.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDef {
    /// The eye point in world space.
    pub position: Vec3,
    /// The point looked at; must differ from `position`.
    pub at: Vec3,
    /// Which way is up in the image; not zero and not parallel to `at - position`.
    pub up: Vec3,
    /// The HALF angle of view in degrees, from the centre of the top row of pixels to the
    /// centre of the bottom row (thesis Fig. 2.1; NFF writes the full angle).
    pub angle: f64,
    /// Extension: lens radius for depth of field; absent or 0 is a pinhole.
    pub aperture: Option<f64>,
    /// Extension: distance to the plane in focus; default the distance from position to at.
    pub focus: Option<f64>,
}

/// A `begin ... end` block.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Block {
    /// The statements inside, in order.
    pub items: Vec<Spanned<BodyItem>>,
    /// From `begin` to `end` inclusive (to the end of the input when `end` is missing).
    pub span: Span,
}

/// One statement of a block.
#[derive(Clone, Debug, PartialEq)]
pub enum BodyItem {
    /// `attribute(...)`: replaces the whole current surface; fields not given take their defaults.
    Attribute(Vec<Spanned<AttrField>>),
    /// A primitive drawn with the current surface and transformation.
    Primitive(Primitive),
    /// A transformation of the primitives that follow in the same block.
    Transform(Transform),
    /// A nested `begin ... end`: its transformations and surface end with it.
    Block(Block),
    /// Extension: `mesh(file = "statue.ply" [; materials = file])`, a mesh file's faces
    /// placed under the current transformation (and surface, unless the file's own are asked
    /// for).
    Mesh(MeshStmt),
}

/// Extension: a mesh file placed in the scene (`docs/yari.md`, "Meshes").
#[derive(Clone, Debug, PartialEq)]
pub struct MeshStmt {
    /// The file as written: an OBJ, PLY or glTF mesh, relative to the YARI file's folder
    /// unless absolute.
    pub file: Spanned<String>,
    /// Whose surfaces its faces take.
    pub materials: MeshMaterials,
}

/// Whose surfaces a mesh's faces take.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MeshMaterials {
    /// The current attribute, like any primitive (`materials = current`, the default).
    #[default]
    Current,
    /// The file's own (`materials = file`): OBJ's MTL, PLY's vertex colours, glTF's
    /// materials, grey where it has none; they end with the statement.
    File,
}

/// One `name = value` inside `attribute(...)`.
#[derive(Clone, Debug, PartialEq)]
pub enum AttrField {
    /// `color = C`: the surface colour (default white).
    Color(Spanned<ColorSpec>),
    /// `kdr = v`: diffuse reflection, 0..1 (default 1); specular reflection is 1 - kdr.
    Kdr(f64),
    /// `kdt = v`: diffuse transmission, 0..1 (default 1); specular transmission is 1 - kdt.
    Kdt(f64),
    /// `ka = v`: ambient coefficient, >= 0 (default 1).
    Ka(f64),
    /// `phong = v`: specular highlight exponent, >= 0 (default 1).
    Phong(f64),
    /// `refract = v`: index of refraction (default 1); must be > 0 when kdt < 1.
    Refract(f64),
    /// `texture = id r,g,b sx,sy,sz`: texture kind, second colour, scale.
    Texture {
        /// Texture kind: 0 none, 1 wood, 2 marble, 3 bumps, 4 turbulence, 5 checker
        /// (`docs/yari.md` section 5); kept as written, checked by the compiler.
        id: f64,
        /// The texture's second colour (veins, mix colour or odd cells), linear RGB.
        color: Vec3,
        /// Feature size per axis: texture space is divided by it; no component may be 0.
        scale: Vec3,
    },
    /// Extension: blurry reflection, the half-angle spread in degrees (0 = mirror).
    Gloss(f64),
    /// Extension: blurry transmission, the half-angle spread in degrees (0 = clear).
    Translucency(f64),
    /// Extension: transmissivity per unit length T (Table 3.1), 1 = no absorption.
    Transmissivity(f64),
    /// Extension: `texture_space = m00 m01 m02 m03 m10 ... m23`, the world-to-texture map
    /// (3x4, row by row) given explicitly instead of the inverse of the current transform.
    /// The writer uses it to print a compiled world exactly.
    TextureSpace([f64; 12]),
}

/// A primitive (`<object>` in Appendix C.4), in the current block's object space.
#[derive(Clone, Debug, PartialEq)]
pub enum Primitive {
    /// `sphere(center = x,y,z ; radius = r)`.
    Sphere {
        /// The centre.
        center: Vec3,
        /// The radius, > 0.
        radius: f64,
    },
    /// `polygon(vertices = n ; x1,y1,z1 ... xn,yn,zn [; normals = ...])`: a planar polygon.
    Polygon {
        /// The vertices in order (at least 3).
        vertices: Vec<Vec3>,
        /// Extension: one normal per vertex (`; normals = nx1,ny1,nz1 ...`), none of them
        /// zero, for smooth shading; `None` is a flat polygon, as in the thesis.
        normals: Option<Vec<Vec3>>,
    },
    /// Ten coefficients, the upper triangle of the symmetric 4x4 matrix Q, row by row
    /// (see [`crate::model::Quadric`]), and optional clipping.
    Quadric {
        /// Upper-triangle coefficients `a b c d e f g h i j`; not all zero.
        coeffs: [f64; 10],
        /// `clip = ...` and `plane = ...` fields, in the order written; empty means unclipped.
        clip: Vec<Clip>,
    },
}

/// Extension: how a quadric is clipped, in the same (object) space as its coefficients.
#[derive(Clone, Debug, PartialEq)]
pub enum Clip {
    /// `clip = xmin,ymin,zmin xmax,ymax,zmax`: keep the part inside the box.
    Box {
        /// The minimum corner; no component greater than the same one of `max`.
        min: Vec3,
        /// The maximum corner.
        max: Vec3,
    },
    /// `plane = a,b,c d`: keep the part where a*x + b*y + c*z <= d.
    Plane {
        /// (a, b, c), not zero; need not be unit length.
        normal: Vec3,
        /// d, in the units of `normal`.
        offset: f64,
    },
}

/// A transformation of the primitives that follow in the same block (and nested blocks),
/// applied after those already in effect.
#[derive(Clone, Debug, PartialEq)]
pub enum Transform {
    /// `translate(x,y,z)`: move by (x, y, z).
    Translate(Vec3),
    /// `scale(x,y,z)`: scale each axis; factors must not be 0 (negative mirrors).
    Scale(Vec3),
    /// Degrees about x, then y, then z.
    Rotate(Vec3),
    /// Extension: the following primitives in this scope move by this world-space
    /// displacement while the shutter is open (motion blur).
    Motion(Vec3),
    /// Extension: `transform(m00 m01 m02 m03 m10 ... m23)`, a general affine map (3x4, row
    /// by row: x' = m00 x + m01 y + m02 z + m03, ...), combined like the others.
    Matrix([f64; 12]),
}
