//! The thesis's `check` tool: a checkerboard of square polygons in two colours, in any
//! orientation. The board lies in the x-y plane (facing +z, the SPD scenes' up) centred at the
//! origin, is rotated about x, then y, then z (YARI's `rotate` order), then moved to `center`.
//! With `view` it also gets a camera looking down at it at 37 degrees (turned with the board,
//! so it always faces the board's top), one light above, a black background and 512x512
//! pixels, so the output renders on its own.

use crate::ast::Vec3;
use crate::nff::{Entity, Fill, NffScene, View};

/// What to build.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckerboardOptions {
    /// Squares along the board's x and y.
    pub squares: [u32; 2],
    /// Side length of one square.
    pub square_size: f64,
    /// The colour of the square at the corner (0, 0), and the other.
    pub colors: [Vec3; 2],
    /// Where the board's centre ends up, after the rotation.
    pub center: Vec3,
    /// Degrees about x, then y, then z.
    pub rotate: Vec3,
    /// Add a camera, a light and a background.
    pub view: bool,
}

impl Default for CheckerboardOptions {
    fn default() -> Self {
        CheckerboardOptions {
            squares: [8, 8],
            square_size: 1.0,
            colors: [[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]],
            center: [0.0; 3],
            rotate: [0.0; 3],
            view: true,
        }
    }
}

/// Why a checkerboard cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CheckerboardError {
    /// No squares one way, or more than [`MAX_SQUARES`] in all.
    #[error("the board needs at least one square each way, and at most {max} in all")]
    Squares {
        /// [`MAX_SQUARES`].
        max: u64,
    },
    /// The square size is not a finite number > 0.
    #[error("the square size must be a positive number")]
    SquareSize,
    /// The centre, rotation or a colour has a NaN or infinite component.
    #[error("centre, rotation and colours must be finite numbers")]
    NotFinite,
}

/// Most squares on one board.
pub const MAX_SQUARES: u64 = 4_000_000;

/// Builds the board: one fill and its squares, then the other fill and its squares.
pub fn checkerboard(o: &CheckerboardOptions) -> Result<NffScene, CheckerboardError> {
    let [nx, ny] = o.squares;
    if nx == 0 || ny == 0 || nx as u64 * ny as u64 > MAX_SQUARES {
        return Err(CheckerboardError::Squares { max: MAX_SQUARES });
    }
    if !(o.square_size > 0.0 && o.square_size.is_finite()) {
        return Err(CheckerboardError::SquareSize);
    }
    let all = o
        .center
        .iter()
        .chain(&o.rotate)
        .chain(o.colors.iter().flatten());
    if !all.into_iter().all(|x| x.is_finite()) {
        return Err(CheckerboardError::NotFinite);
    }
    let rot = rotation(o.rotate);
    let place = |p: Vec3| -> Vec3 {
        let r = apply(&rot, p);
        [r[0] + o.center[0], r[1] + o.center[1], r[2] + o.center[2]]
    };
    let half = [
        nx as f64 * o.square_size / 2.0,
        ny as f64 * o.square_size / 2.0,
    ];
    let mut s = NffScene::default();
    if o.view {
        let extent = half[0].max(half[1]);
        let distance = extent * 2.0f64.sqrt() / 22.5f64.to_radians().tan();
        s.push(Entity::Background([0.0; 3]));
        s.push(Entity::View(View {
            from: place([0.0, -0.8 * distance, 0.6 * distance]),
            at: o.center,
            up: apply(&rot, [0.0, 0.0, 1.0]),
            angle: 45.0,
            hither: 0.01,
            resolution: Some([512, 512]),
        }));
        s.push(Entity::Light {
            position: place([extent, -extent, 3.0 * extent]),
            color: None,
        });
    }
    for (parity, color) in o.colors.iter().enumerate() {
        s.push(Entity::Fill(Fill {
            color: *color,
            kd: 1.0,
            ks: 0.0,
            shine: 100000.0,
            t: 0.0,
            ior: 1.0,
        }));
        for j in 0..ny {
            for i in 0..nx {
                if (i + j) as usize % 2 != parity {
                    continue;
                }
                let x0 = -half[0] + i as f64 * o.square_size;
                let y0 = -half[1] + j as f64 * o.square_size;
                let (x1, y1) = (x0 + o.square_size, y0 + o.square_size);
                let vertices = [[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]]
                    .map(place)
                    .to_vec();
                s.push(Entity::Polygon {
                    vertices,
                    normals: None,
                });
            }
        }
    }
    Ok(s)
}

type Mat3 = [[f64; 3]; 3];

/// Rz * Ry * Rx for angles in degrees (column vectors: x is applied first).
fn rotation(deg: Vec3) -> Mat3 {
    let (sx, cx) = deg[0].to_radians().sin_cos();
    let (sy, cy) = deg[1].to_radians().sin_cos();
    let (sz, cz) = deg[2].to_radians().sin_cos();
    let rx = [[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]];
    let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
    let rz = [[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]];
    mul(&rz, &mul(&ry, &rx))
}

fn mul(a: &Mat3, b: &Mat3) -> Mat3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

fn apply(m: &Mat3, p: Vec3) -> Vec3 {
    std::array::from_fn(|i| m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn squares_by_colour(s: &NffScene) -> Vec<usize> {
        let mut counts = Vec::new();
        for e in &s.entities {
            match e.node {
                Entity::Fill(_) => counts.push(0),
                Entity::Polygon { .. } => *counts.last_mut().unwrap() += 1,
                _ => {}
            }
        }
        counts
    }

    #[test]
    fn default_board_alternates() {
        let s = checkerboard(&CheckerboardOptions::default()).unwrap();
        assert_eq!(squares_by_colour(&s), vec![32, 32]);
        let odd = CheckerboardOptions {
            squares: [3, 3],
            ..Default::default()
        };
        assert_eq!(squares_by_colour(&checkerboard(&odd).unwrap()), vec![5, 4]);
    }

    #[test]
    fn rotation_and_centre_move_the_board() {
        let o = CheckerboardOptions {
            squares: [2, 1],
            square_size: 1.0,
            center: [0.0, 0.0, 5.0],
            rotate: [90.0, 0.0, 0.0],
            view: false,
            ..Default::default()
        };
        let s = checkerboard(&o).unwrap();
        // Rotated 90 degrees about x the board stands in the x-z plane around z = 5.
        for e in &s.entities {
            if let Entity::Polygon { vertices, .. } = &e.node {
                for v in vertices {
                    assert!(v[1].abs() < 1e-12, "{v:?}");
                    assert!(
                        (v[2] - 5.0).abs() <= 0.5 + 1e-12 && v[0].abs() <= 1.0 + 1e-12,
                        "{v:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn bad_options_are_refused() {
        let zero = CheckerboardOptions {
            squares: [0, 4],
            ..Default::default()
        };
        assert_eq!(
            checkerboard(&zero),
            Err(CheckerboardError::Squares { max: MAX_SQUARES })
        );
        let neg = CheckerboardOptions {
            square_size: -1.0,
            ..Default::default()
        };
        assert_eq!(checkerboard(&neg), Err(CheckerboardError::SquareSize));
        let nan = CheckerboardOptions {
            center: [f64::NAN, 0.0, 0.0],
            ..Default::default()
        };
        assert_eq!(checkerboard(&nan), Err(CheckerboardError::NotFinite));
    }
}
