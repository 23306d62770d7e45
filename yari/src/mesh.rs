//! Meshes from today's tools: Wavefront OBJ (with its MTL materials), PLY (ASCII, and
//! binary in either byte order) and glTF 2.0, read as a stream of faces and mapped to YARI polygons, so a
//! scanned statue renders with no converter of the user's own (docs/meshes.md).
//!
//! Each face becomes a `polygon` as soon as it is read (with `normals = ...` where the file
//! gives vertex normals: smooth shading, as NFF's `pp`); faces of more than three corners take
//! the same polygon path as YARI's. Only the vertices are held (a face refers to them by
//! index); a 4M-triangle PLY is never held whole. A file on its own gets a preamble that frames
//! it ([`frame`]): a camera looking at its bounding box from a fixed direction, a light at the
//! eye and a second above, and a neutral grey surface where the file has none.
//!
//! Errors name the file and the line (or, in a binary PLY, the byte offset) in one line
//! ([`MeshError`]).
//!
//! # Layout
//! - this file: the face, the error, and the mapping of faces to YARI items ([`ToYari`]).
//! - [`frame`]: the bounding box and the preamble that frames it.
//! - [`ply`]: PLY through the `ply-rs-bw` crate, element by element.
//! - [`gltf`]: glTF 2.0 (`.gltf`, `.glb`) through the `gltf` crate, node transforms and
//!   metallic-roughness materials.
//! - [`obj`]: OBJ, streamed by our own reader (tobj holds the whole mesh and names no line
//!   in its errors); MTL files through `tobj`.
//! - [`write`]: faces written as OBJ or PLY (the fixture generators).

pub mod frame;
pub mod gltf;
pub mod obj;
pub mod ply;
pub mod write;

use crate::ast::{AttrField, BodyItem, Primitive, Scene, Spanned, Vec3};
use crate::nff::to_yari::fill_attribute;
use crate::nff::Fill;
use crate::span::Span;
use frame::Bounds;
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// The mesh formats read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshKind {
    /// Wavefront OBJ (`.obj`), with MTL materials.
    Obj,
    /// PLY (`.ply`), ASCII or binary.
    Ply,
    /// glTF 2.0 (`.gltf` with its buffers, or `.glb`).
    Gltf,
}

/// Where in a mesh file something is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Place {
    /// A line of a text file (from 1).
    Line(u64),
    /// A byte offset in a binary file.
    Byte(u64),
    /// The file as a whole.
    File,
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Place::Line(n) => write!(f, ":{n}"),
            Place::Byte(n) => write!(f, ": byte {n}"),
            Place::File => Ok(()),
        }
    }
}

/// A mesh file that cannot be read: one line, with the file and the place.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}{place}: {message}", path.display())]
pub struct MeshError {
    /// The file (the MTL file, for an error in it).
    pub path: PathBuf,
    /// Where in it.
    pub place: Place,
    /// What is wrong.
    pub message: String,
}

impl MeshError {
    /// An error at `place` of `path`.
    pub fn new(path: &Path, place: Place, message: impl Into<String>) -> MeshError {
        MeshError {
            path: path.to_path_buf(),
            place,
            message: message.into(),
        }
    }
}

/// The surface of a face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Surface {
    /// None given: neutral grey.
    Default,
    /// A colour (PLY vertex colours, averaged over the face), matte.
    Colour(Vec3),
    /// A material (OBJ's MTL), as NFF's fill.
    Fill(Fill),
}

/// The grey of a face the file gives no surface.
pub const GREY: Vec3 = [0.7, 0.7, 0.7];

impl Surface {
    /// The Hall attribute fields of this surface (NFF's fill mapping, docs/nff-mapping.md).
    pub fn attribute(&self) -> Vec<AttrField> {
        let matte = |color| Fill {
            color,
            kd: 1.0,
            ks: 0.0,
            shine: 100_000.0,
            t: 0.0,
            ior: 1.0,
        };
        let fill = match *self {
            Surface::Default => matte(GREY),
            Surface::Colour(c) => matte(c),
            Surface::Fill(f) => f,
        };
        fill_attribute(&fill)
    }
}

/// One face as read: its corners (at least three), a normal per corner when the file gives
/// them, and its surface.
#[derive(Clone, Debug, PartialEq)]
pub struct Face {
    /// The corners in order.
    pub vertices: Vec<Vec3>,
    /// A normal per corner, for smooth shading; `None`: flat.
    pub normals: Option<Vec<Vec3>>,
    /// Its surface.
    pub surface: Surface,
}

/// What a mesh file held.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshSummary {
    /// Vertices declared.
    pub vertices: u64,
    /// Faces read.
    pub faces: u64,
    /// Triangles they make (a face of n corners makes n - 2).
    pub triangles: u64,
    /// Whether the faces carry vertex normals.
    pub normals: bool,
    /// The bounding box of the vertices faces use.
    pub bounds: Bounds,
    /// The other files read for it: OBJ's material libraries, glTF's buffer files.
    pub companions: Vec<PathBuf>,
    /// glTF primitives of points or lines: they have no faces, so they are left out (and
    /// the loader says so in a warning).
    pub skipped_primitives: u64,
}

impl MeshSummary {
    /// Counts `face`.
    pub fn add(&mut self, face: &Face) {
        self.faces += 1;
        self.triangles += face.vertices.len().saturating_sub(2) as u64;
        self.normals |= face.normals.is_some();
        for v in &face.vertices {
            self.bounds.add(*v);
        }
    }
}

/// The kind named by a path's extension (case ignored), if it is a mesh.
pub fn kind_of(path: &Path) -> Option<MeshKind> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "obj" => Some(MeshKind::Obj),
        "ply" => Some(MeshKind::Ply),
        "gltf" | "glb" => Some(MeshKind::Gltf),
        _ => None,
    }
}

/// Reads the mesh `input` (the file `path`: relative MTL files are found beside it) to its
/// end, handing each face to `each` as soon as it is read: what the file held, or the first
/// error (the faces handed over before it are not to be used).
pub fn read_each(
    kind: MeshKind,
    path: &Path,
    input: &mut dyn BufRead,
    each: &mut dyn FnMut(Face),
) -> Result<MeshSummary, MeshError> {
    let mut summary = MeshSummary::default();
    let mut counted = |f: Face| {
        summary.add(&f);
        each(f);
    };
    let (vertices, companions, skipped) = match kind {
        MeshKind::Obj => {
            let (vertices, companions) = obj::read_each(path, input, &mut counted)?;
            (vertices, companions, 0)
        }
        MeshKind::Ply => (ply::read_each(path, input, &mut counted)?, Vec::new(), 0),
        MeshKind::Gltf => gltf::read_each(path, input, &mut counted)?,
    };
    summary.vertices = vertices;
    summary.companions = companions;
    summary.skipped_primitives = skipped;
    Ok(summary)
}

/// Faces to YARI world-block items: an `attribute` where the surface changes, then the face's
/// `polygon`.
#[derive(Debug, Default)]
pub struct ToYari {
    current: Option<Surface>,
}

impl ToYari {
    /// The items of `face`, handed to `each`.
    pub fn face(&mut self, face: Face, each: &mut dyn FnMut(Spanned<BodyItem>)) {
        let at = Span::default();
        if self.current != Some(face.surface) {
            let fields = face
                .surface
                .attribute()
                .into_iter()
                .map(|f| Spanned::new(f, at))
                .collect();
            each(Spanned::new(BodyItem::Attribute(fields), at));
            self.current = Some(face.surface);
        }
        let polygon = Primitive::Polygon {
            vertices: face.vertices,
            normals: face.normals,
        };
        each(Spanned::new(BodyItem::Primitive(polygon), at));
    }
}

/// The polygons of an NFF scene as faces (its fills as their surfaces), for the mesh
/// writers; a scene with other primitives (spheres, cones) cannot be a mesh.
pub fn faces_of(scene: &crate::nff::NffScene) -> Result<Vec<Face>, MeshError> {
    use crate::nff::Entity;
    let mut fill = None;
    let mut faces = Vec::new();
    for e in &scene.entities {
        match &e.node {
            Entity::Fill(f) => fill = Some(*f),
            Entity::Polygon { vertices, normals } => faces.push(Face {
                vertices: vertices.clone(),
                normals: normals.clone(),
                surface: fill.map_or(Surface::Default, Surface::Fill),
            }),
            Entity::Sphere { .. } | Entity::Cone { .. } => {
                return Err(MeshError::new(
                    Path::new("the scene"),
                    Place::File,
                    "it has spheres or cones, and a mesh holds only polygons (--patches \
                     makes them polygons)",
                ))
            }
            _ => {}
        }
    }
    Ok(faces)
}

/// The mesh file at `path` as a whole YARI scene, framed (for `sunray convert`), with what it
/// held.
pub fn parse_path(kind: MeshKind, path: &Path) -> Result<(Scene, MeshSummary), MeshError> {
    let file = std::fs::File::open(path)
        .map_err(|e| MeshError::new(path, Place::File, format!("cannot read it: {e}")))?;
    let mut input = std::io::BufReader::with_capacity(1 << 16, file);
    let mut scene = Scene::default();
    let mut to_yari = ToYari::default();
    let summary = read_each(kind, path, &mut input, &mut |f| {
        to_yari.face(f, &mut |item| scene.body.items.push(item))
    })?;
    scene.view = frame::view(&summary.bounds);
    Ok((scene, summary))
}

#[cfg(test)]
mod tests;
