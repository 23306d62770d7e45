//! `lattice`: Antonio Costa's cubic lattice from Haines's SPD (`lattice.c`): shiny spheres on
//! the points of a (size+1)^3 grid in the unit cube, each joined to its neighbours by matte
//! red, green and blue cylinders along x, y and z. Six lights.
//! (size+1)^3 spheres and 3 size (size+1)^2 cylinders; size 12 gives Haines's 2197 spheres
//! and 6084 cylinders.

use super::haines_output::{color, cylcone, sphere, CurveFormat};
use crate::nff::{Entity, NffScene, View};

const RADIUS1: f64 = 1.0 / 4.0;
const RADIUS2: f64 = 1.0 / 16.0;

/// The `lattice` scene at `size` (1 or more), its spheres and cylinders written as `format`
/// says.
pub fn lattice(size: u32, format: CurveFormat) -> NffScene {
    let sf = size as f64;
    let inv_factor = 1.0 / sf;
    let radius1 = RADIUS1 / sf;
    let radius2 = RADIUS2 / sf;
    let delta = (radius1 * (1.0 - (RADIUS2 / RADIUS1).sqrt())) * 0.99;
    let mut s = NffScene::default();
    s.push(Entity::Background(super::UNC_SKY_BLUE));
    let half = (size >> 1) as f64 + 0.5;
    let twice = (u64::from(size) << 1) as f64;
    s.push(Entity::View(View {
        from: [half * inv_factor, 1.0, 1.0 - 1.0 / twice],
        at: [half * inv_factor, -1.0, -1.0 - 1.0 / twice],
        up: [0.2, 1.0, 0.0],
        angle: 60.0,
        hither: 0.0,
        resolution: Some([512, 512]),
    }));
    for position in [
        [2.0, 0.5, 0.5],
        [-1.0, 0.5, 0.5],
        [0.5, 2.0, 0.5],
        [0.5, -1.0, 0.5],
        [0.5, 0.5, 2.0],
        [0.5, 0.5, -1.0],
    ] {
        s.push(Entity::Light {
            position,
            color: None,
        });
    }
    for x in 0..=size {
        let x0 = x as f64 / sf;
        for y in 0..=size {
            let y0 = y as f64 / sf;
            for z in 0..=size {
                let z0 = z as f64 / sf;
                color(&mut s, [0.9, 0.9, 0.9], 0.5, 0.5, 37.0, 0.0, 0.0);
                sphere(&mut s, format, [x0, y0, z0, radius1]);
                if x != size {
                    color(&mut s, [0.9, 0.1, 0.1], 0.99, 0.0, 0.0, 0.0, 0.0);
                    cylcone(
                        &mut s,
                        format,
                        [x0 + delta, y0, z0, radius2],
                        [x0 + inv_factor - delta, y0, z0, radius2],
                    );
                }
                if y != size {
                    color(&mut s, [0.1, 0.9, 0.1], 0.99, 0.0, 0.0, 0.0, 0.0);
                    cylcone(
                        &mut s,
                        format,
                        [x0, y0 + delta, z0, radius2],
                        [x0, y0 + inv_factor - delta, z0, radius2],
                    );
                }
                if z != size {
                    color(&mut s, [0.1, 0.1, 0.9], 0.99, 0.0, 0.0, 0.0, 0.0);
                    cylcone(
                        &mut s,
                        format,
                        [x0, y0, z0 + delta, radius2],
                        [x0, y0, z0 + inv_factor - delta, radius2],
                    );
                }
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_follow_the_grid() {
        for size in 1..=4usize {
            let points = (size + 1).pow(3);
            let rods = 3 * size * (size + 1).pow(2);
            assert_eq!(
                lattice(size as u32, CurveFormat::Curves).counts(),
                (points, 0, rods)
            );
        }
    }
}
