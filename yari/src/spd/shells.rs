//! `shells`: Haines's sea shell (`shells.c`) after Pickover: a logarithmic spiral of
//! overlapping spheres, growing along it. One light. A pathological scene on purpose (many
//! tiny, overlapping spheres).
//! 180 * 2^size + 1 spheres; size 5 gives Haines's default (5761).

use super::haines_output::{color, sphere, CurveFormat};
use crate::nff::{Entity, NffScene, View};
use std::f64::consts::PI;

/// Pickover's parameters at Haines's defaults (his `-g`, `-a`, `-b`, `-e` options).
const GAMMA: f64 = 1.0;
const ALPHA: f64 = 0.0;
const BETA: f64 = -2.0;
/// The exponent constant.
const A: f64 = 0.15;
/// The relative size.
const K: f64 = 1.0;

/// The `shells` scene at `size` (1 or more), its spheres written as `format` says.
pub fn shells(size: u32, format: CurveFormat) -> NffScene {
    let mut s = NffScene::default();
    s.push(Entity::Background(super::UNC_SKY_BLUE));
    s.push(Entity::View(View {
        from: [-6.0, -60.0, 35.0],
        at: [0.0, 8.0, -15.0],
        up: [0.0, 0.0, 1.0],
        angle: 45.0,
        hither: 0.5,
        resolution: Some([512, 512]),
    }));
    s.push(Entity::Light {
        position: [-100.0, -100.0, 100.0],
        color: None,
    });
    color(&mut s, [1.0, 0.8, 0.4], 0.8, 0.2, 10.0, 0.0, 1.0);
    let steps = (180.0 * 2.0f64.powi(size as i32)) as i64;
    for i in -steps * 2 / 3..=steps / 3 {
        let angle = 3.0 * 6.0 * PI * i as f64 / steps as f64;
        let r = K * (A * angle).exp();
        let z = if ALPHA > 0.0 {
            // The alternative formula.
            ALPHA * angle
        } else {
            BETA * r
        };
        sphere(
            &mut s,
            format,
            [r * angle.sin(), r * angle.cos(), z, r / GAMMA],
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_double_with_each_size() {
        for size in 1..=3u32 {
            assert_eq!(
                shells(size, CurveFormat::Curves).counts(),
                (180 * (1 << size) + 1, 0, 0)
            );
        }
    }
}
