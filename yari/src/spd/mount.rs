//! `mount`: Haines's fractal mountain (Carpenter's midpoint displacement on a square grid, with
//! his hash-seeded Gaussian random numbers) and a pyramid of four glass spheres.
//! 2 * 4^size triangles; size 6 gives the 8192 polygons and 4 spheres of `mount6.nff`.
//!
//! The original, "faulty" hash of the 1987 database is kept on purpose (Haines asks for it
//! in ray tracing comparisons). Its shifts `7 - size` limit the size to [`MAX_SIZE`].

use super::haines_lib::{
    axis_rotate_matrix, gauss_rand, normalize, rotate_matrix, transform_vector, Axis, Coord4,
};
use super::haines_output::{sphere, CurveFormat};
use crate::nff::{Entity, Fill, NffScene, View};
use std::f64::consts::PI;

/// The largest size the original hash is defined for (its smallest shift is `7 - size`).
pub const MAX_SIZE: u32 = 7;
const FRACTAL_DIMENSION: f64 = 2.2;
const MOUNTAIN_NO: i64 = 21;
const X_CORNER: f64 = -1.0;
const Y_CORNER: f64 = -1.0;
const WIDTH: f64 = 2.0;

/// The `mount` scene at `size` (0 to [`MAX_SIZE`]; larger sizes are clamped by the caller),
/// its four spheres written as `format` says.
pub fn mount(size: u32, format: CurveFormat) -> NffScene {
    let size = size.min(MAX_SIZE);
    let mut s = NffScene::default();
    s.push(Entity::Background(super::UNC_SKY_BLUE));
    s.push(Entity::View(View {
        from: [-1.6, 1.6, 1.7],
        at: [0.0, 0.0, 0.0],
        up: [0.0, 0.0, 1.0],
        angle: 45.0,
        hither: 0.01,
        resolution: Some([512, 512]),
    }));
    s.push(Entity::Light {
        position: [-100.0, -100.0, 100.0],
        color: None,
    });
    s.push(Entity::Fill(Fill::haines(
        [1.0, 1.0, 1.0],
        0.1,
        0.1,
        6.7,
        0.9,
        1.5,
    )));
    create_spheres(&mut s, format, [-0.8, 0.8, 1.0, 0.17]);
    s.push(Entity::Fill(Fill::haines(
        [0.5, 0.45, 0.35],
        1.0,
        0.0,
        0.0,
        0.0,
        0.0,
    )));
    let num_pts = 1i64 << size;
    let ratio = 2.0 / (2.0f64.ln() / (FRACTAL_DIMENSION - 1.0)).exp();
    let grower = Grower {
        size,
        fnum_pts: num_pts as f64,
        roughness: (ratio * ratio - 1.0).sqrt(),
    };
    grower.grow(&mut s, num_pts, 0, 0, [0.0; 4]);
    s
}

/// `create_spheres`: one sphere above `center`, three around below it, touching.
fn create_spheres(s: &mut NffScene, format: CurveFormat, center: Coord4) {
    let axis = normalize([1.0, 1.0, 0.0]);
    let angle = (-1.0f64 / 3.0).acos();
    let pt = [0.0, 0.0, center[3] * (3.0f64 / 2.0).sqrt()];
    let top = [center[0] + pt[0], center[1] + pt[1], center[2] + pt[2]];
    sphere(s, format, [top[0], top[1], top[2], center[3]]);
    let new_pt = transform_vector(pt, &axis_rotate_matrix(axis, angle));
    for i in 0..3 {
        let m = rotate_matrix(Axis::Z, i as f64 * 2.0 * PI / 3.0);
        let p = transform_vector(new_pt, &m);
        let c = [p[0] + center[0], p[1] + center[1], p[2] + center[2]];
        sphere(s, format, [c[0], c[1], c[2], center[3]]);
    }
}

/// The old hash of `mount.c`: `((A << (23-C)) + (B << (15-C)) + (A << (7-C))) & 0xffff`.
fn hash_rand(a: i64, b: i64, c: u32) -> i64 {
    let (a, b) = (a as u64, b as u64);
    let sum = (a << (23 - c))
        .wrapping_add(b << (15 - c))
        .wrapping_add(a << (7 - c));
    (sum & 0xffff) as i64
}

struct Grower {
    size: u32,
    fnum_pts: f64,
    roughness: f64,
}

impl Grower {
    fn rand(&self, x: i64, y: i64) -> f64 {
        gauss_rand(MOUNTAIN_NO + hash_rand(x, y, self.size))
    }

    /// `grow_mountain`: heights `z` at the lower-left, lower-right, upper-right, upper-left
    /// corners of the cell at (`ll_x`, `ll_y`) of `width` grid steps.
    // Haines's literal 1.4142136, not SQRT_2: the heights must match his digit for digit.
    #[allow(clippy::approx_constant)]
    fn grow(&self, s: &mut NffScene, width: i64, ll_x: i64, ll_y: i64, z: [f64; 4]) {
        let [ll_z, lr_z, ur_z, ul_z] = z;
        if width == 1 {
            let l_x = X_CORNER + ll_x as f64 * WIDTH / self.fnum_pts;
            let r_x = X_CORNER + (ll_x + 1) as f64 * WIDTH / self.fnum_pts;
            let l_y = Y_CORNER + ll_y as f64 * WIDTH / self.fnum_pts;
            let u_y = Y_CORNER + (ll_y + 1) as f64 * WIDTH / self.fnum_pts;
            let corners = [
                [l_x, l_y, ll_z],
                [r_x, l_y, lr_z],
                [r_x, u_y, ur_z],
                [l_x, u_y, ul_z],
            ];
            for tri in 0..2 {
                let vertices = (0..3).map(|v| corners[(v + tri * 2) % 4]).collect();
                s.push(Entity::Polygon {
                    vertices,
                    normals: None,
                });
            }
            return;
        }
        let half = width >> 1;
        let hside_length = half as f64 * WIDTH / self.fnum_pts;
        let rise = hside_length * self.roughness;
        let lower = (ll_z + lr_z) / 2.0 + rise * self.rand(ll_x + half, ll_y);
        let right = (lr_z + ur_z) / 2.0 + rise * self.rand(ll_x + width, ll_y + half);
        let upper = (ur_z + ul_z) / 2.0 + rise * self.rand(ll_x + half, ll_y + width);
        let left = (ul_z + ll_z) / 2.0 + rise * self.rand(ll_x, ll_y + half);
        let middle = (ll_z + lr_z + ur_z + ul_z) / 4.0
            + 1.4142136 * rise * self.rand(ll_x + half, ll_y + half);
        self.grow(s, half, ll_x, ll_y, [ll_z, lower, middle, left]);
        self.grow(s, half, ll_x + half, ll_y, [lower, lr_z, right, middle]);
        self.grow(
            s,
            half,
            ll_x + half,
            ll_y + half,
            [middle, right, ur_z, upper],
        );
        self.grow(s, half, ll_x, ll_y + half, [left, middle, upper, ul_z]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_spheres() {
        for size in 0..=3 {
            assert_eq!(
                mount(size, CurveFormat::Curves).counts(),
                (4, 2 * 4usize.pow(size), 0)
            );
        }
    }

    #[test]
    fn shared_edges_share_heights() {
        // Midpoints are hashed from grid coordinates, so neighbouring cells agree: every
        // (x, y) grid point has exactly one height.
        let s = mount(3, CurveFormat::Curves);
        let mut heights = std::collections::HashMap::new();
        for e in &s.entities {
            if let Entity::Polygon { vertices, .. } = &e.node {
                for v in vertices {
                    let key = ((v[0] * 1e6).round() as i64, (v[1] * 1e6).round() as i64);
                    let z = *heights.entry(key).or_insert(v[2]);
                    assert_eq!(z.to_bits(), v[2].to_bits());
                }
            }
        }
        assert_eq!(heights.len(), 9 * 9);
    }
}
