//! Wavefront OBJ, read line by line by a reader of our own: `tobj` loads the whole mesh
//! before handing any of it over and names no line in its errors, while this reader keeps
//! only the vertex lists and hands each face on as it is read. Material libraries (`mtllib`)
//! are read with `tobj::load_mtl_buf`, relative to the OBJ file's folder.
//!
//! Read: `v x y z [w | r g b]`, `vn`, `vt` (counted, for index checks), `f` with corners
//! `v`, `v/t`, `v/t/n` or `v//n` (1-based; negative counts back from the last vertex so far),
//! `usemtl`, `mtllib`. Other statements (`o`, `g`, `s`, `l`, `p`, free-form curves) are
//! skipped. A material maps to NFF's fill: Kd the colour; with `illum` 3 or more, the mean of
//! Ks the mirror weight; Ns the highlight exponent; 1 - d (or Tr) the transmittance; Ni the
//! index of refraction (docs/meshes.md).

use super::{Face, MeshError, Place, Surface};
use crate::ast::{has_direction, Vec3};
use crate::nff::Fill;
use std::collections::HashMap;
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// Materials kept from the libraries, at most.
const MAX_MATERIALS: usize = 65_536;

/// The reader of one file: the vertex lists so far, the materials, the current surface.
struct ObjReader<'a> {
    path: &'a Path,
    line: u64,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    texcoords: u64,
    materials: HashMap<String, Fill>,
    surface: Surface,
    /// The material libraries read.
    libraries: Vec<PathBuf>,
}

impl ObjReader<'_> {
    fn error(&self, message: impl Into<String>) -> MeshError {
        MeshError::new(self.path, Place::Line(self.line), message)
    }

    /// The numbers after the keyword, `at_least` of them.
    fn numbers(&self, words: &[&str], at_least: usize, what: &str) -> Result<Vec<f64>, MeshError> {
        if words.len() < at_least {
            return Err(self.error(format!("{what} needs {at_least} numbers")));
        }
        words
            .iter()
            .map(|w| match w.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                Ok(_) => Err(self.error(format!("{what}: {w} is not a finite number"))),
                Err(_) => Err(self.error(format!("{what}: {w:?} is not a number"))),
            })
            .collect()
    }

    /// A 1-based (or negative, relative) index into a list of `len`, as a 0-based one.
    fn index(&self, word: &str, len: u64, what: &str) -> Result<usize, MeshError> {
        let whats = match what {
            "vertex" => "vertices",
            "normal" => "normals",
            _ => "texture coordinates",
        };
        let i: i64 = word
            .parse()
            .map_err(|_| self.error(format!("face: {word:?} is not a {what} index")))?;
        let resolved = if i < 0 { len as i64 + i } else { i - 1 };
        if i == 0 || resolved < 0 || resolved as u64 >= len {
            return Err(self.error(format!(
                "face: {what} index {i} is out of range (the file has {len} {whats} so far)"
            )));
        }
        Ok(resolved as usize)
    }

    fn face(&self, corners: &[&str]) -> Result<Face, MeshError> {
        if corners.len() < 3 {
            return Err(self.error(format!("face has {} corners (at least 3)", corners.len())));
        }
        let mut vertices = Vec::with_capacity(corners.len());
        let mut normals = Vec::with_capacity(corners.len());
        for c in corners {
            let mut parts = c.split('/');
            let v = self.index(
                parts.next().unwrap_or(""),
                self.positions.len() as u64,
                "vertex",
            )?;
            vertices.push(self.positions[v]);
            if let Some(t) = parts.next().filter(|t| !t.is_empty()) {
                self.index(t, self.texcoords, "texture coordinate")?;
            }
            if let Some(n) = parts.next().filter(|n| !n.is_empty()) {
                normals.push(self.normals[self.index(n, self.normals.len() as u64, "normal")?]);
            }
        }
        let smooth = normals.len() == vertices.len() && normals.iter().all(has_direction);
        Ok(Face {
            vertices,
            normals: smooth.then_some(normals),
            surface: self.surface,
        })
    }

    /// Reads the material libraries `files`, beside the OBJ file.
    fn libraries(&mut self, files: &[&str]) -> Result<(), MeshError> {
        let dir = self.path.parent().unwrap_or(Path::new(""));
        for f in files {
            let path = dir.join(f);
            let file = std::fs::File::open(&path)
                .map_err(|e| self.error(format!("cannot read its material library {f}: {e}")))?;
            self.libraries.push(path.clone());
            let (materials, _) =
                tobj::load_mtl_buf(&mut std::io::BufReader::new(file)).map_err(|e| {
                    MeshError::new(&path, Place::File, format!("not a material library: {e}"))
                })?;
            for m in materials {
                if self.materials.len() >= MAX_MATERIALS {
                    return Err(self.error(format!("more than {MAX_MATERIALS} materials")));
                }
                self.materials.insert(m.name.clone(), fill(&m));
            }
        }
        Ok(())
    }

    /// One line's statement.
    fn statement(&mut self, text: &str, each: &mut dyn FnMut(Face)) -> Result<(), MeshError> {
        let text = text.split('#').next().unwrap_or("");
        let words: Vec<&str> = text.split_whitespace().collect();
        let Some((&keyword, rest)) = words.split_first() else {
            return Ok(());
        };
        match keyword {
            "v" => {
                let xyz = self.numbers(rest, 3, "v")?;
                self.positions.push([xyz[0], xyz[1], xyz[2]]);
            }
            "vn" => {
                let n = self.numbers(rest, 3, "vn")?;
                self.normals.push([n[0], n[1], n[2]]);
            }
            "vt" => self.texcoords += 1,
            "f" | "fo" => each(self.face(rest)?),
            "usemtl" => {
                let name = text.trim_start()[keyword.len()..].trim();
                self.surface = self
                    .materials
                    .get(name)
                    .map_or(Surface::Default, |f| Surface::Fill(*f));
            }
            "mtllib" => self.libraries(rest)?,
            _ => {}
        }
        Ok(())
    }
}

/// An MTL material as NFF's fill.
fn fill(m: &tobj::Material) -> Fill {
    let rgb = |c: [f32; 3]| c.map(f64::from);
    let illum = m.illumination_model.unwrap_or(2);
    let ks = match (illum >= 3, m.specular) {
        (true, Some(s)) => rgb(s).iter().sum::<f64>() / 3.0,
        _ => 0.0,
    };
    let opacity = m.dissolve.map(f64::from).or_else(|| {
        let tr = m.unknown_param.get("Tr")?.trim().parse::<f64>().ok()?;
        Some(1.0 - tr)
    });
    Fill {
        color: m.diffuse.map_or([0.8; 3], rgb),
        kd: 1.0,
        ks: ks.clamp(0.0, 1.0),
        shine: m.shininess.map_or(100_000.0, f64::from).max(0.0),
        t: (1.0 - opacity.unwrap_or(1.0)).clamp(0.0, 1.0),
        ior: m.optical_density.map_or(1.0, f64::from).max(1e-3),
    }
}

/// Reads an OBJ file from `input`, handing each face to `each`: the number of vertices and
/// the material libraries read.
pub fn read_each(
    path: &Path,
    input: &mut dyn BufRead,
    each: &mut dyn FnMut(Face),
) -> Result<(u64, Vec<PathBuf>), MeshError> {
    let mut r = ObjReader {
        path,
        line: 0,
        positions: Vec::new(),
        normals: Vec::new(),
        texcoords: 0,
        materials: HashMap::new(),
        surface: Surface::Default,
        libraries: Vec::new(),
    };
    let mut bytes = Vec::new();
    loop {
        bytes.clear();
        r.line += 1;
        let n = input
            .read_until(b'\n', &mut bytes)
            .map_err(|e| r.error(format!("cannot read it: {e}")))?;
        if n == 0 {
            break;
        }
        let text =
            std::str::from_utf8(&bytes).map_err(|_| r.error("not a text file (not UTF-8)"))?;
        r.statement(text, each)?;
    }
    Ok((r.positions.len() as u64, r.libraries))
}
