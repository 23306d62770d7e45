//! `gears`: Haines's cube of meshed gears (`gears.c`) on a reflective ground square; some
//! gears are transparent. Five lights.
//! `size`^3 gears, each a 144-vertex top and bottom face and 144 side rectangles; size 4 gives
//! the 64 gears (9344 polygons, plus the ground) of Haines's default.

use super::haines_lib::{rotate_matrix, transform_vector, Axis};
use super::haines_output::{color, polygon};
use crate::nff::{Entity, NffScene, View};
use std::f64::consts::PI;

/// Teeth on a gear (a multiple of 4).
const TEETH: usize = 36;
/// The outer radius is a little less than the full radius, so meshed gears do not touch.
const OUTER_EDGE_RATIO: f64 = 0.995;
const INNER_EDGE_RATIO: f64 = 0.9;
const EDGE_DIFF: f64 = 1.0 - INNER_EDGE_RATIO;
/// Ratio of the gear's thickness to its width.
const DEPTH_RATIO: f64 = 0.1;

/// `FRACTION` of `def.h`: `a - (int)a`.
fn fraction(a: f64) -> f64 {
    a - (a as i32) as f64
}

/// The `gears` scene at `size` (1 or more).
pub fn gears(size: u32) -> NffScene {
    let mut s = NffScene::default();
    s.push(Entity::Background(super::UNC_SKY_BLUE));
    s.push(Entity::View(View {
        from: [-1.1, -2.1, 2.6],
        at: [0.0, 0.0, 0.0],
        up: [0.0, 0.0, 1.0],
        angle: 45.0,
        hither: 1.0,
        resolution: Some([512, 512]),
    }));
    for position in [
        [2.0, 4.0, 4.0],
        [-2.0, 4.0, 3.0],
        [2.0, -2.5, 2.5],
        [-1.0, -4.0, 2.0],
        // Just behind the eye.
        [-1.111, -2.121, 2.626],
    ] {
        s.push(Entity::Light {
            position,
            color: None,
        });
    }
    // The ground, off white.
    color(&mut s, [1.0, 0.85, 0.7], 0.3, 0.6, 37.0, 0.0, 0.0);
    let mut ground = [
        [2.0, 2.0, 0.0],
        [-2.0, 2.0, 0.0],
        [-2.0, -2.0, 0.0],
        [2.0, -2.0, 0.0],
    ];
    polygon(&mut s, &mut ground);

    let sf = size as f64;
    let outer_radius = 1.0 / (sf - (size as i64 - 1) as f64 * EDGE_DIFF / 2.0);
    let zero_pt = [-1.0 + outer_radius, -1.0 + outer_radius, 1.0];
    let offset_xy = outer_radius * (2.0 - EDGE_DIFF);
    let offset_z = -1.0 / sf;
    let n = size as i64;
    for iz in 0..n {
        let cz = zero_pt[2] + iz as f64 * offset_z;
        for iy in 0..n {
            let cy = zero_pt[1] + iy as f64 * offset_xy;
            for ix in 0..n {
                let cx = zero_pt[0] + ix as f64 * offset_xy;
                // A pseudo-random gear colour.
                let mut c = [
                    0.01 + fraction((ix * 3 + iy * 2 + iz + 1) as f64 * 5.0 / 7.0),
                    0.01 + fraction((iy * 3 + iz * 2 + ix + 1) as f64 * 3.0 / 7.0),
                    0.01 + fraction((iz * 3 + ix * 2 + iy + 1) as f64 * 2.0 / 7.0),
                ];
                let scale = max(max(c[0], c[1]), c[2]);
                for v in &mut c {
                    *v /= scale;
                }
                if (ix * 4 + iy * 2 + iz) % 5 == 0 {
                    color(&mut s, c, 0.2, 0.0, 0.0, 0.8, 1.1);
                } else {
                    color(&mut s, c, 1.0, 0.0, 0.0, 0.0, 0.0);
                }
                let angle = PI * ((ix + iy + iz) % 2) as f64 / TEETH as f64;
                let thickness = min(DEPTH_RATIO, 1.0 / (2.0 * sf));
                create_gear(
                    &mut s,
                    [cx, cy, cz],
                    angle,
                    OUTER_EDGE_RATIO * outer_radius,
                    (1.0 - EDGE_DIFF) * outer_radius,
                    thickness,
                );
            }
        }
    }
    s
}

/// `MAX` of `def.h`.
fn max(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// `MIN` of `def.h`.
fn min(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

/// `create_tooth`: the four outline points of one tooth at `gear_angle`.
fn create_tooth(
    gear_angle: f64,
    tooth_angle: f64,
    center: [f64; 3],
    outer_pt: [f64; 3],
    inner_pt: [f64; 3],
    edge_pts: &mut [[f64; 3]],
) {
    let steps = [
        (-0.19, outer_pt),
        (0.19, outer_pt),
        (0.3, inner_pt),
        (0.7, inner_pt),
    ];
    for (e, (k, pt)) in edge_pts.iter_mut().zip(steps) {
        let mx = rotate_matrix(Axis::Z, gear_angle + k * tooth_angle);
        let v = transform_vector(pt, &mx);
        *e = [v[0] + center[0], v[1] + center[1], v[2] + center[2]];
    }
}

/// `create_gear`: top face, the side rectangles, bottom face.
fn create_gear(
    s: &mut NffScene,
    center: [f64; 3],
    offset_angle: f64,
    outer_radius: f64,
    inner_radius: f64,
    thickness: f64,
) {
    let mut outer_pt = [outer_radius, 0.0, 0.0];
    let mut inner_pt = [inner_radius, 0.0, 0.0];
    let tooth_angle = 2.0 * PI / TEETH as f64;
    let mut gear_pts = [[0.0; 3]; 4 * TEETH];
    for (t, pts) in gear_pts.chunks_mut(4).enumerate() {
        let gear_angle = offset_angle + 2.0 * PI * t as f64 / TEETH as f64;
        create_tooth(gear_angle, tooth_angle, center, outer_pt, inner_pt, pts);
    }
    polygon(s, &mut gear_pts);
    for side in 0..4 * TEETH {
        let next = (side + 1) % (4 * TEETH);
        let mut side_pts = [gear_pts[side]; 4];
        side_pts[1][2] -= thickness;
        side_pts[2] = gear_pts[next];
        side_pts[2][2] -= thickness;
        side_pts[3] = gear_pts[next];
        polygon(s, &mut side_pts);
    }
    outer_pt[2] = -thickness;
    inner_pt[2] = -thickness;
    for (t, pts) in gear_pts.chunks_mut(4).enumerate() {
        let gear_angle = offset_angle - 2.0 * PI * t as f64 / TEETH as f64;
        create_tooth(gear_angle, -tooth_angle, center, outer_pt, inner_pt, pts);
    }
    polygon(s, &mut gear_pts);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_follow_the_cube_of_the_size() {
        for size in 1..=3u32 {
            let n = size.pow(3) as usize;
            assert_eq!(gears(size).counts(), (0, 1 + 146 * n, 0));
        }
    }
}
