//! The NFF scene as written: Haines's entities in file order, before any mapping to YARI.
//!
//! The reader ([`super::read`](mod@super::read)) fills it from text, the SPD generators
//! ([`crate::spd`]) build it in code, the writer ([`super::write`](mod@super::write)) prints it
//! back in Haines's own number format, and [`super::to_yari`](mod@super::to_yari) maps it onto
//! the YARI syntax tree.

use crate::ast::{Spanned, Vec3};
use crate::span::Span;

/// A whole NFF file: its entities in the order they were written.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NffScene {
    /// The entities, each with where it was written (an empty span when generated).
    pub entities: Vec<Spanned<Entity>>,
}

/// One NFF entity (a letter command and its numbers).
#[derive(Clone, Debug, PartialEq)]
pub enum Entity {
    /// `b r g b`: background colour.
    Background(Vec3),
    /// `v` with `from`, `at`, `up`, `angle`, `hither`, `resolution`.
    View(View),
    /// `l x y z [r g b]`: a point light, colour optional.
    Light {
        /// The light's position in world space.
        position: Vec3,
        /// Its colour, linear RGB; `None` when the line gives only the position.
        color: Option<Vec3>,
    },
    /// `f r g b Kd Ks Shine T ior`: the material of the objects that follow.
    Fill(Fill),
    /// `s x y z r`.
    Sphere {
        /// The centre.
        center: Vec3,
        /// The radius, as written (the mapping to YARI checks it).
        radius: f64,
    },
    /// `p n` (normals `None`) or `pp n` (a normal per vertex).
    Polygon {
        /// The vertices in order.
        vertices: Vec<Vec3>,
        /// For `pp`, one normal per vertex (YARI's `normals = ...`).
        normals: Option<Vec<Vec3>>,
    },
    /// `c`: a cone or cylinder without end caps, from the base disc to the apex disc.
    Cone {
        /// The centre of the base disc.
        base: Vec3,
        /// The radius at the base.
        base_radius: f64,
        /// The centre of the apex disc.
        apex: Vec3,
        /// The radius at the apex (equal to `base_radius` for a cylinder).
        apex_radius: f64,
    },
}

/// The `v` block. `angle` is NFF's FULL angle of view in degrees.
#[derive(Clone, Debug, PartialEq)]
pub struct View {
    /// The eye point.
    pub from: Vec3,
    /// The point looked at.
    pub at: Vec3,
    /// Which way is up in the image.
    pub up: Vec3,
    /// The full angle of view in degrees (twice YARI's camera `angle`).
    pub angle: f64,
    /// Distance to the near clipping plane (YARI has none; it is dropped).
    pub hither: f64,
    /// `resolution x y`: the image width and height in pixels, if given.
    pub resolution: Option<[u32; 2]>,
}

/// The `f` material: colour, diffuse Kd, specular Ks, Phong exponent, transmittance T, index
/// of refraction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fill {
    /// The colour, linear RGB.
    pub color: Vec3,
    /// Diffuse weight Kd, 0..1.
    pub kd: f64,
    /// Specular weight Ks, 0..1.
    pub ks: f64,
    /// Phong exponent of the highlight.
    pub shine: f64,
    /// Transmittance T, 0..1 (0 is opaque).
    pub t: f64,
    /// Index of refraction.
    pub ior: f64,
}

impl Fill {
    /// The fill Haines's `lib_output_color` writes for a highlight of half-width `angle_deg`
    /// degrees: `Shine = ln 0.5 / ln cos(angle)`, or 100000 when the angle is 0.
    pub fn haines(color: Vec3, kd: f64, ks: f64, angle_deg: f64, t: f64, ior: f64) -> Fill {
        let shine = if angle_deg > 0.0 {
            0.5f64.ln() / (angle_deg * std::f64::consts::PI / 180.0).cos().ln()
        } else {
            100000.0
        };
        Fill {
            color,
            kd,
            ks,
            shine,
            t,
            ior,
        }
    }
}

impl NffScene {
    /// Appends an entity without a source position (generated scenes).
    pub fn push(&mut self, entity: Entity) {
        self.entities.push(Spanned::new(entity, Span::default()));
    }

    /// Counts of (spheres, polygons, cones) in the scene.
    pub fn counts(&self) -> (usize, usize, usize) {
        let mut counts = (0, 0, 0);
        for e in &self.entities {
            match e.node {
                Entity::Sphere { .. } => counts.0 += 1,
                Entity::Polygon { .. } => counts.1 += 1,
                Entity::Cone { .. } => counts.2 += 1,
                _ => {}
            }
        }
        counts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn haines_shine_from_angle() {
        // mount's glass (6.7 degrees) and balls' mirror (37 degrees), as printed in the SPD files.
        let glass = Fill::haines([1.0; 3], 0.1, 0.1, 6.7, 0.9, 1.5);
        assert!((glass.shine - 101.148).abs() < 5e-4, "{}", glass.shine);
        let mirror = Fill::haines([1.0, 0.9, 0.7], 0.5, 0.5, 37.0, 0.0, 1.0);
        assert!((mirror.shine - 3.0827).abs() < 5e-5, "{}", mirror.shine);
        assert_eq!(
            Fill::haines([1.0; 3], 1.0, 0.0, 0.0, 0.0, 0.0).shine,
            100000.0
        );
    }
}
