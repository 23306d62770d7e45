//! Faces written out as OBJ (by hand: `tobj` reads only) or PLY (`ply-rs-bw`'s writer,
//! element by element, in any of its three encodings): the generators of the mesh fixtures,
//! which are written from SPD scenes, and `sunray convert IN.nff -o OUT.ply`. Corners at the
//! same place (with the same normal) are one vertex, as in the meshes tools write, so a
//! 4M-triangle tetra has about 2M vertices; coordinates read back bit for bit (OBJ: the
//! shortest decimal that does; PLY: doubles).

use super::Face;
use crate::ast::Vec3;
pub use ply_rs_bw::ply::Encoding as PlyEncoding;
use ply_rs_bw::ply::{
    Addable, ElementDef, Header, PropertyAccess, PropertyDef, PropertyType, ScalarType,
};
use ply_rs_bw::writer::Writer;
use std::collections::HashMap;
use std::io::{self, Write};

/// Numbers each distinct key once, in the order first seen.
#[derive(Default)]
struct Distinct<K> {
    index: HashMap<K, u32>,
    order: Vec<K>,
}

impl<K: Copy + Eq + std::hash::Hash> Distinct<K> {
    fn number(&mut self, k: K) -> u32 {
        let next = self.order.len() as u32;
        *self.index.entry(k).or_insert_with(|| {
            self.order.push(k);
            next
        })
    }
}

fn bits(p: &Vec3) -> [u64; 3] {
    p.map(f64::to_bits)
}

fn from_bits(b: [u64; 3]) -> Vec3 {
    b.map(f64::from_bits)
}

/// `faces` as OBJ text (`v`, `vn` where a face has normals, `f`).
pub fn obj<W: Write>(faces: &[Face], out: &mut W) -> io::Result<()> {
    let (mut points, mut normals) = (Distinct::default(), Distinct::default());
    let corners: Vec<Vec<(u32, Option<u32>)>> = faces
        .iter()
        .map(|f| {
            (0..f.vertices.len())
                .map(|i| {
                    let n = f.normals.as_ref().map(|n| normals.number(bits(&n[i])));
                    (points.number(bits(&f.vertices[i])), n)
                })
                .collect()
        })
        .collect();
    writeln!(out, "# {} faces", faces.len())?;
    for p in points.order.iter().map(|b| from_bits(*b)) {
        writeln!(out, "v {} {} {}", p[0], p[1], p[2])?;
    }
    for n in normals.order.iter().map(|b| from_bits(*b)) {
        writeln!(out, "vn {} {} {}", n[0], n[1], n[2])?;
    }
    for face in corners {
        write!(out, "f")?;
        for (v, n) in face {
            match n {
                Some(n) => write!(out, " {}//{}", v + 1, n + 1)?,
                None => write!(out, " {}", v + 1)?,
            }
        }
        writeln!(out)?;
    }
    Ok(())
}

/// A vertex as written: position and normal.
struct VertexOut([f64; 6]);

impl PropertyAccess for VertexOut {
    fn new() -> Self {
        VertexOut([0.0; 6])
    }
    fn get_double(&self, name: &str) -> Option<f64> {
        let i = ["x", "y", "z", "nx", "ny", "nz"]
            .iter()
            .position(|n| *n == name)?;
        Some(self.0[i])
    }
}

/// A face as written: its vertex numbers.
struct FaceOut(Vec<i32>);

impl PropertyAccess for FaceOut {
    fn new() -> Self {
        FaceOut(Vec::new())
    }
    fn get_list_int(&self, name: &str) -> Option<&[i32]> {
        (name == "vertex_indices").then_some(self.0.as_slice())
    }
}

/// `faces` as PLY in `encoding`; vertex normals when any face has them (a face without gets
/// zero normals, which read back as a flat face).
pub fn ply<W: Write>(faces: &[Face], encoding: PlyEncoding, out: &mut W) -> io::Result<()> {
    let with_normals = faces.iter().any(|f| f.normals.is_some());
    let key = |f: &Face, i: usize| -> [u64; 6] {
        let n = f.normals.as_ref().map_or([0.0; 3], |n| n[i]);
        let (p, n) = (bits(&f.vertices[i]), bits(&n));
        [p[0], p[1], p[2], n[0], n[1], n[2]]
    };
    let mut vertices = Distinct::default();
    for f in faces {
        if f.vertices.len() > usize::from(u8::MAX) {
            return Err(io::Error::other("a face of more than 255 corners"));
        }
        for i in 0..f.vertices.len() {
            vertices.number(key(f, i));
        }
    }
    let double = PropertyType::Scalar(ScalarType::Double);
    let names: &[&str] = if with_normals {
        &["x", "y", "z", "nx", "ny", "nz"]
    } else {
        &["x", "y", "z"]
    };
    let mut header = Header::new();
    header.encoding = encoding;
    let mut vertex = ElementDef::new("vertex".into());
    vertex.count = vertices.order.len();
    for name in names {
        vertex
            .properties
            .add(PropertyDef::new(name.to_string(), double.clone()));
    }
    let mut face = ElementDef::new("face".into());
    face.count = faces.len();
    face.properties.add(PropertyDef::new(
        "vertex_indices".into(),
        PropertyType::List(ScalarType::UChar, ScalarType::Int),
    ));
    header.elements.add(vertex.clone());
    header.elements.add(face.clone());
    let vw = Writer::<VertexOut>::new();
    let fw = Writer::<FaceOut>::new();
    let err = io::Error::other;
    vw.write_header(out, &header).map_err(err)?;
    for k in &vertices.order {
        let v = VertexOut(k.map(f64::from_bits));
        match encoding {
            PlyEncoding::Ascii => vw.write_ascii_element(out, &v, &vertex),
            PlyEncoding::BinaryLittleEndian => vw.write_little_endian_element(out, &v, &vertex),
            PlyEncoding::BinaryBigEndian => vw.write_big_endian_element(out, &v, &vertex),
        }
        .map_err(err)?;
    }
    for f in faces {
        let corners = (0..f.vertices.len())
            .map(|i| vertices.index[&key(f, i)] as i32)
            .collect();
        let e = FaceOut(corners);
        match encoding {
            PlyEncoding::Ascii => fw.write_ascii_element(out, &e, &face),
            PlyEncoding::BinaryLittleEndian => fw.write_little_endian_element(out, &e, &face),
            PlyEncoding::BinaryBigEndian => fw.write_big_endian_element(out, &e, &face),
        }
        .map_err(err)?;
    }
    Ok(())
}
