//! `tree`: Haines's tree (`tree.c`) grown by Aono and Kunii's method, each branch a cone
//! capped by a sphere and splitting in two, over a green field square. Seven lights.
//! 2^(size+1) - 1 cones and as many spheres, plus the field; size 11 gives Haines's 4095
//! of each.

use super::haines_lib::{identity, matrix_multiply, rotate_matrix, transform_point, Axis, Matrix};
use super::haines_output::{color, cylcone, polygon, sphere, CurveFormat};
use crate::nff::{Entity, NffScene, View};
use std::f64::consts::PI;

const BR_ANGLE_0: f64 = 40.0;
const BR_ANGLE_1: f64 = 25.0;
const BR_CONTR_0: f64 = 0.65;
const BR_CONTR_1: f64 = 0.70;
const BR_DIAMETER: f64 = 0.67;
const DIV_ANGLE: f64 = 140.0;
const WIDTH_HEIGHTH_RATIO: f64 = 0.15;

/// The `tree` scene at `size` (0 or more: the trunk, then `size` levels of branches), its
/// cones and spheres written as `format` says (the field stays one polygon).
pub fn tree(size: u32, format: CurveFormat) -> NffScene {
    let mut s = NffScene::default();
    s.push(Entity::Background(super::UNC_SKY_BLUE));
    s.push(Entity::View(View {
        from: [4.5, 0.4, 2.0],
        at: [0.0, 0.0, 1.5],
        up: [0.0, 0.0, 1.0],
        angle: 45.0,
        hither: 1.0,
        resolution: Some([512, 512]),
    }));
    for position in [
        [-5.0, 5.0, 50.0],
        [30.0, -30.0, 30.0],
        [-40.0, -30.0, 20.0],
        [10.0, 30.0, 40.0],
        [-30.0, 40.0, 10.0],
        [50.0, 25.0, 20.0],
        [-10.0, -60.0, 30.0],
    ] {
        s.push(Entity::Light {
            position,
            color: None,
        });
    }
    // The field, green.
    color(&mut s, [0.2, 0.7, 0.2], 1.0, 0.0, 0.0, 0.0, 0.0);
    let mut field = [
        [50.0, 50.0, 0.0],
        [-50.0, 50.0, 0.0],
        [-50.0, -50.0, 0.0],
        [50.0, -50.0, 0.0],
    ];
    polygon(&mut s, &mut field);
    // The tree, brown.
    color(&mut s, [0.55, 0.4, 0.2], 1.0, 0.0, 0.0, 0.0, 0.0);
    let rst = branch_matrices();
    grow_tree(&mut s, format, &rst, &identity(), 1.0, size);
    s
}

/// `create_tree`'s matrices: each branch relative to its parent, rotated about x by the
/// branching angle, then about z by the divergence, shrunk and moved to the parent's tip.
fn branch_matrices() -> [Matrix; 2] {
    std::array::from_fn(|i| {
        let (branch_angle, divergence, contraction) = if i == 0 {
            (BR_ANGLE_0, 90.0, BR_CONTR_0)
        } else {
            (BR_ANGLE_1, DIV_ANGLE + 90.0, BR_CONTR_1)
        };
        let temp1 = rotate_matrix(Axis::X, branch_angle * PI / 180.0);
        let temp2 = rotate_matrix(Axis::Z, divergence * PI / 180.0);
        let tempr = matrix_multiply(&temp1, &temp2);
        let mut tempst = identity();
        tempst[0][0] = contraction;
        tempst[1][1] = contraction;
        tempst[2][2] = contraction;
        tempst[3][2] = 1.0;
        matrix_multiply(&tempr, &tempst)
    })
}

/// `grow_tree`: the branch (a cone from the origin to z = 1 in `cur`'s frame) with a sphere
/// at its tip, then its two sub-branches, depth first.
fn grow_tree(
    s: &mut NffScene,
    format: CurveFormat,
    rst: &[Matrix; 2],
    cur: &Matrix,
    scale: f64,
    depth: u32,
) {
    let b = transform_point([0.0, 0.0, 0.0], cur);
    let base = [b[0], b[1], b[2], scale * WIDTH_HEIGHTH_RATIO];
    let a = transform_point([0.0, 0.0, 1.0], cur);
    let apex = [a[0], a[1], a[2], base[3] * BR_DIAMETER];
    cylcone(s, format, base, apex);
    sphere(s, format, apex);
    if depth > 0 {
        for m in rst {
            let new = matrix_multiply(m, cur);
            grow_tree(s, format, rst, &new, scale * BR_DIAMETER, depth - 1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_double_with_each_level() {
        for size in 0..=4u32 {
            let n = 2usize.pow(size + 1) - 1;
            assert_eq!(tree(size, CurveFormat::Curves).counts(), (n, 1, n));
        }
    }
}
