//! The bytes of a prepared scene file (little-endian):
//!
//! - a header of 128 bytes: the magic `SUNRAYP1`, the model's hash (u64), then for each of
//!   the seven sections its byte offset and its length in items (two u64);
//! - the sections, each at an offset that is a multiple of 64: the world without its objects
//!   (a yari model file), the rest of the scene (postcard: object count, dropped objects,
//!   the primitives' small tables, [`crate::geometry::primitives::parts::Rest`]), then the
//!   flat tables as they lie in memory: primitive slots (u32), corners (3 f64), triangles
//!   (6 u32), BVH nodes (256 bytes), leaf items (u32);
//! - the checksum of everything before it ([`super::checksum`], u64).
//!
//! [`open`] checks the magic, the length, the checksum, and that every section lies within
//! the file, aligned and in order; the tables are then views into the mapping.

use super::checksum::checksum;
use crate::accel::bvh::wide::Node;
use crate::geometry::primitives::mesh::MeshTriangle;
use crate::geometry::primitives::Slot;
use crate::geometry::Vec3;
use crate::store::{Plain, Store};
use memmap2::Mmap;
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

const MAGIC: &[u8; 8] = b"SUNRAYP1";
/// How many sections a file has.
const SECTIONS: usize = 7;
const HEADER: usize = 16 + SECTIONS * 16;
const ALIGN: usize = 64;

/// The sections, in file order.
#[derive(Clone, Copy, Debug)]
pub enum Section {
    /// The world without its objects (a yari model file).
    World,
    /// The rest of the scene (postcard).
    Rest,
    /// Primitive number to slot.
    Slots,
    /// The mesh's corners.
    Vertices,
    /// The mesh's triangles.
    Triangles,
    /// The BVH's nodes.
    Nodes,
    /// The BVH's leaf items.
    Items,
}

/// What a file is written from.
pub struct Contents<'a> {
    /// The model's hash.
    pub model_hash: u64,
    /// [`Section::World`]'s bytes.
    pub world: &'a [u8],
    /// [`Section::Rest`]'s bytes.
    pub rest: &'a [u8],
    /// The primitives' slots.
    pub slots: &'a [Slot],
    /// The mesh's corners.
    pub vertices: &'a [Vec3],
    /// The mesh's triangles.
    pub triangles: &'a [MeshTriangle],
    /// The BVH's nodes.
    pub nodes: &'a [Node],
    /// The BVH's leaf items.
    pub items: &'a [Slot],
}

fn align(at: usize) -> usize {
    at.div_ceil(ALIGN) * ALIGN
}

/// Writes `c` to a new file at `path` (the caller renames it into place); its length and
/// checksum.
pub fn write(path: &Path, c: &Contents) -> std::io::Result<(u64, u64)> {
    let sizes = [
        (c.world.len(), 1),
        (c.rest.len(), 1),
        (c.slots.len(), 4),
        (c.vertices.len(), std::mem::size_of::<Vec3>()),
        (c.triangles.len(), std::mem::size_of::<MeshTriangle>()),
        (c.nodes.len(), std::mem::size_of::<Node>()),
        (c.items.len(), 4),
    ];
    let mut header = Vec::with_capacity(HEADER);
    header.extend_from_slice(MAGIC);
    header.extend_from_slice(&c.model_hash.to_le_bytes());
    let mut at = HEADER;
    for (count, size) in sizes {
        at = align(at);
        header.extend_from_slice(&(at as u64).to_le_bytes());
        header.extend_from_slice(&(count as u64).to_le_bytes());
        at += count * size;
    }
    // Readable too: it is mapped for its checksum once written.
    let file = std::fs::File::options()
        .read(true)
        .write(true)
        .create(true)
        .truncate(true)
        .open(path)?;
    let mut out = Sink {
        out: std::io::BufWriter::with_capacity(1 << 20, &file),
        written: 0,
    };
    out.section(&header)?;
    out.section(c.world)?;
    out.section(c.rest)?;
    out.table(c.slots)?;
    out.table(c.vertices)?;
    out.table(c.triangles)?;
    out.table(c.nodes)?;
    out.table(c.items)?;
    let written = out.written;
    out.out.flush()?;
    drop(out);
    // SAFETY: the file was just made by this process under a name of its own; nothing
    // else changes it while it is mapped here.
    let map = unsafe { Mmap::map(&file)? };
    let sum = checksum(&map);
    drop(map);
    let mut file = file;
    file.write_all(&sum.to_le_bytes())?;
    file.sync_all()?;
    Ok((written as u64 + 8, sum))
}

/// A file being written, and how many bytes it has.
struct Sink<W: Write> {
    out: W,
    written: usize,
}

impl<W: Write> Sink<W> {
    /// Zeros up to the next multiple of 64, then `bytes`.
    fn section(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        let start = align(self.written);
        self.out.write_all(&vec![0; start - self.written])?;
        self.out.write_all(bytes)?;
        self.written = start + bytes.len();
        Ok(())
    }

    /// `items` as one section, put a megabyte at a time.
    fn table<T: Plain>(&mut self, items: &[T]) -> std::io::Result<()> {
        self.section(&[])?;
        let per = ((1 << 20) / std::mem::size_of::<T>()).max(1);
        for chunk in items.chunks(per) {
            let bytes = crate::store::bytes_of(chunk);
            self.out.write_all(&bytes)?;
            self.written += bytes.len();
        }
        Ok(())
    }
}

/// A prepared scene file mapped, its checksum and sections checked.
pub struct Opened {
    map: Arc<Mmap>,
    /// The model's hash it says.
    pub model_hash: u64,
    /// Its length and checksum.
    pub len_sum: (u64, u64),
    sections: [(usize, usize); SECTIONS],
}

/// Maps and checks the file at `path` (see the module's text).
pub fn open(path: &Path) -> Result<Opened, String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    // SAFETY: cache files are never changed in place: they are written under another name
    // and renamed over (a new inode), so this mapping's bytes stay as they are; a file cut
    // short under a mapping would raise SIGBUS, which no writer here does.
    let map = Arc::new(unsafe { Mmap::map(&file) }.map_err(|e| e.to_string())?);
    let Some((body, sum)) = map.split_last_chunk::<8>() else {
        return Err("too short".into());
    };
    if body.len() < HEADER || &body[..8] != MAGIC {
        return Err("no prepared scene header".into());
    }
    let sum = u64::from_le_bytes(*sum);
    if checksum(body) != sum {
        return Err("checksum mismatch".into());
    }
    let word = |k: usize| {
        let at = 8 + 8 * k;
        u64::from_le_bytes(body[at..at + 8].try_into().unwrap_or([0xff; 8]))
    };
    let mut sections = [(0, 0); SECTIONS];
    let mut end = HEADER;
    for (k, s) in sections.iter_mut().enumerate() {
        let (offset, count) = (word(1 + 2 * k) as usize, word(2 + 2 * k) as usize);
        if offset < end || !offset.is_multiple_of(ALIGN) || offset > body.len() {
            return Err("a section out of place".into());
        }
        *s = (offset, count);
        end = offset;
    }
    Ok(Opened {
        model_hash: word(0),
        len_sum: (map.len() as u64, sum),
        sections,
        map,
    })
}

impl Opened {
    /// The bytes of a byte section.
    pub fn bytes(&self, s: Section) -> Result<&[u8], String> {
        let (offset, count) = self.sections[s as usize];
        let end = offset
            .checked_add(count)
            .filter(|&e| e <= self.map.len() - 8);
        end.map(|end| &self.map[offset..end])
            .ok_or_else(|| format!("{s:?} past the end"))
    }

    /// A table section, as a view into the mapping.
    pub fn table<T: Plain>(&self, s: Section) -> Result<Store<T>, String> {
        let (offset, count) = self.sections[s as usize];
        let within = count
            .checked_mul(std::mem::size_of::<T>())
            .and_then(|b| b.checked_add(offset))
            .is_some_and(|end| end <= self.map.len() - 8);
        if !within {
            return Err(format!("{s:?} past the end"));
        }
        Store::mapped(&self.map, offset, count).map_err(|e| format!("{s:?}: {e}"))
    }
}
