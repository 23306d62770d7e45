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

/// `faces` as binary glTF (`.glb`): one mesh of triangles (a face of more corners is fanned
/// from its first), positions and, when any face has them, normals (zero for a face without:
/// flat when read back) as glTF's 32-bit floats (so coordinates that are not floats are
/// rounded), no indices, no material (read back as the neutral grey).
pub fn glb(faces: &[Face]) -> io::Result<Vec<u8>> {
    let with_normals = faces.iter().any(|f| f.normals.is_some());
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut normals: Vec<[f32; 3]> = Vec::new();
    let f32s = |v: &Vec3| v.map(|x| x as f32);
    for f in faces {
        for i in 1..f.vertices.len().saturating_sub(1) {
            for k in [0, i, i + 1] {
                positions.push(f32s(&f.vertices[k]));
                if with_normals {
                    normals.push(f.normals.as_ref().map_or([0.0; 3], |n| f32s(&n[k])));
                }
            }
        }
    }
    let count = positions.len();
    let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in &positions {
        min = std::array::from_fn(|i| min[i].min(p[i]));
        max = std::array::from_fn(|i| max[i].max(p[i]));
    }
    let mut bin: Vec<u8> = Vec::with_capacity(count * 24);
    for v in positions.iter().chain(&normals) {
        for x in v {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    let bytes = count * 12;
    let (normal_view, normal_accessor, normal_attr) = if with_normals {
        (
            format!(r#",{{"buffer":0,"byteOffset":{bytes},"byteLength":{bytes}}}"#),
            format!(r#",{{"bufferView":1,"componentType":5126,"count":{count},"type":"VEC3"}}"#),
            r#","NORMAL":1"#.to_string(),
        )
    } else {
        Default::default()
    };
    let json = format!(
        r#"{{"asset":{{"version":"2.0","generator":"sunray"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0{normal_attr}}}}}]}}],"buffers":[{{"byteLength":{}}}],"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{bytes}}}{normal_view}],"accessors":[{{"bufferView":0,"componentType":5126,"count":{count},"type":"VEC3","min":{:?},"max":{:?}}}{normal_accessor}]}}"#,
        bin.len(),
        min,
        max
    );
    let mut json = json.into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let total = u32::try_from(total).map_err(|_| io::Error::other("over 4 GiB for a .glb"))?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total.to_le_bytes());
    for (chunk, kind) in [(&json, b"JSON"), (&bin, b"BIN\0")] {
        out.extend_from_slice(&(chunk.len() as u32).to_le_bytes());
        out.extend_from_slice(kind);
        out.extend_from_slice(chunk);
    }
    Ok(out)
}
