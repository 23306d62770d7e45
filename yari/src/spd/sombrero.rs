//! `sombrero`: Alexander Enzmann's height field example from Haines's SPD (`sombrero.c`): the
//! damped ripple `cos(2 pi r) e^-r` sampled on a square grid (as C `float`s) and written as
//! two triangles per grid cell. One light.
//! The grid is 32 * 2^(size-1) points a side, so 2 (32 * 2^(size-1) - 1)^2 triangles; size 1
//! (Haines's default) gives 1922.

use super::haines_output::{color, polygon};
use crate::nff::{Entity, NffScene, View};

/// The `sombrero` scene at `size` (1 or more).
pub fn sombrero(size: u32) -> NffScene {
    let mut s = NffScene::default();
    s.push(Entity::Background(super::UNC_SKY_BLUE));
    s.push(Entity::View(View {
        from: [0.0, 5.0, -8.0],
        at: [0.0, 0.0, 0.0],
        up: [0.0, 0.0, 1.0],
        angle: 40.0,
        hither: 0.01,
        resolution: Some([512, 512]),
    }));
    s.push(Entity::Light {
        position: [10.0, 10.0, -10.0],
        color: None,
    });
    // Shiny red.
    color(&mut s, [1.0, 0.1, 0.1], 0.8, 0.0, 40.0, 0.0, 1.0);
    let width = 32usize << (size.max(1) - 1);
    let data = create_sombrero(width, width, -4.0, 4.0, -4.0, 4.0);
    output_height(&mut s, &data, width, width, [-4.0, 4.0], -3.0, [-4.0, 4.0]);
    s
}

/// `create_sombrero`: the heights, row `i` at y, column `j` at x, stepping x and y by
/// repeated addition as his loop does, each value rounded to a C `float`.
fn create_sombrero(
    width: usize,
    height: usize,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
) -> Vec<Vec<f32>> {
    let (a_const, b_const, c_const) = (1.0, 1.0, 3.0);
    // His own digits of pi.
    #[allow(clippy::approx_constant)]
    let two_pi_a = 2.0 * 3.14159265358 * a_const;
    let deltax = (x1 - x0) / width as f64;
    let deltay = (y1 - y0) / height as f64;
    let mut data = Vec::with_capacity(height);
    let mut y = y0;
    for _ in 0..height {
        let mut row = Vec::with_capacity(width);
        let mut x = x0;
        for _ in 0..width {
            let r = (x * x + y * y).sqrt();
            row.push((c_const * (two_pi_a * r).cos() * (-b_const * r).exp() / 3.0) as f32);
            x += deltax;
        }
        data.push(row);
        y += deltay;
    }
    data
}

/// `lib_output_polygon_height` (`libply.c`): two triangles per cell, x across, the height
/// (plus `y0`) up, z along the rows. `xr` and `zr` are the x and z ranges.
fn output_height(
    s: &mut NffScene,
    data: &[Vec<f32>],
    height: usize,
    width: usize,
    xr: [f64; 2],
    y0: f64,
    zr: [f64; 2],
) {
    let (x0, z0) = (xr[0], zr[0]);
    let xdelta = (xr[1] - x0) / (width - 1) as f64;
    let zdelta = (zr[1] - z0) / (height - 1) as f64;
    let at = |i: usize, j: usize| {
        [
            x0 + j as f64 * xdelta,
            y0 + f64::from(data[i][j]),
            z0 + i as f64 * zdelta,
        ]
    };
    for i in 0..height - 1 {
        for j in 0..width - 1 {
            let mut verts = [at(i, j), at(i + 1, j + 1), at(i, j + 1)];
            polygon(s, &mut verts);
            // The corner is copied from the (possibly collapsed) previous triangle.
            verts[2] = verts[1];
            verts[1] = at(i + 1, j);
            polygon(s, &mut verts);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_follow_the_grid() {
        for size in 1..=2u32 {
            let w = 32usize << (size - 1);
            assert_eq!(sombrero(size).counts(), (0, 2 * (w - 1) * (w - 1), 0));
        }
    }
}
