//! Where on the image an eye ray can meet anything: the screen rectangles of the boxes every
//! hitting ray enters ([`Accel::outer_boxes`]: a cut through the BVH, up to 64 boxes). A
//! pixel outside all of them is background without a ray being traced: on small SPD scenes
//! most pixels are, and their eye rays were a third of the render.
//!
//! The rectangles are conservative: each is the bounding rectangle of the projected corners of
//! the part of a box in front of a near depth no ray through the image can meet it before (a
//! convex solid in front of the eye projects inside the hull of its corners), grown by
//! [`MARGIN`] pixels, far more than the rounding of a ray's set-up or slab test. A box holding
//! the eye covers the whole image. So a pixel left out is one whose every
//! eye ray misses every outer box: the ray the tracer would have traced reaches no leaf, hits
//! nothing and returns the background, which is exactly what the pixel gets, with the same
//! counts but one: its eye rays count one node each (the root's test, which the footprint
//! stands for), where tracing them would also have counted the inner nodes above the cut
//! whose boxes they enter (`voxels` of tetra 6 at 512x512: 956,422, not 988,585).

use crate::accel::{Accel, OuterBoxes};
use crate::camera::Camera;
use crate::geometry::{Aabb, Real, Vec3};
use std::ops::Range;

/// Pixels a rectangle is grown by on every side.
pub const MARGIN: Real = 1.0;

/// The screen rectangles of a scene's outer boxes for one camera.
#[derive(Clone, Debug)]
pub struct Footprint {
    /// `[x0, x1, y0, y1]` in the pixel units of [`Camera::direction`], grown by [`MARGIN`].
    rects: Vec<[Real; 4]>,
    /// What an eye ray outside every rectangle adds to the voxel count.
    pub voxels_on_miss: u64,
}

impl Footprint {
    /// The footprint of `accel`'s outer boxes seen by `camera`, or None when no pixel can be
    /// left out: the accelerator knows no outer boxes, or the camera has a lens (its rays do
    /// not share an origin).
    pub fn new(camera: &Camera, accel: &Accel) -> Option<Footprint> {
        if !camera.is_pinhole() {
            return None;
        }
        let OuterBoxes {
            boxes,
            voxels_on_miss,
        } = accel.outer_boxes()?;
        let rects = boxes.iter().map(|b| rectangle(camera, b)).collect();
        Some(Footprint {
            rects,
            voxels_on_miss,
        })
    }

    /// The pixels of row `y` (of `width`) whose eye rays may meet something, as sorted,
    /// disjoint ranges. A pixel's rays pass through points of the square [x, x+1] x [y, y+1].
    pub fn row(&self, y: u32, width: u32) -> Vec<Range<u32>> {
        let (top, bottom) = (y as Real, y as Real + 1.0);
        let mut spans: Vec<Range<u32>> = self
            .rects
            .iter()
            .filter(|r| r[2] <= bottom && r[3] >= top)
            .filter_map(|r| {
                let start = r[0].floor().max(0.0);
                let end = (r[1].floor() + 1.0).min(width as Real);
                (start < end).then_some(start as u32..end as u32)
            })
            .collect();
        spans.sort_by_key(|s| s.start);
        let mut merged: Vec<Range<u32>> = Vec::with_capacity(spans.len());
        for s in spans {
            match merged.last_mut() {
                Some(last) if s.start <= last.end => last.end = last.end.max(s.end),
                _ => merged.push(s),
            }
        }
        merged
    }
}

/// The grown screen rectangle of `b`: the bounding rectangle of the projected corners of the
/// part of `b` at least `near` in front of the eye. `near` is half the depth below which no
/// ray through the image can meet the box (a point it meets that close would be nearer the
/// eye than the box is), so a box reaching behind the eye (a floor under the camera) still
/// leaves out the sky above it. The whole plane when the eye is in the box.
fn rectangle(camera: &Camera, b: &Aabb) -> [Real; 4] {
    const EVERYWHERE: [Real; 4] = [
        Real::NEG_INFINITY,
        Real::INFINITY,
        Real::NEG_INFINITY,
        Real::INFINITY,
    ];
    let eye = camera.position;
    let distance = (b.min - eye).max(eye - b.max).max(Vec3::ZERO).length();
    let near = distance / (2.0 * (1.0 + camera.max_slope()));
    if !(near > 0.0 && near.is_finite()) {
        return EVERYWHERE;
    }
    let corner = |k: usize| {
        Vec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        )
    };
    // The clipped box's corners: the box's own in front of `near`, and where its edges
    // (corners differing in one coordinate) cross the depth `near`.
    let mut points: Vec<Vec3> = (0..8)
        .map(corner)
        .filter(|&c| camera.depth(c) >= near)
        .collect();
    for k in 0..8 {
        for bit in [1, 2, 4] {
            if k & bit != 0 {
                continue;
            }
            let (a, c) = (corner(k), corner(k | bit));
            let (da, dc) = (camera.depth(a), camera.depth(c));
            if (da < near) != (dc < near) {
                points.push(a + (c - a) * ((near - da) / (dc - da)));
            }
        }
    }
    let mut r = [
        Real::INFINITY,
        Real::NEG_INFINITY,
        Real::INFINITY,
        Real::NEG_INFINITY,
    ];
    for p in points {
        let Some((x, y)) = camera.project(p) else {
            return EVERYWHERE;
        };
        r = [r[0].min(x), r[1].max(x), r[2].min(y), r[3].max(y)];
    }
    // No point in front: the box is behind the eye, and the rectangle stays empty.
    [r[0] - MARGIN, r[1] + MARGIN, r[2] - MARGIN, r[3] + MARGIN]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{AccelKind, AccelOptions, Scratch};
    use crate::geometry::{Primitive, PrimitiveKind, Primitives, RayPre};
    use crate::stats::Counters;

    fn camera(w: u32, h: u32) -> Camera {
        let m = yari::model::Camera {
            position: Vec3::new(0.3, -0.2, 6.0),
            at: Vec3::ZERO,
            up: Vec3::Y,
            half_angle_deg: 20.0,
            aperture: 0.0,
            focus_distance: 1.0,
        };
        Camera::new(&m, w, h)
    }

    fn spheres(centres: &[(Real, Real, Real)], radius: Real) -> Vec<Primitive> {
        centres
            .iter()
            .enumerate()
            .map(|(i, &(x, y, z))| Primitive {
                kind: PrimitiveKind::Sphere {
                    centre: Vec3::new(x, y, z),
                    radius,
                },
                object: i as u32,
                surface: 0,
                motion: Vec3::ZERO,
            })
            .collect()
    }

    fn bvh(list: Vec<Primitive>) -> (Primitives, Accel) {
        let mut prims = Primitives::from_list(list);
        let opts = AccelOptions {
            kind: AccelKind::Bvh,
            ..AccelOptions::default()
        };
        let accel = Accel::build(&mut prims, &opts);
        (prims, accel)
    }

    /// Checks that every ray through every pixel corner and centre left out of the footprint
    /// misses everything, testing no primitive; returns the pixels left out.
    fn left_out_see_nothing(prims: &Primitives, accel: &Accel, (w, h): (u32, u32)) -> u32 {
        let cam = camera(w, h);
        let fp = Footprint::new(&cam, accel).unwrap();
        assert_eq!(fp.voxels_on_miss, 1);
        let mut scratch = Scratch::new(prims.len(), false);
        let mut outside = 0;
        for y in 0..h {
            let row = fp.row(y, w);
            for x in 0..w {
                if row.iter().any(|r| r.contains(&x)) {
                    continue;
                }
                outside += 1;
                for (dx, dy) in [(0.0, 0.0), (0.5, 0.5), (1.0, 1.0), (0.0, 1.0), (1.0, 0.0)] {
                    let ray = cam.ray(x as Real + dx, y as Real + dy, 0.0, None);
                    let mut c = Counters::default();
                    let pre = RayPre::new(ray);
                    let hit = accel.closest(prims, &pre, Real::INFINITY, &mut scratch, &mut c);
                    assert_eq!(hit, None, "pixel {x},{y}");
                    assert_eq!(c.intersection_tests, 0, "pixel {x},{y}");
                    assert!(c.voxels >= 1, "pixel {x},{y}");
                }
            }
        }
        outside
    }

    fn nine_spheres() -> Vec<Primitive> {
        spheres(
            &[
                (-1.0, -0.5, 0.0),
                (1.2, 0.4, -1.0),
                (0.0, 1.0, 1.0),
                (0.3, 0.0, -3.0),
                (-0.8, 0.9, -0.5),
                (0.9, -1.1, 0.5),
                (0.0, 0.0, 0.0),
                (-1.5, 1.3, -2.0),
                (1.4, 1.4, 0.2),
            ],
            0.35,
        )
    }

    #[test]
    fn pixels_left_out_see_nothing() {
        let (prims, accel) = bvh(nine_spheres());
        let outside = left_out_see_nothing(&prims, &accel, (48, 40));
        assert!(outside > 48 * 40 / 4, "{outside} left out");
    }

    /// A floor under the eye reaching far behind it (its box holds points beside and behind
    /// the eye): the sky above the floor's horizon and the spheres is still left out.
    #[test]
    fn a_floor_behind_the_eye_leaves_out_the_sky() {
        let mut list = nine_spheres();
        let (y, far) = (-2.0, 50.0);
        let floor = [
            Vec3::new(-far, y, -far),
            Vec3::new(far, y, -far),
            Vec3::new(far, y, far),
            Vec3::new(-far, y, far),
        ];
        for v in [
            [floor[0], floor[1], floor[2]],
            [floor[0], floor[2], floor[3]],
        ] {
            list.push(Primitive {
                kind: PrimitiveKind::Triangle {
                    v,
                    normal: Vec3::Y,
                    solid: false,
                },
                object: 9,
                surface: 0,
                motion: Vec3::ZERO,
            });
        }
        let (prims, accel) = bvh(list);
        let (w, h) = (48, 40);
        let outside = left_out_see_nothing(&prims, &accel, (w, h));
        assert!(outside > w * 4, "{outside} left out");
        // The floor's own box, seen alone, covers the rows below its horizon only.
        let cam = camera(w, h);
        let r = rectangle(
            &cam,
            &Aabb::new(Vec3::new(-far, y, -far), Vec3::new(far, y, far)),
        );
        assert!(r[2] > 0.0 && r[2] < h as Real && r[3] > h as Real, "{r:?}");
    }

    #[test]
    fn a_box_around_the_eye_covers_the_image() {
        let mut list = spheres(&[(0.3, -0.2, 6.0), (5.0, 5.0, 5.0)], 1.0);
        list.extend(spheres(&[(0.0, 0.0, 0.0); 8], 0.1));
        let (_, accel) = bvh(list);
        let fp = Footprint::new(&camera(16, 16), &accel).unwrap();
        for y in 0..16 {
            assert_eq!(fp.row(y, 16), vec![0..16]);
        }
    }

    #[test]
    fn rows_merge_overlapping_rectangles() {
        let fp = Footprint {
            rects: vec![
                [2.5, 4.2, 0.0, 3.0],
                [-3.0, 1.0, 0.5, 0.9],
                [4.0, 7.0, 0.0, 2.0],
                [12.0, 30.0, 0.0, 9.0],
            ],
            voxels_on_miss: 1,
        };
        assert_eq!(fp.row(0, 20), vec![0..8, 12..20]);
        assert_eq!(fp.row(5, 20), vec![12..20]);
        assert_eq!(fp.row(10, 20), vec![]);
    }
}
