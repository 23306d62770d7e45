//! The `mesh(file = "...")` statement: a mesh file's faces compiled where the statement
//! stands, each as soon as it is read ([`crate::mesh::read_each`]), as polygons under the
//! current transformation and motion. Their surface is the current attribute, or with
//! `materials = file` the file's own, which end with the statement (as a block's would).
//!
//! What the compiler says of the faces (a polygon with no area, say) is said once per
//! message at the statement, with how many faces it was said of, not once per face. A file
//! that cannot be read is one error at the file's name, in the mesh reader's words (the
//! mesh's own file and line or byte).

use super::stack::State;
use super::Compiler;
use crate::ast::{BodyItem, MeshMaterials, MeshStmt, Primitive, Spanned};
use crate::diag::Severity;
use crate::mesh::{MeshSummary, ToYari};
use crate::model::{Object, Surface};
use crate::span::Span;
use std::path::{Path, PathBuf};

/// At most this many distinct messages about a mesh's faces are kept; the rest are counted.
const MAX_FACE_MESSAGES: usize = 32;

/// A mesh file a scene placed: where it was found and what it held (with the other files
/// read for it, its MTL libraries or glTF buffers).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshRead {
    /// The file, as found (relative to the YARI file's folder when written relative).
    pub path: PathBuf,
    /// What it held.
    pub summary: MeshSummary,
}

/// Messages about one mesh's faces, each with the faces it was said of.
#[derive(Debug, Default)]
pub(crate) struct FaceMessages {
    said: Vec<(Severity, String, usize)>,
    others: usize,
}

impl FaceMessages {
    pub(crate) fn add(&mut self, severity: Severity, message: String) {
        let known = self
            .said
            .iter()
            .position(|(s, m, _)| *s == severity && *m == message);
        match known {
            Some(k) => self.said[k].2 += 1,
            None if self.said.len() < MAX_FACE_MESSAGES => self.said.push((severity, message, 1)),
            None => self.others += 1,
        }
    }
}

impl Compiler<'_> {
    /// Compiles the mesh statement `m` (the whole statement at `span`) in `state`.
    pub(super) fn mesh(
        &mut self,
        m: &MeshStmt,
        span: Span,
        state: &State,
        depth: usize,
        surfaces: &mut Vec<Surface>,
        out: &mut dyn FnMut(&[Surface], Object),
    ) {
        let name = &m.file.node;
        let path = match &self.folder {
            Some(dir) if Path::new(name).is_relative() => dir.join(name),
            _ => PathBuf::from(name),
        };
        let Some(kind) = crate::mesh::kind_of(&path) else {
            let msg = format!("`{name}` is not a mesh file: expected .obj, .ply, .gltf or .glb");
            return self.error(m.file.span, msg);
        };
        let file = match std::fs::File::open(&path) {
            Ok(f) => f,
            Err(e) => {
                return self.error(m.file.span, format!("cannot read {}: {e}", path.display()))
            }
        };
        let mut input = std::io::BufReader::with_capacity(1 << 16, file);
        let outer = self.faces.replace(FaceMessages::default());
        let mut inner = state.clone();
        let mut to_yari = ToYari::default();
        let read = crate::mesh::read_each(kind, &path, &mut input, &mut |face| {
            let mut place = |item: Spanned<BodyItem>| {
                let item = Spanned::new(item.node, span);
                self.item(&item, &mut inner, depth, surfaces, out)
            };
            match m.materials {
                MeshMaterials::File => to_yari.face(face, &mut place),
                MeshMaterials::Current => place(Spanned::new(
                    BodyItem::Primitive(Primitive::Polygon {
                        vertices: face.vertices,
                        normals: face.normals,
                    }),
                    span,
                )),
            }
        });
        let said = std::mem::replace(&mut self.faces, outer).unwrap_or_default();
        match read {
            Err(e) => self.error(m.file.span, e.to_string()),
            Ok(summary) => {
                self.say_faces(name, span, said);
                self.meshes.push(MeshRead { path, summary });
            }
        }
    }

    /// What was said of the faces of the mesh `name` (at `span`), once per message.
    fn say_faces(&mut self, name: &str, span: Span, said: FaceMessages) {
        for (severity, message, n) in said.said {
            let faces = if n == 1 {
                "1 face".into()
            } else {
                format!("{n} faces")
            };
            let message = format!("in {name}: {message} ({faces})");
            match severity {
                Severity::Error => self.error(span, message),
                Severity::Warning => self.warn(span, message),
            }
        }
        if said.others > 0 {
            let message = format!("in {name}: {} more messages about its faces", said.others);
            self.warn(span, message);
        }
    }
}
