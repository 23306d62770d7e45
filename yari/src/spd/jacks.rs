//! `jacks`: Alexander Enzmann's recursive jacks from Haines's SPD (`jacks.c`): a jack (three
//! crossed cylinders with a sphere at each end) with a half-size copy in each of its eight
//! octants, `size` levels deep, the whole turned to face the viewer. One light.
//! (8^size - 1) / 7 jacks of 3 cylinders and 6 spheres; size 1 (Haines's default) is one
//! jack.
//!
//! His program places the objects with his library's transformation stack; NFF has none, so
//! his library writes each sphere and cylinder transformed (centre and ends as points, radius
//! times the x scale), and so does [`TxStack`].

use super::haines_lib::Axis;
use super::haines_output::{color, CurveFormat, TxStack};
use crate::nff::{Entity, NffScene, View};
use std::f64::consts::PI;

/// The patch resolution his `jacks` sets (`lib_set_polygonalization(2, 2)`, after reading
/// its options, so it also overrides his `-t N`): 48 triangles a sphere, 16 a cylinder.
pub const RESOLUTION: u32 = 2;

/// The `jacks` scene at `size` (1 or more), its cylinders and spheres written as `format`
/// says (patches without a resolution at [`RESOLUTION`]).
pub fn jacks(size: u32, format: CurveFormat) -> NffScene {
    let format = format.with_default_resolution(RESOLUTION);
    let mut s = NffScene::default();
    // Dark purple.
    s.push(Entity::Background([0.2, 0.05, 0.2]));
    s.push(Entity::View(View {
        from: [0.0, 0.0, -8.0],
        at: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        angle: 25.0,
        hither: 0.001,
        resolution: Some([256, 256]),
    }));
    s.push(Entity::Light {
        position: [-10.0, 3.0, -20.0],
        color: None,
    });
    let mut tx = TxStack::default();
    tx.push();
    tx.rotate(Axis::X, -30.0 * PI / 180.0);
    tx.rotate(Axis::Y, -20.0 * PI / 180.0);
    // Pink.
    color(&mut s, [0.737, 0.561, 0.561], 0.7, 0.7, 20.0, 0.0, 1.0);
    make_rec_jack(&mut s, format, &mut tx, 1, size);
    tx.pop();
    s
}

/// `make_jack_obj`: one jack, shrunk to 3/4 so the copies do not overlap.
fn make_jack_obj(s: &mut NffScene, format: CurveFormat, tx: &mut TxStack) {
    tx.push();
    tx.scale([0.75, 0.75, 0.75]);
    // Written out as his code does: negating would give -0 where he has 0.
    let cylinders = [
        ([-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
        ([0.0, -1.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0, -1.0], [0.0, 0.0, 1.0]),
    ];
    for (b, a) in cylinders {
        tx.cylcone(s, format, [b[0], b[1], b[2], 0.1], [a[0], a[1], a[2], 0.1]);
    }
    let spheres = [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [-1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, -1.0],
    ];
    for c in spheres {
        tx.sphere(s, format, [c[0], c[1], c[2], 0.2]);
    }
    tx.pop();
}

/// `make_rec_jack`: the jack, then (above `max_depth`) a half-size jack in each octant.
fn make_rec_jack(
    s: &mut NffScene,
    format: CurveFormat,
    tx: &mut TxStack,
    depth: u32,
    max_depth: u32,
) {
    make_jack_obj(s, format, tx);
    if depth < max_depth {
        for i in [-0.5, 0.5] {
            for j in [-0.5, 0.5] {
                for k in [-0.5, 0.5] {
                    tx.push();
                    tx.translate([i, j, k]);
                    tx.scale([0.5, 0.5, 0.5]);
                    make_rec_jack(s, format, tx, depth + 1, max_depth);
                    tx.pop();
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_follow_the_powers_of_eight() {
        for size in 1..=3u32 {
            let jacks_n = (8usize.pow(size) - 1) / 7;
            assert_eq!(
                jacks(size, CurveFormat::Curves).counts(),
                (6 * jacks_n, 0, 3 * jacks_n)
            );
        }
    }
}
