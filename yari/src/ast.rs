//! The YARI syntax tree, as written: one node per statement, each with its span.
//!
//! The grammar is Appendix C.4 of the thesis plus the documented extensions (see the crate
//! docs and `docs/yari.md`): `samples(n)`, light `radius`, camera `aperture`/`focus`,
//! attribute `gloss`/`translucency`/`transmissivity`, quadric clipping, and `motion(x,y,z)`.
//! The parser builds it, the compiler (`compile`) turns it into a [`crate::model::World`],
//! and the writer prints it back to YARI text.

use crate::span::Span;

/// A value with the span it was written at.
#[derive(Clone, Debug, PartialEq)]
pub struct Spanned<T> {
    pub node: T,
    pub span: Span,
}

impl<T> Spanned<T> {
    pub fn new(node: T, span: Span) -> Self {
        Spanned { node, span }
    }
}

pub type Vec3 = [f64; 3];

/// A colour as written: an `r,g,b` triple or a name looked up in the colour table.
#[derive(Clone, Debug, PartialEq)]
pub enum ColorSpec {
    Rgb(Vec3),
    Named(String),
}

/// A whole scene file: the preamble (`<view>`) and the world block (`<body>`).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Scene {
    pub view: Vec<Spanned<ViewStmt>>,
    pub body: Block,
}

/// A preamble statement.
#[derive(Clone, Debug, PartialEq)]
pub enum ViewStmt {
    Background(Spanned<ColorSpec>),
    Ambient(Spanned<ColorSpec>),
    Resolution(u32, u32),
    Light(LightDef),
    Camera(CameraDef),
    /// Extension: samples per pixel (jittered, box filter). Default 1.
    Samples(u32),
}

#[derive(Clone, Debug, PartialEq)]
pub struct LightDef {
    pub position: Vec3,
    pub color: Spanned<ColorSpec>,
    /// Extension: radius of a spherical area light; absent or 0 is a point light.
    pub radius: Option<f64>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct CameraDef {
    pub position: Vec3,
    pub at: Vec3,
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
    pub items: Vec<Spanned<BodyItem>>,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum BodyItem {
    Attribute(Vec<Spanned<AttrField>>),
    Primitive(Primitive),
    Transform(Transform),
    Block(Block),
}

/// One `name = value` inside `attribute(...)`.
#[derive(Clone, Debug, PartialEq)]
pub enum AttrField {
    Color(Spanned<ColorSpec>),
    Kdr(f64),
    Kdt(f64),
    Ka(f64),
    Phong(f64),
    Refract(f64),
    /// `texture = id r,g,b sx,sy,sz`: texture kind, second colour, scale.
    Texture {
        id: f64,
        color: Vec3,
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

#[derive(Clone, Debug, PartialEq)]
pub enum Primitive {
    Sphere {
        center: Vec3,
        radius: f64,
    },
    Polygon {
        vertices: Vec<Vec3>,
    },
    /// Ten coefficients, the upper triangle of the symmetric 4x4 matrix Q, row by row
    /// (see [`crate::model::Quadric`]), and optional clipping.
    Quadric {
        coeffs: [f64; 10],
        clip: Vec<Clip>,
    },
}

/// Extension: how a quadric is clipped, in the same (object) space as its coefficients.
#[derive(Clone, Debug, PartialEq)]
pub enum Clip {
    /// `clip = xmin,ymin,zmin xmax,ymax,zmax`: keep the part inside the box.
    Box { min: Vec3, max: Vec3 },
    /// `plane = a,b,c d`: keep the part where a*x + b*y + c*z <= d.
    Plane { normal: Vec3, offset: f64 },
}

#[derive(Clone, Debug, PartialEq)]
pub enum Transform {
    Translate(Vec3),
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
