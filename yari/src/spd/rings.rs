//! `rings`: Haines's pyramid of objects made of six pentagonal rings (`rings.c`), each ring
//! five cylinders and five spheres joining the edge midpoints of a dodecahedron, in front of
//! a white wall. Three lights.
//! size*(size+1)*(2*size+1)/6 objects of 30 cylinders and 30 spheres, plus the wall; size 7
//! gives Haines's 4200 spheres and 4200 cylinders.

use super::haines_lib::{rotate_matrix, transform_point, Axis};
use super::haines_output::{color, cylcone, polygon, sphere, CurveFormat};
use crate::nff::{Entity, NffScene, View};
use std::f64::consts::PI;

/// Radius of the cylinders and spheres.
const RADIUS: f64 = 0.07412;
/// `SPREAD_OUT`: above 1, deeper layers spread out more.
const SPREAD_OUT: f64 = 1.0;

/// The `rings` scene at `size` (1 or more), its cylinders and spheres written as `format`
/// says (the wall stays one polygon).
pub fn rings(size: u32, format: CurveFormat) -> NffScene {
    let spread = 1.0 / (PI / 8.0).sin();
    let (y_diff, xz_diff) = if SPREAD_OUT <= spread {
        (spread / SPREAD_OUT, 1.0)
    } else {
        (1.0, SPREAD_OUT / spread)
    };
    let mut s = NffScene::default();
    // Never seen.
    s.push(Entity::Background(super::UNC_SKY_BLUE));
    let from = [-1.0, -spread, 0.5];
    s.push(Entity::View(View {
        from,
        at: [from[0], from[1] + 1.0, from[2]],
        up: [0.0, 0.0, 1.0],
        angle: 45.0,
        hither: 1.0,
        resolution: Some([512, 512]),
    }));
    for position in [
        [3.0, -spread, 3.0],
        [-4.0, -spread, 1.0],
        [2.0, -spread, -4.0],
    ] {
        s.push(Entity::Light {
            position,
            color: None,
        });
    }
    // The wall, white, just spanning the 45 degree view plus 1%.
    color(&mut s, [1.0, 1.0, 1.0], 1.0, 0.0, 0.0, 0.0, 0.0);
    let wy = y_diff * (size + 1) as f64;
    let wxz = 1.01 * (wy - from[1]) * (PI / 8.0).tan();
    let mut wall = [
        [wxz + from[0], wy, wxz + from[2]],
        [-wxz + from[0], wy, wxz + from[2]],
        [-wxz + from[0], wy, -wxz + from[2]],
        [wxz + from[0], wy, -wxz + from[2]],
    ];
    polygon(&mut s, &mut wall);
    // RGB and their complements.
    let ring_color = [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 1.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 0.0],
    ];
    let dodec = create_dodec(RADIUS);
    let depth_count = size as i64;
    for depth in 0..depth_count {
        let oy = y_diff * (depth + 1) as f64;
        for objz in 0..=depth {
            let oz = xz_diff * (2 * objz - depth) as f64;
            for objx in 0..=depth {
                let ox = xz_diff * (2 * objx - depth) as f64;
                for elem in 0..30 {
                    let d = dodec[elem];
                    let base = [d[0] + ox, d[1] + oy, d[2] + oz, RADIUS];
                    let prev = if elem % 5 == 0 {
                        // A new ring.
                        color(&mut s, ring_color[elem / 5], 0.5, 0.2, 37.0, 0.0, 0.0);
                        elem + 4
                    } else {
                        elem - 1
                    };
                    let p = dodec[prev];
                    let apex = [p[0] + ox, p[1] + oy, p[2] + oz, RADIUS];
                    cylcone(&mut s, format, base, apex);
                    sphere(&mut s, format, base);
                }
            }
        }
    }
    s
}

/// `create_dodec`: the 30 points the rings join, scaled into the unit sphere: one pentagon
/// in the x-y plane, and five more turned about x by the dihedral angle, then about z.
fn create_dodec(minor_radius: f64) -> [[f64; 3]; 30] {
    let mut vertex = [[0.0; 3]; 30];
    let scale = 1.0 / (1.0 + minor_radius);
    for (i, v) in vertex.iter_mut().take(5).enumerate() {
        let a = i as f64 * 2.0 * PI / 5.0;
        *v = [scale * a.cos(), scale * a.sin(), 0.0];
    }
    let x_rotation = 2.0 * ((PI / 3.0).cos() / (PI / 5.0).sin()).acos();
    let x_matrix = rotate_matrix(Axis::X, x_rotation);
    for pentagon in 1..6 {
        let z_rotation = PI * (2.0 * (pentagon - 1) as f64 + 1.0) / 5.0;
        let z_matrix = rotate_matrix(Axis::Z, z_rotation);
        for v in 0..5 {
            let temp = transform_point(vertex[v], &x_matrix);
            vertex[5 * pentagon + v] = transform_point(temp, &z_matrix);
        }
    }
    vertex
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_follow_the_pyramid() {
        for size in 1..=3u32 {
            let n = 5 * size * (size + 1) * (2 * size + 1);
            assert_eq!(
                rings(size, CurveFormat::Curves).counts(),
                (n as usize, 1, n as usize)
            );
        }
    }
}
