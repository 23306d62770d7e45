//! Closed polygon meshes. A transparent polygon is a thin sheet (light passes straight
//! through it) unless it is a face of a closed mesh: transparent polygons that together bound
//! a volume, every edge shared by exactly two of them and walked in opposite directions (a
//! consistently oriented, watertight surface). Such faces refract like a sphere's surface,
//! and the volume they bound is a medium, so a glass slab or prism bends light by Snell's law.
//!
//! Only transparent polygons are looked at (a scene pays nothing for this unless it has
//! some); vertices are matched exactly, as modellers and the SPD generators write them.

use super::Vec3;
use std::collections::HashMap;
use yari::model::{Shape, World};

/// How a polygon takes part in a closed mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Face {
    /// Not a face of a closed transparent mesh (a thin sheet, or not a polygon).
    Open,
    /// A face whose right-hand normal points out of the volume.
    Outward,
    /// A face whose right-hand normal points into the volume (the mesh is wound inside out).
    Inward,
}

/// A transparent static polygon: a candidate face of a closed mesh.
#[derive(Clone, Debug)]
pub struct Polygon {
    /// The object it is.
    pub object: usize,
    /// Its vertices in order.
    pub vertices: Vec<Vec3>,
}

impl Polygon {
    /// Object `object`, a polygon with `vertices`.
    pub fn new(object: usize, vertices: &[Vec3]) -> Polygon {
        Polygon {
            object,
            vertices: vertices.to_vec(),
        }
    }
}

/// Per object of `world`, how it takes part in a closed transparent mesh.
pub fn closed_faces(world: &World) -> Vec<Face> {
    let candidates: Vec<Polygon> = world
        .objects
        .iter()
        .enumerate()
        .filter_map(|(i, obj)| {
            let (Shape::Polygon { vertices } | Shape::SmoothPolygon { vertices, .. }) = &obj.shape
            else {
                return None;
            };
            let transparent = world
                .surfaces
                .get(obj.surface as usize)
                .is_some_and(|s| s.kst() > 0.0);
            (transparent && obj.motion == Vec3::ZERO).then(|| Polygon::new(i, vertices))
        })
        .collect();
    let mut faces = vec![Face::Open; world.objects.len()];
    let refs: Vec<&Polygon> = candidates.iter().collect();
    for (p, face) in candidates.iter().zip(closed_faces_of(&refs)) {
        faces[p.object] = face;
    }
    faces
}

/// How each of `candidates` (transparent static polygons) takes part in a closed mesh.
pub fn closed_faces_of(candidates: &[&Polygon]) -> Vec<Face> {
    let mut faces = vec![Face::Open; candidates.len()];
    let mut vertex_ids: HashMap<[u64; 3], u32> = HashMap::new();
    // Candidate polygons: (index in `candidates`, vertex ids in order, positions).
    let mut polys: Vec<(usize, Vec<u32>, Vec<Vec3>)> = Vec::new();
    for (i, candidate) in candidates.iter().enumerate() {
        let vertices = &candidate.vertices;
        let mut ids: Vec<u32> = Vec::with_capacity(vertices.len());
        let mut points = Vec::with_capacity(vertices.len());
        for &p in vertices {
            let key = (p + Vec3::ZERO).to_array().map(f64::to_bits); // -0 and +0 alike
            let next = vertex_ids.len() as u32;
            let id = *vertex_ids.entry(key).or_insert(next);
            if ids.last() != Some(&id) {
                ids.push(id);
                points.push(p);
            }
        }
        while ids.len() > 1 && ids.first() == ids.last() {
            ids.pop();
            points.pop();
        }
        if ids.len() >= 3 {
            polys.push((i, ids, points));
        }
    }
    if polys.is_empty() {
        return faces;
    }
    // Which polygon walks each directed edge; an edge walked twice the same way is not manifold.
    let mut owner: HashMap<(u32, u32), usize> = HashMap::new();
    let mut manifold = vec![true; polys.len()];
    for (p, (_, ids, _)) in polys.iter().enumerate() {
        for e in edges(ids) {
            if let Some(q) = owner.insert(e, p) {
                manifold[p] = false;
                manifold[q] = false;
            }
        }
    }
    // Join polygons across shared edges; a component is closed when every edge of every
    // polygon in it has its twin.
    let mut parent: Vec<usize> = (0..polys.len()).collect();
    for (p, (_, ids, _)) in polys.iter().enumerate() {
        for (a, b) in edges(ids) {
            match owner.get(&(b, a)) {
                Some(&q) => union(&mut parent, p, q),
                None => manifold[p] = false,
            }
        }
    }
    let mut closed: HashMap<usize, bool> = HashMap::new();
    let mut volume: HashMap<usize, f64> = HashMap::new();
    for (p, (_, _, points)) in polys.iter().enumerate() {
        let root = find(&mut parent, p);
        *closed.entry(root).or_insert(true) &= manifold[p];
        // Six times the signed volume: positive when the faces' normals point outwards.
        let v0 = points[0];
        *volume.entry(root).or_insert(0.0) += (1..points.len() - 1)
            .map(|k| v0.dot(points[k].cross(points[k + 1])))
            .sum::<f64>();
    }
    for (p, (object, _, _)) in polys.iter().enumerate() {
        let root = find(&mut parent, p);
        if !closed[&root] {
            continue;
        }
        let v = volume[&root];
        faces[*object] = if v > 0.0 {
            Face::Outward
        } else if v < 0.0 {
            Face::Inward
        } else {
            Face::Open
        };
    }
    faces
}

fn edges(ids: &[u32]) -> impl Iterator<Item = (u32, u32)> + '_ {
    (0..ids.len()).map(move |k| (ids[k], ids[(k + 1) % ids.len()]))
}

fn find(parent: &mut [usize], mut p: usize) -> usize {
    while parent[p] != p {
        parent[p] = parent[parent[p]];
        p = parent[p];
    }
    p
}

fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra] = rb;
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use yari::model::{Object, Surface};

    /// The six faces of the box [lo, hi], wound so their normals point out (or in).
    pub fn box_faces(lo: Vec3, hi: Vec3, outward: bool) -> Vec<Vec<Vec3>> {
        let c = |x: bool, y: bool, z: bool| {
            Vec3::new(
                if x { hi.x } else { lo.x },
                if y { hi.y } else { lo.y },
                if z { hi.z } else { lo.z },
            )
        };
        let (f, t) = (false, true);
        let mut faces = vec![
            vec![c(f, f, f), c(f, t, f), c(t, t, f), c(t, f, f)], // z = lo, normal -z
            vec![c(f, f, t), c(t, f, t), c(t, t, t), c(f, t, t)], // z = hi, normal +z
            vec![c(f, f, f), c(t, f, f), c(t, f, t), c(f, f, t)], // y = lo, normal -y
            vec![c(f, t, f), c(f, t, t), c(t, t, t), c(t, t, f)], // y = hi, normal +y
            vec![c(f, f, f), c(f, f, t), c(f, t, t), c(f, t, f)], // x = lo, normal -x
            vec![c(t, f, f), c(t, t, f), c(t, t, t), c(t, f, t)], // x = hi, normal +x
        ];
        if !outward {
            faces.iter_mut().for_each(|f| f.reverse());
        }
        faces
    }

    fn world_of(faces: Vec<Vec<Vec3>>, kdt: f64) -> World {
        let mut w = crate::bench::spd_world(yari::spd::Database::Tetra, 1).unwrap();
        w.surfaces = vec![Surface {
            kdt,
            ..Surface::default()
        }];
        w.objects = faces
            .into_iter()
            .map(|vertices| Object {
                shape: Shape::Polygon { vertices },
                surface: 0,
                motion: Vec3::ZERO,
            })
            .collect();
        w
    }

    #[test]
    fn a_glass_box_is_closed_and_oriented() {
        let faces = box_faces(Vec3::splat(-1.0), Vec3::new(2.0, 1.0, 0.5), true);
        assert_eq!(
            closed_faces(&world_of(faces.clone(), 0.0)),
            vec![Face::Outward; 6]
        );
        let inside_out = box_faces(Vec3::splat(-1.0), Vec3::ONE, false);
        assert_eq!(
            closed_faces(&world_of(inside_out, 0.0)),
            vec![Face::Inward; 6]
        );
        // Opaque faces are not looked at.
        assert_eq!(closed_faces(&world_of(faces, 1.0)), vec![Face::Open; 6]);
    }

    #[test]
    fn an_open_or_badly_wound_box_is_thin_sheets() {
        let mut lid_off = box_faces(Vec3::splat(-1.0), Vec3::ONE, true);
        lid_off.pop();
        assert_eq!(closed_faces(&world_of(lid_off, 0.0)), vec![Face::Open; 5]);
        let mut flipped = box_faces(Vec3::splat(-1.0), Vec3::ONE, true);
        flipped[2].reverse();
        assert_eq!(closed_faces(&world_of(flipped, 0.0)), vec![Face::Open; 6]);
    }

    #[test]
    fn two_boxes_are_judged_apart() {
        let mut faces = box_faces(Vec3::splat(-1.0), Vec3::ONE, true);
        let mut open = box_faces(Vec3::splat(3.0), Vec3::splat(4.0), true);
        open.pop();
        faces.extend(open);
        let got = closed_faces(&world_of(faces, 0.0));
        assert_eq!(&got[..6], &[Face::Outward; 6]);
        assert_eq!(&got[6..], &[Face::Open; 5]);
    }
}
