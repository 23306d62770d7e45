//! Haines's polygonal patch output (his `-t` option, `OUTPUT_PATCHES`), NFF branch, kept step
//! for step so the triangles print as his programs print them: `lib_output_polygon_sphere`
//! and `lib_output_polygon_cylcone` of `libply.c`, each triangle written through
//! `lib_output_polypatch` ([`polypatch_triangle`], also used by `teapot`) as a `pp 3`
//! (vertices and unit normals, in his order).
//!
//! Under a transformation (`jacks`) the shapes are made in object space and each triangle is
//! then transformed as his `split_polygon` does: vertices as points by the current matrix,
//! normals by the transpose of its inverse, not renormalized (a scaled jack's normals are
//! longer than 1 in his files, and in ours).

use super::haines_lib::{
    axis_rotate_matrix, cross, invert_matrix, normalize, normalize_len, rotate_cube_face,
    rotate_matrix, transform_normal, transform_point, transform_vector, Axis, Coord4, Matrix,
};
use crate::nff::{Entity, NffScene};
use std::f64::consts::PI;

/// `EPSILON2` of `def.h`: a cylinder axis this close to z is crossed with x instead.
const EPSILON2: f64 = 1.0e-6;

/// The current transformation of `libtx.c` when it is active, with its inverse (for
/// normals), as `split_polygon` uses them.
#[derive(Clone, Copy, Debug)]
pub struct PatchTx {
    matrix: Matrix,
    inverse: Matrix,
}

impl PatchTx {
    /// The transformation `matrix` (row vectors, as [`super::haines_output::TxStack`] keeps it).
    pub fn new(matrix: &Matrix) -> PatchTx {
        PatchTx {
            matrix: *matrix,
            inverse: invert_matrix(matrix),
        }
    }
}

/// `lib_output_polypatch` for a triangle: his polygon splitter returns a triangle as it is,
/// so this is one `pp 3` with the vertices and normals in order.
pub fn polypatch_triangle(s: &mut NffScene, vert: [[f64; 3]; 3], norm: [[f64; 3]; 3]) {
    s.push(Entity::Polygon {
        vertices: vert.to_vec(),
        normals: Some(norm.to_vec()),
    });
}

/// `lib_output_polypatch` for a triangle, under `tx` if any: his splitter returns a triangle
/// as it is (it never drops one), then transforms it.
fn patch(s: &mut NffScene, tx: Option<&PatchTx>, vert: [[f64; 3]; 3], norm: [[f64; 3]; 3]) {
    match tx {
        None => polypatch_triangle(s, vert, norm),
        Some(t) => polypatch_triangle(
            s,
            vert.map(|v| transform_point(v, &t.matrix)),
            norm.map(|n| transform_normal(n, &t.inverse)),
        ),
    }
}

/// The unit-sphere grid of one cube face (+z) of `lib_output_polygon_sphere`: the points
/// where the great circles through the y axis (turned about y) meet those through the x axis
/// (turned about x), `resolution` + 1 of each, 45 degrees either side of +z.
fn sphere_grid(resolution: usize) -> Vec<Vec<[f64; 3]>> {
    let res = resolution as f64;
    let angle = |e: usize| (PI / 4.0) * (2.0 * e as f64 / res - 1.0);
    let x_axis: Vec<[f64; 3]> = (0..=resolution)
        .map(|e| transform_vector([1.0, 0.0, 0.0], &rotate_matrix(Axis::Y, angle(e))))
        .collect();
    let y_axis: Vec<[f64; 3]> = (0..=resolution)
        .map(|e| transform_vector([0.0, 1.0, 0.0], &rotate_matrix(Axis::X, angle(e))))
        .collect();
    x_axis
        .iter()
        .map(|x| y_axis.iter().map(|y| normalize(cross(*x, *y))).collect())
        .collect()
}

/// `lib_output_polygon_sphere`: the sphere `center` (w = radius) as a cube projected onto it,
/// each face a `resolution` x `resolution` grid of great-circle quads split in two triangles:
/// 12 resolution^2 `pp` triangles whose vertex normals are the unit directions from the
/// centre.
pub fn polygon_sphere(s: &mut NffScene, center: Coord4, resolution: u32, tx: Option<&PatchTx>) {
    let res = resolution as usize;
    let mut pt = sphere_grid(res);
    for face in 0..6 {
        for p in pt.iter_mut().flatten() {
            rotate_cube_face(p, face);
        }
        for u in 0..res {
            for v in 0..res {
                for tri in 0..2 {
                    let mut vert = [[0.0; 3]; 3];
                    let mut norm = [[0.0; 3]; 3];
                    for edge in 0..3 {
                        let p = match (tri * 2 + edge) % 4 {
                            0 => pt[u][v],
                            1 => pt[u][v + 1],
                            2 => pt[u + 1][v + 1],
                            _ => pt[u + 1][v],
                        };
                        norm[edge] = p;
                        vert[edge] = std::array::from_fn(|k| p[k] * center[3] + center[k]);
                    }
                    patch(s, tx, vert, norm);
                }
            }
        }
    }
}

/// `lib_output_polygon_cylcone`: the side of the cylinder or cone from `base` to `apex` (w =
/// the radius at each end, no end caps) as 4 `resolution` slices around the axis, each two
/// `pp` triangles: 8 resolution triangles. The normals are the true normals of the cone
/// (perpendicular to its side), the same at both ends of a slice edge.
pub fn polygon_cylcone(
    s: &mut NffScene,
    base: Coord4,
    apex: Coord4,
    resolution: u32,
    tx: Option<&PatchTx>,
) {
    let axis = [apex[0] - base[0], apex[1] - base[1], apex[2] - base[2]];
    let (norm_axis, height) = normalize_len(axis);
    let (mut start_dir, divisor) = normalize_len(cross(axis, [0.0, 0.0, 1.0]));
    if divisor.abs() < EPSILON2 {
        start_dir = normalize(cross(axis, [1.0, 0.0, 0.0]));
    }
    let radius0 = start_dir.map(|d| d * base[3]);
    let radius1 = start_dir.map(|d| d * apex[3]);
    let add = |a: [f64; 3], c: Coord4| [a[0] + c[0], a[1] + c[1], a[2] + c[2]];
    let start_norm = if base[3] == apex[3] {
        start_dir
    } else {
        let ba = base[3] - apex[3];
        normalize(std::array::from_fn(|k| {
            start_dir[k] * height + norm_axis[k] * ba
        }))
    };
    // His arrays of four; the fourth is never written.
    let mut vert = [[0.0; 3]; 3];
    let mut norm = [start_norm; 3];
    vert[2] = add(radius0, base);
    vert[1] = add(radius1, apex);
    let slices = 4 * resolution;
    let delta_angle = 2.0 * PI / f64::from(slices);
    let mut angle = delta_angle;
    for _ in 1..=slices {
        let mx = axis_rotate_matrix(norm_axis, angle);
        let nmx = invert_matrix(&mx);
        vert[0] = add(transform_point(radius1, &mx), apex);
        norm[0] = transform_normal(start_norm, &nmx);
        patch(s, tx, vert, norm);
        vert[1] = vert[0];
        norm[1] = norm[0];
        vert[0] = add(transform_point(radius0, &mx), base);
        patch(s, tx, vert, norm);
        vert[2] = vert[0];
        norm[2] = norm[0];
        angle += delta_angle;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nff::Entity;

    /// A patch's vertices and normals.
    type Patch = (Vec<[f64; 3]>, Vec<[f64; 3]>);

    /// The triangles of `s`.
    fn triangles(s: &NffScene) -> Vec<Patch> {
        s.entities
            .iter()
            .map(|e| match &e.node {
                Entity::Polygon {
                    vertices,
                    normals: Some(n),
                } => (vertices.clone(), n.clone()),
                e => panic!("not a patch: {e:?}"),
            })
            .collect()
    }

    fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12)
    }

    #[test]
    fn sphere_vertices_lie_on_it_with_radial_normals() {
        let (c, r) = ([1.0, -2.0, 0.5], 0.75);
        for resolution in 1..=4u32 {
            let mut s = NffScene::default();
            polygon_sphere(&mut s, [c[0], c[1], c[2], r], resolution, None);
            let tris = triangles(&s);
            assert_eq!(tris.len(), 12 * (resolution * resolution) as usize);
            for (vertices, normals) in &tris {
                assert_eq!(vertices.len(), 3);
                for (p, n) in vertices.iter().zip(normals) {
                    let d = sub(*p, c);
                    assert!((dot(d, d).sqrt() - r).abs() < 1e-12, "{p:?} off the sphere");
                    assert!(close(*n, d.map(|x| x / r)), "normal {n:?} at {p:?}");
                }
                // Wound counterclockwise seen from outside: the face normal points out.
                let face = cross(sub(vertices[1], vertices[0]), sub(vertices[2], vertices[0]));
                assert!(dot(face, normals[0]) > 0.0);
            }
        }
        // Haines's default: 108 triangles a sphere.
        let mut s = NffScene::default();
        polygon_sphere(&mut s, [0.0, 0.0, 0.0, 1.0], 3, None);
        assert_eq!(s.entities.len(), 108);
    }

    #[test]
    fn cylinder_and_cone_sides_have_their_normals() {
        // A cylinder along z (crossed with x, his special case) and a slanted cone.
        for (base, apex) in [
            ([0.0, 0.0, -1.0, 0.5], [0.0, 0.0, 1.0, 0.5]),
            ([1.0, 2.0, 3.0, 0.6], [2.0, 2.5, 4.0, 0.2]),
        ] {
            let mut s = NffScene::default();
            polygon_cylcone(&mut s, base, apex, 3, None);
            let tris = triangles(&s);
            assert_eq!(tris.len(), 24);
            let b = [base[0], base[1], base[2]];
            let (axis, height) = normalize_len(sub([apex[0], apex[1], apex[2]], b));
            for (vertices, normals) in &tris {
                for (p, n) in vertices.iter().zip(normals) {
                    let along = dot(sub(*p, b), axis);
                    let radial = sub(sub(*p, b), axis.map(|x| x * along));
                    let want_r = base[3] + (apex[3] - base[3]) * along / height;
                    assert!((dot(radial, radial).sqrt() - want_r).abs() < 1e-12);
                    assert!((dot(*n, *n) - 1.0).abs() < 1e-12);
                    // The normal points out and is perpendicular to the side line.
                    let slope = (base[3] - apex[3]) / height;
                    let want = normalize(std::array::from_fn(|k| {
                        radial[k] / want_r + axis[k] * slope
                    }));
                    assert!(close(*n, want), "{n:?} vs {want:?}");
                }
            }
        }
    }

    #[test]
    fn a_transformed_sphere_keeps_radial_normals() {
        // Scaled by 1/2 and moved: the vertices lie on the sphere of radius r/2 about the moved
        // centre; normals, not renormalized (as his), are twice the unit radial direction.
        let m = super::super::haines_lib::matrix_multiply(
            &super::super::haines_lib::scale_matrix([0.5, 0.5, 0.5]),
            &super::super::haines_lib::translate_matrix([1.0, 2.0, 3.0]),
        );
        let mut s = NffScene::default();
        polygon_sphere(&mut s, [2.0, 0.0, 0.0, 0.4], 2, Some(&PatchTx::new(&m)));
        let c = [2.0, 2.0, 3.0];
        for (vertices, normals) in triangles(&s) {
            for (p, n) in vertices.iter().zip(&normals) {
                let d = sub(*p, c);
                assert!((dot(d, d).sqrt() - 0.2).abs() < 1e-12);
                assert!(close(*n, d.map(|x| x / 0.2 * 2.0)), "{n:?}");
            }
        }
    }
}
