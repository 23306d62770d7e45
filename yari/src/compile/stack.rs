//! The graphics state: the current transformation, attribute and motion, and how the
//! transformation statements change it.
//!
//! A new transformation T is applied AFTER those already in effect: the current map M
//! becomes T * M, so a point is moved first by the earliest transformation (thesis
//! Appendix C.5). `rotate(x,y,z)` turns x degrees about the x axis, then y about y, then z
//! about z. `motion(v)` adds v to the displacement of the following primitives; it is a
//! world-space vector and is not transformed. Entering a block copies the state; leaving it
//! drops the copy, so `end` restores transformation, attribute and motion together.

use super::Compiler;
use crate::ast::Transform;
use crate::model::Surface;
use crate::span::Span;
use glam::{DAffine3, DMat3, DVec3};

#[derive(Clone, Debug)]
pub(crate) struct State {
    /// Object space to world space.
    pub(crate) transform: DAffine3,
    /// True while no transformation has been applied (so no arithmetic is done and a
    /// world-space file compiles to exactly its own numbers).
    pub(crate) identity: bool,
    /// World-space displacement over the shutter interval.
    pub(crate) motion: DVec3,
    /// The current surface; a texture's `world_to_texture` is filled in when it is used.
    pub(crate) surface: Surface,
    /// An explicit `texture_space` map, used instead of the inverse transformation.
    pub(crate) texture_space: Option<DAffine3>,
    /// The index of the current surface in the world, while it is still valid.
    pub(crate) cached_surface: Option<u32>,
}

impl State {
    pub(crate) fn new() -> State {
        State {
            transform: DAffine3::IDENTITY,
            identity: true,
            motion: DVec3::ZERO,
            surface: Surface::default(),
            texture_space: None,
            cached_surface: None,
        }
    }

    /// The inverse of the current transformation, if it has a finite one.
    pub(crate) fn inverse(&self) -> Option<DAffine3> {
        if self.identity {
            return Some(DAffine3::IDENTITY);
        }
        let inv = self.transform.inverse();
        inv.is_finite().then_some(inv)
    }

    /// Applies one transformation statement.
    pub(crate) fn apply(&mut self, c: &mut Compiler<'_>, t: &Transform, span: Span) {
        let m = match t {
            Transform::Motion(v) => {
                let v = DVec3::from_array(*v);
                self.motion += v;
                if !self.motion.is_finite() {
                    c.error(span, "motion vector is not finite");
                }
                return;
            }
            Transform::Translate(v) => DAffine3::from_translation(DVec3::from_array(*v)),
            Transform::Scale(v) => {
                if v.contains(&0.0) {
                    c.error(span, "scale factors must not be zero");
                    return;
                }
                DAffine3::from_scale(DVec3::from_array(*v))
            }
            Transform::Rotate(v) => DAffine3::from_mat3(rotation_xyz(*v)),
            Transform::Matrix(m) => {
                let a = rows_to_affine(m);
                if a.matrix3.determinant() == 0.0 {
                    c.error(
                        span,
                        "transform matrix is singular (its 3x3 part has determinant 0)",
                    );
                    return;
                }
                a
            }
        };
        if !m.is_finite() {
            c.error(span, "transformation is not finite");
            return;
        }
        let combined = if self.identity { m } else { m * self.transform };
        if !combined.is_finite() {
            c.error(span, "the combined transformation overflows");
            return;
        }
        self.transform = combined;
        self.identity = false;
        if self.surface.texture.is_some() && self.texture_space.is_none() {
            self.cached_surface = None;
        }
    }

    /// Object space to world space for a point.
    pub(crate) fn point(&self, p: [f64; 3]) -> DVec3 {
        let p = DVec3::from_array(p);
        if self.identity {
            p
        } else {
            self.transform.transform_point3(p)
        }
    }
}

/// Rotation by `deg[0]` degrees about x, then `deg[1]` about y, then `deg[2]` about z.
pub(crate) fn rotation_xyz(deg: [f64; 3]) -> DMat3 {
    DMat3::from_rotation_z(deg[2].to_radians())
        * DMat3::from_rotation_y(deg[1].to_radians())
        * DMat3::from_rotation_x(deg[0].to_radians())
}

/// A 3x4 matrix given row by row as an affine map.
pub fn rows_to_affine(m: &[f64; 12]) -> DAffine3 {
    DAffine3 {
        matrix3: DMat3::from_cols(
            DVec3::new(m[0], m[4], m[8]),
            DVec3::new(m[1], m[5], m[9]),
            DVec3::new(m[2], m[6], m[10]),
        ),
        translation: DVec3::new(m[3], m[7], m[11]),
    }
}
