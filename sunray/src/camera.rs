//! The pinhole camera (with an optional thin lens) of YARI's `camera(...)`.
//!
//! Convention (NFF's, with YARI's half angle): the half angle spans from the image centre to
//! the centre of the top pixel row, i.e. the full angle spans the centres of the top and bottom
//! rows; pixels are square; scanline 0 is at the top; x grows to the right as seen by the eye.

use crate::geometry::{Ray, Real, Vec3};
use crate::sampler::{sample_disc, SampleStream};

/// The eye-ray generator for one image: an orthonormal view frame, pixel size and lens.
#[derive(Clone, Debug)]
pub struct Camera {
    /// The eye point (the lens centre), world coordinates.
    pub position: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// Image-plane size of a pixel at distance 1.
    pixel: Real,
    width: u32,
    height: u32,
    aperture: Real,
    focus_distance: Real,
}

impl Camera {
    /// Builds the camera for an image of `width x height` pixels, on the view frame of
    /// [`yari::model::Camera::frame`] (which the POV-Ray export writes too). A degenerate view
    /// (eye at the look-at point, up parallel to the view) falls back to sane axes instead of
    /// NaNs.
    pub fn new(c: &yari::model::Camera, width: u32, height: u32) -> Camera {
        let yari::model::CameraFrame {
            forward,
            right,
            up,
            pixel,
        } = c.frame(height);
        Camera {
            position: c.position,
            forward,
            right,
            up,
            pixel,
            width,
            height,
            aperture: c.aperture.max(0.0),
            focus_distance: c.focus_distance,
        }
    }

    /// The direction (unnormalised) through image point (px, py) in pixel units, (0, 0) being
    /// the top-left corner of the image and (i + 0.5, j + 0.5) the centre of pixel (i, j).
    pub fn direction(&self, px: Real, py: Real) -> Vec3 {
        let x = (px - self.width as Real * 0.5) * self.pixel;
        let y = (self.height as Real * 0.5 - py) * self.pixel;
        self.forward + self.right * x + self.up * y
    }

    /// Where point `p` appears on the image, in the pixel units of [`Camera::direction`], or
    /// None unless it lies clearly in front of the eye.
    pub fn project(&self, p: Vec3) -> Option<(Real, Real)> {
        let v = p - self.position;
        let z = v.dot(self.forward);
        let in_front = z > 1e-9 * v.length();
        if !in_front || !v.is_finite() {
            return None;
        }
        let x = v.dot(self.right) / (z * self.pixel);
        let y = v.dot(self.up) / (z * self.pixel);
        Some((x + self.width as Real * 0.5, self.height as Real * 0.5 - y))
    }

    /// How far in front of the eye `p` is, along the view direction.
    pub fn depth(&self, p: Vec3) -> Real {
        (p - self.position).dot(self.forward)
    }

    /// An upper bound on how far an eye ray through the image (or up to two pixels beyond
    /// its edges) strays from the view direction per unit of depth.
    pub fn max_slope(&self) -> Real {
        let half_w = self.width as Real * 0.5 + 2.0;
        let half_h = self.height as Real * 0.5 + 2.0;
        (half_w + half_h) * self.pixel
    }

    /// True when every eye ray starts at the eye point (no lens), so that the ray through
    /// (px, py) is the eye point plus a multiple of [`Camera::direction`].
    pub fn is_pinhole(&self) -> bool {
        !(self.aperture > 0.0 && self.focus_distance > 0.0)
    }

    /// The eye ray through (px, py); with an aperture, from a point on the lens (using two
    /// numbers of `rng`) towards the same point on the plane in focus.
    #[inline]
    pub fn ray(&self, px: Real, py: Real, time: Real, rng: Option<&mut SampleStream>) -> Ray {
        let dir = self.direction(px, py).normalize();
        let mut ray = Ray {
            origin: self.position,
            dir,
            time,
        };
        if self.aperture > 0.0 && self.focus_distance > 0.0 {
            if let Some(rng) = rng {
                let (u, v) = rng.next_2d();
                let (dx, dy) = sample_disc(u, v);
                let focus = self.position + dir * (self.focus_distance / dir.dot(self.forward));
                let origin = self.position + (self.right * dx + self.up * dy) * self.aperture;
                ray.origin = origin;
                ray.dir = (focus - origin).normalize();
            }
        }
        ray
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(angle: Real) -> yari::model::Camera {
        yari::model::Camera {
            position: Vec3::ZERO,
            at: Vec3::NEG_Z,
            up: Vec3::Y,
            half_angle_deg: angle,
            aperture: 0.0,
            focus_distance: 1.0,
        }
    }

    #[test]
    fn half_angle_spans_centre_to_top_row_centre() {
        let cam = Camera::new(&model(45.0), 11, 11);
        let top = cam.direction(5.5, 0.5).normalize();
        let centre = cam.direction(5.5, 5.5).normalize();
        assert!((centre - Vec3::NEG_Z).length() < 1e-12);
        let angle = top.dot(centre).acos().to_degrees();
        assert!((angle - 45.0).abs() < 1e-9, "{angle}");
        assert!(top.y > 0.0, "scanline 0 is at the top");
        assert!(cam.direction(10.5, 5.5).x > 0.0, "x grows to the right");
    }

    #[test]
    fn project_inverts_direction() {
        let mut m = model(30.0);
        m.position = Vec3::new(1.0, 2.0, 3.0);
        m.at = Vec3::new(-2.0, 0.5, -4.0);
        let cam = Camera::new(&m, 64, 48);
        for (px, py) in [(0.0, 0.0), (10.25, 40.5), (63.9, 1.0), (-5.0, 100.0)] {
            let p = cam.position + cam.direction(px, py) * 7.5;
            let (x, y) = cam.project(p).unwrap();
            assert!((x - px).abs() < 1e-9 && (y - py).abs() < 1e-9, "{x} {y}");
        }
        assert_eq!(cam.project(cam.position - cam.direction(3.0, 3.0)), None);
        assert_eq!(cam.project(cam.position), None);
    }

    #[test]
    fn degenerate_view_gives_finite_rays() {
        let mut m = model(30.0);
        m.up = Vec3::NEG_Z;
        let cam = Camera::new(&m, 4, 4);
        assert!(cam.direction(0.0, 0.0).is_finite());
    }
}
