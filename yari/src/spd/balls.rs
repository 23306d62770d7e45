//! `balls`, the sphereflake: a sphere sprouting nine spheres of a third its radius, each of
//! which does the same, `size` levels deep, over a square floor polygon; three lights.
//! (9^(size+1) - 1) / 8 spheres; size 4 gives the 7381 spheres of `balls4.nff`.

use super::haines_lib::{
    axis_rotate_matrix, cross, identity, normalize, rotate_matrix, transform_coord, Axis, Coord4,
    Matrix,
};
use super::haines_output::{sphere, CurveFormat};
use crate::nff::{Entity, Fill, NffScene, View};
use std::f64::consts::PI;

/// The `balls` scene at `size` (0 or more), its spheres written as `format` says (the floor
/// stays one polygon).
pub fn balls(size: u32, format: CurveFormat) -> NffScene {
    let radius = 1.0;
    let mut s = NffScene::default();
    s.push(Entity::Background(super::UNC_SKY_BLUE));
    s.push(Entity::View(View {
        from: [2.1, 1.3, 1.7],
        at: [0.0, 0.0, 0.0],
        up: [0.0, 0.0, 1.0],
        angle: 45.0,
        hither: 0.01,
        resolution: Some([512, 512]),
    }));
    for position in [[4.0, 3.0, 2.0], [1.0, -4.0, 4.0], [-3.0, 1.0, 5.0]] {
        s.push(Entity::Light {
            position,
            color: None,
        });
    }
    s.push(Entity::Fill(Fill::haines(
        [1.0, 0.75, 0.33],
        0.8,
        0.0,
        0.0,
        0.0,
        1.0,
    )));
    let (bx, by, bz) = (12.0 * radius, 12.0 * radius, -radius / 2.0);
    let floor = vec![[bx, by, bz], [-bx, by, bz], [-bx, -by, bz], [bx, -by, bz]];
    s.push(Entity::Polygon {
        vertices: floor,
        normals: None,
    });
    s.push(Entity::Fill(Fill::haines(
        [1.0, 0.9, 0.7],
        0.5,
        0.5,
        37.0,
        0.0,
        1.0,
    )));
    let objset = create_objset();
    output_object(
        &mut s,
        format,
        &objset,
        size,
        [0.0, 0.0, 0.0, radius / 2.0],
        [0.0, 0.0, 1.0, 1.0 / 3.0],
    );
    s
}

/// `output_object`: the sphere `center` (w = radius), then its nine children around
/// `direction` (w = the child radius ratio), depth first.
fn output_object(
    s: &mut NffScene,
    format: CurveFormat,
    objset: &[Coord4; 9],
    depth: u32,
    center: Coord4,
    direction: Coord4,
) {
    sphere(s, format, center);
    if depth == 0 {
        return;
    }
    let mx: Matrix = if direction[2] >= 0.9999 {
        identity()
    } else if direction[2] <= -0.9999 {
        rotate_matrix(Axis::Y, PI)
    } else {
        let z_axis = [0.0, 0.0, 1.0];
        let dir = [direction[0], direction[1], direction[2]];
        let axis = normalize(cross(z_axis, dir));
        let angle = (z_axis[0] * dir[0] + z_axis[1] * dir[1] + z_axis[2] * dir[2]).acos();
        axis_rotate_matrix(axis, angle)
    };
    let scale = center[3] * (1.0 + direction[3]);
    for v in objset {
        let p = transform_coord(*v, &mx);
        let child: Coord4 = [
            p[0] * scale + center[0],
            p[1] * scale + center[1],
            p[2] * scale + center[2],
            center[3] * direction[3],
        ];
        let child_dir: Coord4 = [
            (child[0] - center[0]) / scale,
            (child[1] - center[1]) / scale,
            (child[2] - center[2]) / scale,
            direction[3],
        ];
        output_object(s, format, objset, depth - 1, child, child_dir);
    }
}

/// `create_objset`: the nine unit directions of the children, three trios 120 degrees apart.
fn create_objset() -> [Coord4; 9] {
    let dist = 1.0 / 2.0f64.sqrt();
    let mut trio: [Coord4; 3] = [
        [dist, dist, 0.0, 0.0],
        [dist, 0.0, -dist, 0.0],
        [0.0, dist, -dist, 0.0],
    ];
    let axis = normalize([1.0, -1.0, 0.0]);
    let mx = axis_rotate_matrix(axis, (2.0 / 6.0f64.sqrt()).asin());
    for t in trio.iter_mut() {
        *t = transform_coord(*t, &mx);
    }
    let mut objset = [[0.0; 4]; 9];
    for set in 0..3 {
        let mx = rotate_matrix(Axis::Z, set as f64 * 2.0 * PI / 3.0);
        for (v, t) in trio.iter().enumerate() {
            objset[set * 3 + v] = transform_coord(*t, &mx);
        }
    }
    objset
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_follow_the_sum_of_powers_of_nine() {
        for size in 0..=3u32 {
            let spheres = (0..=size).map(|k| 9usize.pow(k)).sum::<usize>();
            assert_eq!(balls(size, CurveFormat::Curves).counts(), (spheres, 1, 0));
        }
    }

    #[test]
    fn children_touch_their_parent() {
        let s = balls(1, CurveFormat::Curves);
        let spheres: Vec<_> = s
            .entities
            .iter()
            .filter_map(|e| match e.node {
                Entity::Sphere { center, radius } => Some((center, radius)),
                _ => None,
            })
            .collect();
        let (c0, r0) = spheres[0];
        for &(c, r) in &spheres[1..] {
            let d =
                ((c[0] - c0[0]).powi(2) + (c[1] - c0[1]).powi(2) + (c[2] - c0[2]).powi(2)).sqrt();
            assert!((d - (r0 + r)).abs() < 1e-12, "distance {d} vs {}", r0 + r);
        }
    }
}
