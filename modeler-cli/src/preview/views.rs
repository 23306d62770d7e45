//! The editor's four views: front, top and side orthographic projections sharing one scale,
//! and a perspective view from the view location (or the camera). Each maps a world point
//! to a pixel position and a depth key (larger = nearer, affine in screen space), and gives
//! the eye ray through a pixel for the shapes that are ray cast (quadrics).

use glam::DVec3;

/// One of the four views.
#[derive(Clone, Debug)]
pub enum Projection {
    /// Right, up and toward-the-viewer axes; the world point at the image centre; pixels per
    /// world unit.
    Ortho {
        /// The image's x axis in the world.
        right: DVec3,
        /// The image's y axis (up on screen).
        up: DVec3,
        /// Towards the viewer (depth grows the other way).
        toward: DVec3,
        /// The world point at the image centre.
        centre: DVec3,
        /// Pixels per world unit.
        scale: f64,
    },
    /// Eye, forward/right/up unit axes, pixels per unit of tangent; near-plane depth.
    Perspective {
        /// Where the eye is.
        eye: DVec3,
        /// The direction of view (unit).
        forward: DVec3,
        /// The image's x axis (unit).
        right: DVec3,
        /// The image's y axis (unit).
        up: DVec3,
        /// Pixels per unit of tangent of the angle off the axis.
        scale: f64,
        /// Nearest depth drawn.
        near: f64,
    },
}

/// A view: its projection and its size in pixels.
#[derive(Clone, Debug)]
pub struct View {
    /// Its name in the corner (FRONT, TOP, SIDE, PERSPECTIVE).
    pub label: &'static str,
    /// How world points map to pixels.
    pub projection: Projection,
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
}

impl View {
    fn half(&self) -> (f64, f64) {
        (
            (self.width as f64 - 1.0) / 2.0,
            (self.height as f64 - 1.0) / 2.0,
        )
    }

    /// Pixel x, pixel y and depth key of a world point (for perspective, only in front of
    /// the near plane; see [`View::clip_near`]).
    pub fn project(&self, p: DVec3) -> [f64; 3] {
        let (hx, hy) = self.half();
        match &self.projection {
            Projection::Ortho {
                right,
                up,
                toward,
                centre,
                scale,
            } => {
                let d = p - *centre;
                [
                    hx + d.dot(*right) * scale,
                    hy - d.dot(*up) * scale,
                    d.dot(*toward),
                ]
            }
            Projection::Perspective {
                eye,
                forward,
                right,
                up,
                scale,
                ..
            } => {
                let d = p - *eye;
                let z = d.dot(*forward);
                [
                    hx + d.dot(*right) / z * scale,
                    hy - d.dot(*up) / z * scale,
                    1.0 / z,
                ]
            }
        }
    }

    /// The depth of a point along the viewing direction (perspective: distance in front of
    /// the eye; orthographic: unbounded, so nothing is clipped).
    pub fn depth(&self, p: DVec3) -> f64 {
        match &self.projection {
            Projection::Ortho { .. } => f64::INFINITY,
            Projection::Perspective { eye, forward, .. } => (p - *eye).dot(*forward),
        }
    }

    /// Clips a polygon (or, with `closed` false, a polyline) against the near plane.
    pub fn clip_near(&self, pts: &[DVec3], closed: bool) -> Vec<DVec3> {
        let Projection::Perspective { near, .. } = &self.projection else {
            return pts.to_vec();
        };
        let mut out = Vec::with_capacity(pts.len() + 2);
        let n = pts.len();
        let edges = if closed { n } else { n.saturating_sub(1) };
        if !closed && n > 0 && self.depth(pts[0]) >= *near {
            out.push(pts[0]);
        }
        for i in 0..edges {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            let (da, db) = (self.depth(a) - near, self.depth(b) - near);
            if (da >= 0.0) != (db >= 0.0) {
                out.push(a + (b - a) * (da / (da - db)));
            }
            if db >= 0.0 {
                out.push(b);
            }
        }
        out
    }

    /// The eye ray (origin, unit direction) through pixel (x, y).
    pub fn ray(&self, x: f64, y: f64, reach: f64) -> (DVec3, DVec3) {
        let (hx, hy) = self.half();
        match &self.projection {
            Projection::Ortho {
                right,
                up,
                toward,
                centre,
                scale,
            } => {
                let o = *centre
                    + *right * ((x - hx) / scale)
                    + *up * ((hy - y) / scale)
                    + *toward * reach;
                (o, -*toward)
            }
            Projection::Perspective {
                eye,
                forward,
                right,
                up,
                scale,
                ..
            } => {
                let d = *forward + *right * ((x - hx) / scale) + *up * ((hy - y) / scale);
                (*eye, d.normalize())
            }
        }
    }

    /// The depth key of a world point on an eye ray.
    pub fn key(&self, p: DVec3) -> f64 {
        self.project(p)[2]
    }

    /// The unit direction from a point toward the viewer.
    pub fn toward_viewer(&self, p: DVec3) -> DVec3 {
        match &self.projection {
            Projection::Ortho { toward, .. } => *toward,
            Projection::Perspective { eye, .. } => (*eye - p).normalize_or_zero(),
        }
    }
}

/// The three orthographic views of a box (min, max), all at one scale so that lengths
/// compare across them: front (from +z), top (from +y, -z up the page) and side (from +x,
/// -z to the right).
pub fn ortho_views(min: DVec3, max: DVec3, size: usize) -> [View; 3] {
    let centre = (min + max) * 0.5;
    let extent = (max - min).max_element().max(1e-9) * 1.15;
    let scale = (size as f64 - 1.0) / extent;
    let make = |label, right: DVec3, up: DVec3| View {
        label,
        projection: Projection::Ortho {
            right,
            up,
            toward: right.cross(up),
            centre,
            scale,
        },
        width: size,
        height: size,
    };
    [
        make("FRONT", DVec3::X, DVec3::Y),
        make("TOP", DVec3::X, DVec3::NEG_Z),
        make("SIDE", DVec3::NEG_Z, DVec3::Y),
    ]
}

/// A perspective view with YARI's camera convention: `half_angle` degrees from the image
/// centre to the centre of the top row of pixels, square pixels.
pub fn perspective_view(
    eye: DVec3,
    at: DVec3,
    up: DVec3,
    half_angle: f64,
    size: usize,
    near: f64,
) -> Option<View> {
    let forward = (at - eye).try_normalize()?;
    let right = forward.cross(up).try_normalize()?;
    let up = right.cross(forward);
    let tan = half_angle.to_radians().tan();
    if !(tan.is_finite() && tan > 0.0) {
        return None;
    }
    let scale = ((size as f64 - 1.0) / 2.0) / tan;
    Some(View {
        label: "PERSPECTIVE",
        projection: Projection::Perspective {
            eye,
            forward,
            right,
            up,
            scale,
            near,
        },
        width: size,
        height: size,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ortho_views_put_axes_where_a_draughtsman_expects() {
        let [front, top, side] = ortho_views(DVec3::splat(-1.0), DVec3::splat(1.0), 101);
        let p = DVec3::new(1.0, 0.0, 0.0);
        assert!(front.project(p)[0] > 50.0 && top.project(p)[0] > 50.0);
        // +y is up in the front and side views; +z is down the page in the top view.
        assert!(front.project(DVec3::Y)[1] < 50.0 && side.project(DVec3::Y)[1] < 50.0);
        assert!(top.project(DVec3::Z)[1] > 50.0);
        // Nearer means a larger key: +z in front, +y on top, +x at the side.
        assert!(front.key(DVec3::Z) > front.key(-DVec3::Z));
        assert!(top.key(DVec3::Y) > top.key(-DVec3::Y));
        assert!(side.key(DVec3::X) > side.key(-DVec3::X));
    }

    #[test]
    fn the_half_angle_reaches_the_centre_of_the_top_row() {
        let v = perspective_view(DVec3::ZERO, DVec3::NEG_Z, DVec3::Y, 45.0, 101, 0.01).unwrap();
        // At 45 degrees a point at height 1, depth 1 is on the top row's centre.
        let p = v.project(DVec3::new(0.0, 1.0, -1.0));
        assert!((p[0] - 50.0).abs() < 1e-9 && p[1].abs() < 1e-9);
        let (o, d) = v.ray(50.0, 0.0, 0.0);
        assert_eq!(o, DVec3::ZERO);
        assert!((d - DVec3::new(0.0, 1.0, -1.0).normalize()).length() < 1e-12);
        assert!(perspective_view(DVec3::ZERO, DVec3::ZERO, DVec3::Y, 45.0, 10, 0.1).is_none());
    }

    #[test]
    fn near_clipping_cuts_a_polygon_through_the_eye_plane() {
        let v = perspective_view(DVec3::ZERO, DVec3::NEG_Z, DVec3::Y, 30.0, 64, 0.5).unwrap();
        let tri = [
            DVec3::new(0.0, 0.0, -2.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(-1.0, 0.0, 1.0),
        ];
        let clipped = v.clip_near(&tri, true);
        assert_eq!(clipped.len(), 3);
        assert!(clipped.iter().all(|p| v.depth(*p) >= 0.5 - 1e-12));
    }
}
