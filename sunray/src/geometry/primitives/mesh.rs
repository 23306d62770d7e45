//! The scene's static triangles as one indexed mesh: each distinct corner stored once, each
//! triangle three corner indices and its primitive's number, surface and normal in 24 bytes.
//! A triangle's plane normal is recomputed from its corners when that gives the polygon's
//! normal to the bit (every triangle that was a polygon of three corners), and kept in a
//! table of its own otherwise (the triangles of a larger polygon share one entry).
//!
//! Corners are stored in order of first use. The triangles stay in primitive order until an
//! accelerator's order is adopted ([`super::Primitives::adopt_order`]: the BVH's leaves),
//! so that the triangles a ray meets in a leaf lie side by side in memory.

use super::super::polygon::plane_normal;
use super::super::Vec3;
use crate::store::{Plain, Store};
use std::collections::HashMap;

/// `MeshTriangle::normal`: the triangle is a face of a closed transparent mesh.
const SOLID: u32 = 1 << 30;
/// `MeshTriangle::normal`: the normal is the negated stored or recomputed one.
const FLIP: u32 = 1 << 31;
/// `MeshTriangle::normal`'s low bits when the normal is recomputed from the corners.
const RECOMPUTED: u32 = SOLID - 1;

/// One triangle of the mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct MeshTriangle {
    /// Its corners: indices into [`Mesh::vertices`], in the polygon's winding.
    pub v: [u32; 3],
    /// Its number among the scene's primitives (ties between equal hits go to the lower).
    pub prim: u32,
    /// Its surface: an index into the world's surfaces.
    pub surface: u32,
    /// Low 30 bits: an index into [`Mesh::normals`], or all ones when the normal is
    /// recomputed from the corners; bit 30: a face of a closed transparent mesh; bit 31:
    /// the normal is negated (a face of a mesh wound inside out).
    normal: u32,
}

// SAFETY: `repr(C)` of six u32 (no padding, any bits valid), put in that order.
unsafe impl Plain for MeshTriangle {
    fn put(&self, out: &mut Vec<u8>) {
        for w in self.v.iter().chain(&[self.prim, self.surface, self.normal]) {
            w.put(out);
        }
    }
}

/// Indexed static triangles (see the module's text).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Distinct corners.
    pub vertices: Store<Vec3>,
    /// The triangles.
    pub triangles: Store<MeshTriangle>,
    /// Normals that cannot be recomputed from a triangle's corners.
    normals: Vec<Vec3>,
    /// Corner positions (their exact bits) to their index, while the mesh is built.
    ids: HashMap<[u64; 3], u32, foldhash::fast::RandomState>,
}

impl Mesh {
    /// Adds the triangles of one polygon, with the polygon's unit `normal`, for primitives
    /// numbered from `first_prim`; the positions of the new triangles in
    /// [`Mesh::triangles`].
    pub fn add_polygon(
        &mut self,
        triangles: &[[Vec3; 3]],
        normal: Vec3,
        first_prim: u32,
        surface: u32,
    ) -> std::ops::Range<usize> {
        let start = self.triangles.len();
        let mut stored = None;
        for (k, corners) in triangles.iter().enumerate() {
            let recomputed = plane_normal(corners);
            let same =
                recomputed.to_array().map(f64::to_bits) == normal.to_array().map(f64::to_bits);
            let n = if same {
                RECOMPUTED
            } else {
                *stored.get_or_insert_with(|| {
                    self.normals.push(normal);
                    (self.normals.len() - 1) as u32
                })
            };
            let v = corners.map(|p| self.vertex(p));
            self.triangles.edit().push(MeshTriangle {
                v,
                prim: first_prim + k as u32,
                surface,
                normal: n,
            });
        }
        start..self.triangles.len()
    }

    /// The index of corner `p`, added if new. Corners are the same only when every bit is
    /// (so -0 and +0 stay apart, and the corners given are the corners intersected).
    fn vertex(&mut self, p: Vec3) -> u32 {
        let next = self.vertices.len() as u32;
        let id = *self
            .ids
            .entry(p.to_array().map(f64::to_bits))
            .or_insert(next);
        if id == next {
            self.vertices.edit().push(p);
        }
        id
    }

    /// Marks the triangles at `range` as faces of a closed transparent mesh, their normals
    /// negated when `flip`.
    pub fn make_solid(&mut self, range: std::ops::Range<usize>, flip: bool) {
        for t in &mut self.triangles.edit()[range] {
            t.normal |= SOLID | if flip { FLIP } else { 0 };
        }
    }

    /// The corners of `t`.
    #[inline(always)]
    pub fn corners(&self, t: &MeshTriangle) -> [Vec3; 3] {
        t.v.map(|i| self.vertices[i as usize])
    }

    /// The unit plane normal of `t`, exactly the polygon's (negated for an inward face).
    #[inline]
    pub fn normal(&self, t: &MeshTriangle) -> Vec3 {
        let index = t.normal & RECOMPUTED;
        let n = if index == RECOMPUTED {
            plane_normal(&self.corners(t))
        } else {
            self.normals[index as usize]
        };
        if t.normal & FLIP != 0 {
            -n
        } else {
            n
        }
    }

    /// Whether `t`'s normal is its own plane's, recomputed from its corners (not a larger or
    /// warped polygon's, nor one given with the triangle).
    pub fn has_plane_normal(t: &MeshTriangle) -> bool {
        t.normal & RECOMPUTED == RECOMPUTED
    }

    /// Whether `t`'s normal is the negated plane normal (a face of a mesh wound inside out).
    #[inline]
    pub fn is_flipped(t: &MeshTriangle) -> bool {
        t.normal & FLIP != 0
    }

    /// Whether `t` is a face of a closed transparent mesh.
    #[inline]
    pub fn is_solid(t: &MeshTriangle) -> bool {
        t.normal & SOLID != 0
    }

    /// Ends the building: forgets the corner index. (Corners were added in order of first
    /// use, so nothing needs renumbering until the triangles are reordered.)
    pub fn finish(&mut self) {
        self.ids = HashMap::default();
        self.triangles.edit().shrink_to_fit();
        self.vertices.edit().shrink_to_fit();
        self.normals.shrink_to_fit();
    }

    /// Moves triangle `k` to `new[k]` (a permutation), and renumbers the corners by first
    /// use in the new order.
    pub fn permute(&mut self, new: &[u32]) {
        super::permute(&mut self.triangles.edit(), new);
        self.renumber_vertices();
    }

    /// Puts the corners in order of first use by the triangles.
    fn renumber_vertices(&mut self) {
        let old = std::mem::take(&mut self.vertices);
        let mut renumbered = vec![u32::MAX; old.len()];
        let mut vertices = Vec::with_capacity(old.len());
        for t in self.triangles.edit().iter_mut() {
            for v in &mut t.v {
                let new = &mut renumbered[*v as usize];
                if *new == u32::MAX {
                    *new = vertices.len() as u32;
                    vertices.push(old[*v as usize]);
                }
                *v = *new;
            }
        }
        self.vertices = vertices.into();
    }

    /// Bytes held (for the memory figures).
    pub fn bytes(&self) -> usize {
        self.vertices.owned_bytes()
            + self.triangles.owned_bytes()
            + self.normals.capacity() * std::mem::size_of::<Vec3>()
    }

    /// Normals that cannot be recomputed from a triangle's corners (for a prepared scene).
    pub fn normals(&self) -> &[Vec3] {
        &self.normals
    }

    /// The mesh of finished tables (a prepared scene's, read back), checked: every corner
    /// and stored normal a triangle names exists.
    pub fn from_tables(
        vertices: Store<Vec3>,
        triangles: Store<MeshTriangle>,
        normals: Vec<Vec3>,
    ) -> Result<Mesh, String> {
        let corners = vertices.len() as u32;
        let stored = normals.len() as u32;
        let bad = triangles.iter().any(|t| {
            let n = t.normal & RECOMPUTED;
            t.v.iter().any(|&v| v >= corners) || (n != RECOMPUTED && n >= stored)
        });
        if bad {
            return Err("a triangle names a corner or normal that is not there".into());
        }
        Ok(Mesh {
            vertices,
            triangles,
            normals,
            ids: HashMap::default(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_are_shared_and_normals_exact() {
        let mut m = Mesh::default();
        let (a, b, c, d) = (Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0));
        // One triangle polygon: its normal is recomputed; a quad: one stored normal.
        let n1 = plane_normal(&[a, b, c]);
        m.add_polygon(&[[a, b, c]], n1, 0, 0);
        let quad = plane_normal(&[a, b, d, c]);
        m.add_polygon(&[[a, b, d], [a, d, c]], quad, 1, 0);
        m.finish();
        assert_eq!(m.vertices.len(), 4, "corners are stored once");
        assert_eq!(m.triangles.len(), 3);
        for t in &m.triangles {
            let want = if t.prim == 0 { n1 } else { quad };
            assert_eq!(
                m.normal(t).to_array().map(f64::to_bits),
                want.to_array().map(f64::to_bits)
            );
        }
        assert!(m.normals.len() <= 1);
        // -0 and +0 are different corners.
        let mut z = Mesh::default();
        let neg = Vec3::new(-0.0, 0.0, 0.0);
        z.add_polygon(&[[Vec3::ZERO, Vec3::X, Vec3::Y]], n1, 0, 0);
        z.add_polygon(&[[neg, Vec3::X, Vec3::Y]], n1, 1, 0);
        z.finish();
        assert_eq!(z.vertices.len(), 4);
    }

    #[test]
    fn solid_faces_keep_their_flag_and_flip_their_normal() {
        let mut m = Mesh::default();
        let n = plane_normal(&[Vec3::ZERO, Vec3::X, Vec3::Y]);
        let r = m.add_polygon(&[[Vec3::ZERO, Vec3::X, Vec3::Y]], n, 0, 3);
        m.make_solid(r, true);
        m.finish();
        let t = m.triangles[0];
        assert!(Mesh::is_solid(&t));
        assert_eq!(m.normal(&t), -n);
        assert_eq!(t.surface, 3);
    }
}
