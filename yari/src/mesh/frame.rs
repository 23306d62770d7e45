//! The preamble of a mesh file rendered on its own: 512x512 pixels, a black background, a
//! camera looking at the centre of the bounding box from +x+y+z (y up, as glTF and most
//! scanners and modellers write) far enough that the sphere around the box fills a 22.5-degree
//! half angle, a white light at the eye and a dimmer one above the box.

use crate::ast::{CameraDef, ColorSpec, LightDef, Spanned, Vec3, ViewStmt};
use crate::span::Span;

/// The bounding box of the points added (empty until the first).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// The lowest corner.
    pub min: Vec3,
    /// The highest corner.
    pub max: Vec3,
}

impl Default for Bounds {
    fn default() -> Bounds {
        Bounds {
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
        }
    }
}

impl Bounds {
    /// Grows the box to hold `p`.
    pub fn add(&mut self, p: Vec3) {
        self.min = std::array::from_fn(|i| self.min[i].min(p[i]));
        self.max = std::array::from_fn(|i| self.max[i].max(p[i]));
    }

    /// Whether no point was added.
    pub fn is_empty(&self) -> bool {
        self.min[0] > self.max[0]
    }

    /// The centre of the box and the radius of the sphere around it (1 when it is a point or
    /// empty).
    pub fn sphere(&self) -> (Vec3, f64) {
        if self.is_empty() {
            return ([0.0; 3], 1.0);
        }
        let center = std::array::from_fn(|i| (self.min[i] + self.max[i]) / 2.0);
        let r = (0..3)
            .map(|i| (self.max[i] - self.min[i]).powi(2))
            .sum::<f64>()
            .sqrt()
            / 2.0;
        (center, if r > 0.0 { r } else { 1.0 })
    }
}

/// The half angle of the camera, degrees.
const HALF_ANGLE: f64 = 22.5;

/// The preamble framing `bounds`.
pub fn view(bounds: &Bounds) -> Vec<Spanned<ViewStmt>> {
    let (center, radius) = bounds.sphere();
    let distance = radius / HALF_ANGLE.to_radians().sin() * 1.05;
    let dir = 1.0 / 3.0f64.sqrt();
    let eye: Vec3 = center.map(|c| c + distance * dir);
    let above: Vec3 = [center[0], center[1] + distance, center[2]];
    let at = Span::default();
    let colour = |v: f64| Spanned::new(ColorSpec::Rgb([v; 3]), at);
    let light = |position, v| {
        Spanned::new(
            ViewStmt::Light(LightDef {
                position,
                color: colour(v),
                radius: None,
            }),
            at,
        )
    };
    vec![
        Spanned::new(ViewStmt::Resolution(512, 512), at),
        Spanned::new(ViewStmt::Background(colour(0.0)), at),
        light(eye, 0.8),
        light(above, 0.5),
        Spanned::new(
            ViewStmt::Camera(CameraDef {
                position: eye,
                at: center,
                up: [0.0, 1.0, 0.0],
                angle: HALF_ANGLE,
                aperture: None,
                focus: None,
            }),
            at,
        ),
    ]
}
