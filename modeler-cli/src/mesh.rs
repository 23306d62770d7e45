//! Polygon meshes with shared vertices, as revolve and extrude build them, and the checks
//! that make them trustworthy: closed (every edge shared by exactly two faces, traversed in
//! opposite directions) and outward (positive enclosed volume).

use crate::project::Primitive;
use glam::DVec3;
use std::collections::HashMap;

/// Faces index into one vertex table, so a shared edge has bit-identical end points.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// The vertex table, each vertex stored once.
    pub vertices: Vec<DVec3>,
    /// Each face as indices into `vertices`, 3 or more, counter-clockwise seen from outside
    /// when the mesh is outward.
    pub faces: Vec<Vec<usize>>,
    /// Smooth shading: for each face (when not empty), a normal per corner in the face's
    /// order, or `None` for a flat face.
    pub normals: Vec<Option<Vec<DVec3>>>,
}

impl Mesh {
    /// The enclosed volume, positive when the faces wind counter-clockwise seen from
    /// outside (their normals by the right-hand rule point out).
    pub fn signed_volume(&self) -> f64 {
        let mut six_v = 0.0;
        for f in &self.faces {
            let v0 = self.vertices[f[0]];
            for w in f[1..].windows(2) {
                six_v += v0.dot(self.vertices[w[0]].cross(self.vertices[w[1]]));
            }
        }
        six_v / 6.0
    }

    /// Reverses every face (its corner normals with it).
    pub fn flip(&mut self) {
        for f in &mut self.faces {
            f.reverse();
        }
        for n in self.normals.iter_mut().flatten() {
            n.reverse();
        }
    }

    /// Makes the faces face outward (positive volume).
    pub fn orient_outward(&mut self) {
        if self.signed_volume() < 0.0 {
            self.flip();
        }
    }

    /// Checks that the surface is closed and consistently oriented: every directed edge
    /// occurs once and its reverse occurs once. Returns the first problem found.
    pub fn check_closed(&self) -> Result<(), String> {
        let mut directed: HashMap<(usize, usize), usize> = HashMap::new();
        for (fi, f) in self.faces.iter().enumerate() {
            if f.len() < 3 {
                return Err(format!("face {fi} has {} vertices", f.len()));
            }
            for i in 0..f.len() {
                let (a, b) = (f[i], f[(i + 1) % f.len()]);
                if a == b {
                    return Err(format!("face {fi} repeats vertex {a}"));
                }
                *directed.entry((a, b)).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &directed {
            if n != 1 {
                return Err(format!(
                    "edge {a}->{b} is traversed {n} times in the same direction"
                ));
            }
            if !directed.contains_key(&(b, a)) {
                return Err(format!(
                    "edge {a}->{b} has no neighbour face (the surface is open there)"
                ));
            }
        }
        Ok(())
    }

    /// Checks that no two vertices of the table are at the same place, so that the
    /// index-based [`Mesh::check_closed`] speaks for the coordinates written out.
    pub fn check_welded(&self) -> Result<(), String> {
        let mut seen: HashMap<[u64; 3], usize> = HashMap::new();
        for (i, v) in self.vertices.iter().enumerate() {
            let key = [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
            if let Some(j) = seen.insert(key, i) {
                return Err(format!("vertices {j} and {i} are both at {v}"));
            }
        }
        Ok(())
    }

    /// The faces as YARI polygons (with `normals = ...` where a face has corner normals).
    pub fn to_primitives(&self) -> Vec<Primitive> {
        self.faces
            .iter()
            .enumerate()
            .map(|(k, f)| Primitive::Polygon {
                vertices: f.iter().map(|&i| self.vertices[i].to_array()).collect(),
                normals: self
                    .normals
                    .get(k)
                    .cloned()
                    .flatten()
                    .map(|n| n.iter().map(|v| v.to_array()).collect()),
            })
            .collect()
    }

    /// Rebuilds a mesh from polygons by merging bit-identical vertices (for checking an
    /// object read back from YARI).
    pub fn from_polygons<'a>(polygons: impl Iterator<Item = &'a [[f64; 3]]>) -> Mesh {
        let mut mesh = Mesh::default();
        let mut index: HashMap<[u64; 3], usize> = HashMap::new();
        for poly in polygons {
            let face = poly
                .iter()
                .map(|p| {
                    let key = [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()];
                    *index.entry(key).or_insert_with(|| {
                        mesh.vertices.push(DVec3::from_array(*p));
                        mesh.vertices.len() - 1
                    })
                })
                .collect();
            mesh.faces.push(face);
        }
        mesh
    }
}

/// Drops consecutive duplicates (and, for a closed outline, a last point equal to the first).
pub fn dedup_points(points: &[DVec3], closed: bool, eps: f64) -> Vec<DVec3> {
    let mut out: Vec<DVec3> = Vec::with_capacity(points.len());
    for &p in points {
        if out.last().is_none_or(|q| q.distance(p) > eps) {
            out.push(p);
        }
    }
    if closed && out.len() > 1 && out[0].distance(out[out.len() - 1]) <= eps {
        out.pop();
    }
    out
}

/// A size for tolerances: the largest coordinate magnitude (at least 1).
pub fn scale_of(points: &[DVec3]) -> f64 {
    points
        .iter()
        .map(|p| p.abs().max_element())
        .fold(1.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> Mesh {
        let vertices = (0..8)
            .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        let faces = vec![
            vec![0, 2, 3, 1],
            vec![4, 5, 7, 6],
            vec![0, 1, 5, 4],
            vec![2, 6, 7, 3],
            vec![0, 4, 6, 2],
            vec![1, 3, 7, 5],
        ];
        Mesh {
            vertices,
            faces,
            normals: Vec::new(),
        }
    }

    #[test]
    fn a_unit_cube_is_closed_with_volume_one() {
        let m = cube();
        m.check_closed().unwrap();
        m.check_welded().unwrap();
        assert!((m.signed_volume() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_missing_or_flipped_face_is_caught() {
        let mut open = cube();
        open.faces.pop();
        assert!(open.check_closed().unwrap_err().contains("open"));
        let mut flipped = cube();
        flipped.faces[0].reverse();
        assert!(flipped.check_closed().is_err());
        let mut inside_out = cube();
        inside_out.flip();
        inside_out.check_closed().unwrap();
        assert!(inside_out.signed_volume() < 0.0);
        inside_out.orient_outward();
        assert!(inside_out.signed_volume() > 0.0);
    }

    #[test]
    fn polygons_merge_back_into_the_same_mesh() {
        let m = cube();
        let polys: Vec<Vec<[f64; 3]>> = m
            .faces
            .iter()
            .map(|f| f.iter().map(|&i| m.vertices[i].to_array()).collect())
            .collect();
        let back = Mesh::from_polygons(polys.iter().map(|p| p.as_slice()));
        back.check_closed().unwrap();
        assert_eq!(back.faces.len(), 6);
        assert_eq!(back.vertices.len(), 8);
    }
}
