//! PLY, ASCII or binary in either byte order, through the `ply-rs-bw` crate: its parser reads
//! the header, then this reader takes the elements in order one at a time
//! (`read_ascii_element`, `read_{little,big}_endian_element`), so vertices are held (faces
//! refer to them) and each face goes on as soon as it is read. The crate caps what it
//! allocates for a count it has not read yet, so a header that claims billions costs nothing.
//!
//! Read: `vertex` (`x y z`, with `nx ny nz` and `red green blue`, bytes or 0-1 floats, where
//! present) and `face` (`vertex_indices` or `vertex_index`, and an optional face colour);
//! other elements (edges, materials) are read and skipped.

use super::{Face, MeshError, Place, Surface};
use crate::ast::{has_direction, Vec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{ElementDef, Encoding, PropertyAccess, PropertyAccessResult};
use std::io::{BufRead, Read};
use std::path::Path;

/// One vertex as read; `has` says which fields the file gave (a bit each, see `slot`).
#[derive(Clone, Copy, Debug, Default)]
struct PlyVertex {
    p: Vec3,
    n: Vec3,
    c: Vec3,
    has: u16,
}

/// The bits of `PlyVertex::has` for x, y and z.
const POSITION: u16 = 0b111;

fn slot(name: &str) -> Option<(usize, u16)> {
    Some(match name {
        "x" => (0, 1),
        "y" => (1, 2),
        "z" => (2, 4),
        "nx" => (3, 8),
        "ny" => (4, 16),
        "nz" => (5, 32),
        "red" | "diffuse_red" => (6, 64),
        "green" | "diffuse_green" => (7, 128),
        "blue" | "diffuse_blue" => (8, 256),
        _ => return None,
    })
}

impl PlyVertex {
    fn set(&mut self, name: &str, v: f64, byte: bool) -> PropertyAccessResult {
        let Some((i, bit)) = slot(name) else {
            return PropertyAccessResult::Ignored;
        };
        match i {
            0..=2 => self.p[i] = v,
            3..=5 => self.n[i - 3] = v,
            _ => self.c[i - 6] = if byte { v / 255.0 } else { v },
        }
        self.has |= bit;
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        PlyVertex::default()
    }
    fn set_uchar(&mut self, name: &str, v: u8) -> PropertyAccessResult {
        self.set(name, f64::from(v), true)
    }
    fn set_float(&mut self, name: &str, v: f32) -> PropertyAccessResult {
        self.set(name, f64::from(v), false)
    }
    fn set_double(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        self.set(name, v, false)
    }
    fn set_int(&mut self, name: &str, v: i32) -> PropertyAccessResult {
        self.set(name, f64::from(v), false)
    }
    fn set_short(&mut self, name: &str, v: i16) -> PropertyAccessResult {
        self.set(name, f64::from(v), false)
    }
}

/// One face as read: its vertex indices and its own colour, if any.
#[derive(Clone, Debug, Default)]
struct PlyFace {
    indices: Vec<i64>,
    c: Vec3,
    has_colour: u8,
}

impl PlyFace {
    fn list(&mut self, name: &str, v: impl Iterator<Item = i64>) -> PropertyAccessResult {
        if name == "vertex_indices" || name == "vertex_index" {
            self.indices = v.collect();
            PropertyAccessResult::Set
        } else {
            PropertyAccessResult::Ignored
        }
    }

    fn colour(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        let i = match name {
            "red" => 0,
            "green" => 1,
            "blue" => 2,
            _ => return PropertyAccessResult::Ignored,
        };
        self.c[i] = v;
        self.has_colour |= 1 << i;
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        PlyFace::default()
    }
    fn set_list_int(&mut self, name: &str, v: Vec<i32>) -> PropertyAccessResult {
        self.list(name, v.into_iter().map(i64::from))
    }
    fn set_list_uint(&mut self, name: &str, v: Vec<u32>) -> PropertyAccessResult {
        self.list(name, v.into_iter().map(i64::from))
    }
    fn set_list_short(&mut self, name: &str, v: Vec<i16>) -> PropertyAccessResult {
        self.list(name, v.into_iter().map(i64::from))
    }
    fn set_list_ushort(&mut self, name: &str, v: Vec<u16>) -> PropertyAccessResult {
        self.list(name, v.into_iter().map(i64::from))
    }
    fn set_list_uchar(&mut self, name: &str, v: Vec<u8>) -> PropertyAccessResult {
        self.list(name, v.into_iter().map(i64::from))
    }
    fn set_uchar(&mut self, name: &str, v: u8) -> PropertyAccessResult {
        self.colour(name, f64::from(v) / 255.0)
    }
    fn set_float(&mut self, name: &str, v: f32) -> PropertyAccessResult {
        self.colour(name, f64::from(v))
    }
}

/// An element of another kind, read and dropped.
struct Skipped;

impl PropertyAccess for Skipped {
    fn new() -> Self {
        Skipped
    }
}

/// A reader that counts the bytes and lines taken from it, for the place of an error. Lines
/// are counted only while `lines_wanted` (the header, and an ASCII payload): a binary payload
/// is not scanned for newlines it does not have.
struct Counting<'a> {
    inner: &'a mut dyn BufRead,
    bytes: u64,
    lines: u64,
    lines_wanted: bool,
}

impl Read for Counting<'_> {
    fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
        let n = {
            let buf = self.fill_buf()?;
            let n = buf.len().min(out.len());
            out[..n].copy_from_slice(&buf[..n]);
            n
        };
        self.consume(n);
        Ok(n)
    }
}

impl BufRead for Counting<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        self.inner.fill_buf()
    }
    fn consume(&mut self, n: usize) {
        if self.lines_wanted {
            if let Ok(buf) = self.inner.fill_buf() {
                self.lines += buf[..n.min(buf.len())]
                    .iter()
                    .filter(|b| **b == b'\n')
                    .count() as u64;
            }
        }
        self.bytes += n as u64;
        self.inner.consume(n);
    }
}

/// The reader of one file: its header's encoding, where it is, and the vertices so far
/// (positions always; normals and colours only when the vertex element declares them, so a
/// plain mesh costs 24 bytes a vertex).
struct PlyReader<'a> {
    path: &'a Path,
    reader: Reader<Counting<'a>>,
    encoding: Encoding,
    line: String,
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    colours: Option<Vec<Vec3>>,
}

impl<'a> PlyReader<'a> {
    /// Where the next element starts.
    fn place(&self) -> Place {
        let c = self.reader.get_ref();
        match self.encoding {
            Encoding::Ascii => Place::Line(c.lines + 1),
            _ => Place::Byte(c.bytes),
        }
    }

    fn error(&self, place: Place, message: impl Into<String>) -> MeshError {
        MeshError::new(self.path, place, message)
    }

    /// The next element of `def` (number `i`, from 0).
    fn element<E: PropertyAccess>(
        &mut self,
        parser: &Parser<E>,
        def: &ElementDef,
        i: usize,
    ) -> Result<E, MeshError> {
        let at = self.place();
        let ends = || {
            format!(
                "the file ends inside {} {} of {} (truncated?)",
                def.name,
                i + 1,
                def.count
            )
        };
        let read = match self.encoding {
            Encoding::Ascii => {
                self.line.clear();
                let n = self
                    .reader
                    .get_mut()
                    .read_line(&mut self.line)
                    .map_err(|e| self.error(at, format!("cannot read it: {e}")))?;
                if n == 0 {
                    return Err(self.error(at, ends()));
                }
                parser.read_ascii_element(&self.line, def)
            }
            Encoding::BinaryLittleEndian => {
                parser.read_little_endian_element(self.reader.get_mut(), def)
            }
            Encoding::BinaryBigEndian => parser.read_big_endian_element(self.reader.get_mut(), def),
        };
        read.map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => self.error(at, ends()),
            _ if self.encoding == Encoding::Ascii => {
                let names: Vec<&str> = def.properties.keys().map(String::as_str).collect();
                let text: String = self.line.trim().chars().take(60).collect();
                self.error(
                    at,
                    format!(
                        "{} {}: {text:?} is not numbers for {}",
                        def.name,
                        i + 1,
                        names.join(" ")
                    ),
                )
            }
            _ => self.error(at, format!("{} {}: {}", def.name, i + 1, first_line(&e))),
        })
    }

    fn vertex(&mut self, v: PlyVertex, i: usize, at: Place) -> Result<(), MeshError> {
        if v.has & POSITION != POSITION {
            return Err(self.error(at, format!("vertex {} has no x, y and z", i + 1)));
        }
        if v.p.iter().chain(&v.n).chain(&v.c).any(|x| !x.is_finite()) {
            return Err(self.error(
                at,
                format!("vertex {} has a value that is not a finite number", i + 1),
            ));
        }
        self.positions.push(v.p);
        if let Some(n) = &mut self.normals {
            n.push(v.n);
        }
        if let Some(c) = &mut self.colours {
            c.push(v.c);
        }
        Ok(())
    }

    /// Keeps normals and colours when the vertex element `def` declares all three of them.
    fn declared(&mut self, def: &ElementDef) {
        let has = |names: [&str; 3]| names.iter().all(|n| def.properties.contains_key(*n));
        self.normals = has(["nx", "ny", "nz"]).then(Vec::new);
        self.colours = (has(["red", "green", "blue"])
            || has(["diffuse_red", "diffuse_green", "diffuse_blue"]))
        .then(Vec::new);
    }

    fn face(&self, f: PlyFace, i: usize, at: Place) -> Result<Face, MeshError> {
        if f.indices.len() < 3 {
            return Err(self.error(
                at,
                format!(
                    "face {} has {} corners (at least 3)",
                    i + 1,
                    f.indices.len()
                ),
            ));
        }
        let mut corners = Vec::with_capacity(f.indices.len());
        for &k in &f.indices {
            match usize::try_from(k)
                .ok()
                .filter(|k| *k < self.positions.len())
            {
                Some(k) => corners.push(k),
                None => {
                    return Err(self.error(
                        at,
                        format!(
                            "face {}: vertex index {k} is out of range (the file has {} \
                             vertices, numbered from 0)",
                            i + 1,
                            self.positions.len()
                        ),
                    ))
                }
            }
        }
        let normals = self
            .normals
            .as_ref()
            .map(|n| corners.iter().map(|&k| n[k]).collect::<Vec<_>>())
            .filter(|n| n.iter().all(has_direction));
        let surface = match &self.colours {
            _ if f.has_colour == 0b111 => Surface::Colour(f.c),
            Some(c) => {
                let n = corners.len() as f64;
                Surface::Colour(std::array::from_fn(|j| {
                    corners.iter().map(|&k| c[k][j]).sum::<f64>() / n
                }))
            }
            None => Surface::Default,
        };
        Ok(Face {
            vertices: corners.iter().map(|&k| self.positions[k]).collect(),
            normals,
            surface,
        })
    }
}

/// The first line of an error of the crate (some run over several).
fn first_line(e: &impl std::fmt::Display) -> String {
    let s = e.to_string();
    s.lines().next().unwrap_or_default().trim().to_string()
}

/// Reads a PLY file from `input`, handing each face to `each`: the number of vertices.
pub fn read_each(
    path: &Path,
    input: &mut dyn BufRead,
    each: &mut dyn FnMut(Face),
) -> Result<u64, MeshError> {
    let counting = Counting {
        inner: input,
        bytes: 0,
        lines: 0,
        lines_wanted: true,
    };
    let mut reader = Reader::new(counting);
    let vertex_parser = Parser::<PlyVertex>::new();
    let face_parser = Parser::<PlyFace>::new();
    let skip_parser = Parser::<Skipped>::new();
    let header = vertex_parser.read_header(&mut reader).map_err(|e| {
        let line = reader.get_ref().lines + 1;
        MeshError::new(
            path,
            Place::Line(line),
            format!("not a PLY header: {}", first_line(&e)),
        )
    })?;
    reader.get_mut().lines_wanted = header.encoding == Encoding::Ascii;
    let mut r = PlyReader {
        path,
        reader,
        encoding: header.encoding,
        line: String::new(),
        positions: Vec::new(),
        normals: None,
        colours: None,
    };
    let mut seen_vertices = false;
    for (name, def) in &header.elements {
        if name == "vertex" {
            r.declared(def);
        }
        for i in 0..def.count {
            let at = r.place();
            match name.as_str() {
                "vertex" => {
                    let v = r.element(&vertex_parser, def, i)?;
                    r.vertex(v, i, at)?;
                    seen_vertices = true;
                }
                "face" if !seen_vertices && def.count > 0 => {
                    return Err(r.error(at, "faces come before any vertex element"));
                }
                "face" => {
                    let f = r.element(&face_parser, def, i)?;
                    each(r.face(f, i, at)?);
                }
                _ => {
                    r.element(&skip_parser, def, i)?;
                }
            }
        }
    }
    Ok(r.positions.len() as u64)
}
