//! glTF 2.0 (`.gltf` with its buffers, `.glb`) through the `gltf` crate: the default scene's
//! nodes (or the first scene's), each mesh's triangle primitives under the node's transform,
//! vertex normals where given (carried by the inverse transpose), and the metallic-roughness
//! material with the transmission and ior extensions mapped to NFF's fill (docs/meshes.md).
//! Buffers come from the `.glb`'s binary chunk, a file beside the `.gltf`, or a base64
//! `data:` URI; each is checked to hold the bytes it declares before anything is read, so an
//! accessor never reads past the data. The file is held whole (glTF's buffers are addressed
//! by offset); textures are not read.

use super::{Face, MeshError, Place, Surface};
use crate::ast::{has_direction, Vec3};
use crate::nff::Fill;
use base64::Engine;
use glam::{DMat3, DMat4, DVec3};
use gltf::mesh::Mode;
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// Node depth followed at most (a cycle is refused by the crate's validation; this bounds a
/// deep chain).
const MAX_DEPTH: usize = 256;

/// The reader of one file: its buffers and where it is.
struct GltfReader<'a> {
    path: &'a Path,
    buffers: Vec<Vec<u8>>,
    vertices: u64,
    /// The buffer files read.
    files: Vec<PathBuf>,
    /// Primitives of points or lines, which have no faces: left out.
    skipped: u64,
}

impl GltfReader<'_> {
    fn error(&self, message: impl Into<String>) -> MeshError {
        MeshError::new(self.path, Place::File, message)
    }

    /// The data of every buffer, each checked to hold its declared length.
    fn load_buffers(&mut self, doc: &gltf::Gltf) -> Result<(), MeshError> {
        let dir = self.path.parent().unwrap_or(Path::new(""));
        for b in doc.buffers() {
            let data = match b.source() {
                gltf::buffer::Source::Bin => doc.blob.clone().ok_or_else(|| {
                    self.error(format!(
                        "buffer {} is the binary chunk, which the file lacks",
                        b.index()
                    ))
                })?,
                gltf::buffer::Source::Uri(uri) => match uri.strip_prefix("data:") {
                    Some(data) => {
                        let b64 = data.split_once(";base64,").map(|(_, d)| d).ok_or_else(|| {
                            self.error(format!(
                                "buffer {}: a data URI that is not base64",
                                b.index()
                            ))
                        })?;
                        base64::engine::general_purpose::STANDARD
                            .decode(b64)
                            .map_err(|e| self.error(format!("buffer {}: {e}", b.index())))?
                    }
                    None => {
                        let file = dir.join(uri);
                        let data = std::fs::read(&file).map_err(|e| {
                            self.error(format!("cannot read buffer {} ({uri}): {e}", b.index()))
                        })?;
                        self.files.push(file);
                        data
                    }
                },
            };
            if data.len() < b.length() {
                return Err(self.error(format!(
                    "buffer {} holds {} bytes, fewer than the {} it declares (truncated?)",
                    b.index(),
                    data.len(),
                    b.length()
                )));
            }
            self.buffers.push(data);
        }
        Ok(())
    }

    /// The faces of `node` and its children under `parent`.
    fn node(
        &mut self,
        node: gltf::Node<'_>,
        parent: DMat4,
        depth: usize,
        each: &mut dyn FnMut(Face),
    ) -> Result<(), MeshError> {
        if depth > MAX_DEPTH {
            return Err(self.error(format!("nodes nested deeper than {MAX_DEPTH}")));
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if let Some(mesh) = node.mesh() {
            for p in mesh.primitives() {
                self.primitive(&p, mesh.index(), &world, each)?;
            }
        }
        for child in node.children() {
            self.node(child, world, depth + 1, each)?;
        }
        Ok(())
    }

    fn primitive(
        &mut self,
        p: &gltf::Primitive<'_>,
        mesh: usize,
        world: &DMat4,
        each: &mut dyn FnMut(Face),
    ) -> Result<(), MeshError> {
        if !matches!(
            p.mode(),
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.skipped += 1;
            return Ok(());
        }
        let buffers = &self.buffers;
        let reader = p.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let short = |what: &str| {
            self.error(format!(
                "mesh {mesh} primitive {}: its {what} accessor reads past its buffer",
                p.index()
            ))
        };
        let positions: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| short("POSITION"))?
            .map(|v| {
                world
                    .transform_point3(DVec3::from(v.map(f64::from)))
                    .to_array()
            })
            .collect();
        if positions.iter().flatten().any(|x| !x.is_finite()) {
            return Err(self.error(format!(
                "mesh {mesh}: a position that is not a finite number"
            )));
        }
        let carry = DMat3::from_mat4(*world).inverse().transpose();
        let normals: Option<Vec<Vec3>> = match p.get(&gltf::Semantic::Normals) {
            Some(_) => Some(
                reader
                    .read_normals()
                    .ok_or_else(|| short("NORMAL"))?
                    .map(|n| carry.mul_vec3(DVec3::from(n.map(f64::from))).to_array())
                    .collect(),
            ),
            None => None,
        };
        let indices: Vec<u32> = match p.indices() {
            Some(_) => reader
                .read_indices()
                .ok_or_else(|| short("indices"))?
                .into_u32()
                .collect(),
            None => (0..positions.len() as u32).collect(),
        };
        let n = positions.len();
        if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
            return Err(self.error(format!(
                "mesh {mesh} primitive {}: index {bad} is out of range ({n} vertices)",
                p.index()
            )));
        }
        // A primitive without a material gets the neutral grey of a file without surfaces.
        let surface = match p.material().index() {
            Some(_) => Surface::Fill(fill(&p.material())),
            None => Surface::Default,
        };
        for tri in triangles(p.mode(), &indices) {
            let corners = tri.map(|i| i as usize);
            let normals = normals
                .as_ref()
                .map(|ns| corners.iter().map(|&i| ns[i]).collect::<Vec<_>>())
                .filter(|ns| ns.iter().all(has_direction));
            each(Face {
                vertices: corners.iter().map(|&i| positions[i]).collect(),
                normals,
                surface,
            });
        }
        self.vertices += n as u64;
        Ok(())
    }
}

/// The triangles of a primitive's index list in `mode`.
fn triangles(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::TriangleStrip => (2..idx.len())
            .map(|i| match i % 2 {
                0 => [idx[i - 2], idx[i - 1], idx[i]],
                _ => [idx[i - 1], idx[i - 2], idx[i]],
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
        _ => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    }
}

/// A metallic-roughness material as NFF's fill: the base colour; a mirror weight of
/// metallic x (1 - roughness); a highlight exponent 2 / roughness^4 - 2 (Blinn-Phong's
/// equivalent, capped at 100000); KHR_materials_transmission's factor as the transmittance,
/// with KHR_materials_ior's index (1.5, glTF's default, when absent).
fn fill(m: &gltf::Material<'_>) -> Fill {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, _] = pbr.base_color_factor().map(f64::from);
    let metallic = f64::from(pbr.metallic_factor()).clamp(0.0, 1.0);
    let rough = f64::from(pbr.roughness_factor()).clamp(0.0, 1.0);
    let shine = if rough > 0.0 {
        (2.0 / rough.powi(4) - 2.0).clamp(0.0, 100_000.0)
    } else {
        100_000.0
    };
    let t = m
        .transmission()
        .map_or(0.0, |t| f64::from(t.transmission_factor()).clamp(0.0, 1.0));
    Fill {
        color: [r, g, b],
        kd: 1.0,
        ks: metallic * (1.0 - rough),
        shine,
        t,
        ior: m.ior().map_or(1.5, f64::from).max(1e-3),
    }
}

/// Reads a glTF file (JSON or binary) from `input`, handing each triangle to `each`: the
/// number of vertices, the buffer files read and the primitives left out (points, lines).
pub fn read_each(
    path: &Path,
    input: &mut dyn BufRead,
    each: &mut dyn FnMut(Face),
) -> Result<(u64, Vec<PathBuf>, u64), MeshError> {
    let mut bytes = Vec::new();
    input
        .read_to_end(&mut bytes)
        .map_err(|e| MeshError::new(path, Place::File, format!("cannot read it: {e}")))?;
    let doc = gltf::Gltf::from_slice(&bytes)
        .map_err(|e| MeshError::new(path, Place::File, format!("not glTF 2.0: {e}")))?;
    drop(bytes);
    let mut r = GltfReader {
        path,
        buffers: Vec::new(),
        vertices: 0,
        files: Vec::new(),
        skipped: 0,
    };
    r.load_buffers(&doc)?;
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    let roots: Vec<gltf::Node<'_>> = match scene {
        Some(s) => s.nodes().collect(),
        None => {
            // No scene: every node that is no other's child.
            let children: std::collections::HashSet<usize> = doc
                .nodes()
                .flat_map(|n| n.children().map(|c| c.index()).collect::<Vec<_>>())
                .collect();
            doc.nodes()
                .filter(|n| !children.contains(&n.index()))
                .collect()
        }
    };
    for node in roots {
        r.node(node, DMat4::IDENTITY, 0, each)?;
    }
    Ok((r.vertices, r.files, r.skipped))
}
