//! `tetra`: Haines's recursive tetrahedral pyramid (Glassner's and Kay & Kajiya's test scene).
//! 4^size triangles; size 6 gives the 4096 polygons of `tetra6.nff`.

use super::haines_lib::Coord4;
use crate::nff::{Entity, Fill, NffScene, View};

/// The `tetra` scene at `size` (1 or more).
pub fn tetra(size: u32) -> NffScene {
    let mut s = NffScene::default();
    s.push(Entity::Background(super::UNC_SKY_BLUE));
    s.push(Entity::View(View {
        from: [1.022846, -3.177154, -2.174512],
        at: [-0.004103, -0.004103, 0.216539],
        up: [-0.816497, -0.816497, 0.816497],
        angle: 45.0,
        hither: 1.0,
        resolution: Some([512, 512]),
    }));
    s.push(Entity::Light {
        position: [2.0, -18.0, -5.0],
        color: None,
    });
    s.push(Entity::Fill(Fill::haines(
        [1.0, 0.2, 0.2],
        1.0,
        0.0,
        0.0,
        0.0,
        0.0,
    )));
    create_tetra(&mut s, size, [0.0, 0.0, 0.0, 1.0]);
    s
}

/// `create_tetra`: at depth 1 (or less) output the four faces of the tetrahedron inscribed in
/// the cube of half-size `center[3]`; otherwise recurse into the four corner sub-tetrahedra.
fn create_tetra(s: &mut NffScene, depth: u32, center: Coord4) {
    let corners = || {
        let mut dirs = Vec::with_capacity(4);
        for x in [-1.0, 1.0] {
            for y in [-1.0, 1.0] {
                for z in [-1.0, 1.0] {
                    if x * y * z == 1.0 {
                        dirs.push([x, y, z]);
                    }
                }
            }
        }
        dirs
    };
    if depth <= 1 {
        let pts: Vec<[f64; 3]> = corners()
            .iter()
            .map(|d| std::array::from_fn(|i| center[i] + d[i] * center[3]))
            .collect();
        for face in 0..4 {
            let mut order: [usize; 3] = std::array::from_fn(|v| (face + v) % 4);
            if face % 2 == 1 {
                order.swap(0, 2);
            }
            s.push(Entity::Polygon {
                vertices: order.iter().map(|&i| pts[i]).collect(),
                normals: None,
            });
        }
    } else {
        for d in corners() {
            let sub: Coord4 = [
                center[0] + d[0] * center[3] / 2.0,
                center[1] + d[1] * center[3] / 2.0,
                center[2] + d[2] * center[3] / 2.0,
                center[3] / 2.0,
            ];
            create_tetra(s, depth - 1, sub);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_follow_four_to_the_size() {
        for size in 1..=4 {
            assert_eq!(tetra(size).counts(), (0, 4usize.pow(size), 0));
        }
    }
}
