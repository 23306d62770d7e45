//! The pieces of Haines's output library the generators need, NFF branch only, kept step for
//! step so the entities (and thus the printed text) are his: `lib_output_color` (`libpr1.c`),
//! `lib_output_polygon` (`libply.c`), `lib_output_sphere` and `lib_output_cylcone`
//! (`libpr2.c`) and the transformation stack of `libtx.c` (`jacks`).
//!
//! Spheres and cylinders/cones are written as his `curve_format` says ([`CurveFormat`]): as
//! `s` and `c` (his default, `OUTPUT_CURVES`), or as `pp` triangles (`-t`, `OUTPUT_PATCHES`,
//! made by [`super::haines_patches`]).

use super::haines_lib::{
    matrix_multiply, normalize_len, rotate_matrix, scale_matrix, transform_point, translate_matrix,
    Axis, Coord4, Matrix,
};
use super::haines_patches::{polygon_cylcone, polygon_sphere, PatchTx};
use crate::ast::Vec3;
use crate::nff::{Entity, Fill, NffScene};
use std::f64::consts::PI;

/// `EPSILON` of `def.h` (not on a Macintosh): how far from the identity a transformation
/// must be to count as one.
const EPSILON: f64 = 1.0e-8;
/// `EPSILON2` of `def.h`: edges shorter than this are collapsed by `lib_output_polygon`.
const EPSILON2: f64 = 1.0e-6;

/// `lib_output_color` for NFF: the `f` line for colour `color`, diffuse `kd`, specular `ks`,
/// highlight half-angle `ang` degrees, transmittance `kt` and index of refraction `ior`
/// (his ambient and `ks_spec` arguments are not written to NFF). The Phong exponent is his:
/// 100000 for an angle of 0 or less, 1 from 90 degrees on, else `ln 0.5 / ln cos(ang)`.
pub fn color(s: &mut NffScene, color: Vec3, kd: f64, ks: f64, ang: f64, kt: f64, ior: f64) {
    let ang_radians = PI * ang / 180.0;
    let shine = if ang_radians <= 0.0 {
        100000.0
    } else if ang_radians >= PI / 2.0 {
        1.0
    } else {
        0.5f64.ln() / ang_radians.cos().ln()
    };
    s.push(Entity::Fill(Fill {
        color,
        kd,
        ks,
        shine,
        t: kt,
        ior,
    }));
}

/// `lib_output_polygon`: first collapses every vertex closer than `EPSILON2` to the next one
/// (cyclically), IN PLACE as his code does (the caller's array is changed: later vertices
/// move down, the last ones repeat), then writes a `p` if three or more vertices are left.
pub fn polygon(s: &mut NffScene, vert: &mut [[f64; 3]]) {
    let mut tot_vert = vert.len();
    let mut i = 0;
    while i < tot_vert {
        let a = vert[i];
        let b = vert[(i + 1) % tot_vert];
        let (_, len) = normalize_len([a[0] - b[0], a[1] - b[1], a[2] - b[2]]);
        if len < EPSILON2 {
            vert.copy_within(i + 1..tot_vert, i);
            tot_vert -= 1;
        } else {
            i += 1;
        }
    }
    if tot_vert < 3 {
        return;
    }
    s.push(Entity::Polygon {
        vertices: vert[..tot_vert].to_vec(),
        normals: None,
    });
}

/// His programs' `curve_format`: how spheres, cylinders and cones are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CurveFormat {
    /// `OUTPUT_CURVES` (his default, `-c`): spheres as `s`, cylinders and cones as `c`.
    #[default]
    Curves,
    /// `OUTPUT_PATCHES` (`-t [N]`): every sphere as 12 R^2 and every cylinder or cone as 8 R
    /// `pp` triangles with vertex normals (`lib_output_polygon_sphere` and
    /// `lib_output_polygon_cylcone`), R being the resolution.
    Patches {
        /// His `gU_resolution` = `gV_resolution`: `None` for his programs' own
        /// ([`DEFAULT_RESOLUTION`], 3; `jacks` sets 2), or R for every database (his `-t R`;
        /// his `jacks` ignores it and his `shells` refuses it).
        resolution: Option<u32>,
    },
}

impl CurveFormat {
    /// `-t` alone: patches at his programs' resolutions (108 triangles a sphere and 24 a
    /// cylinder or cone; in `jacks`, 48 and 16).
    pub const PATCHES: CurveFormat = CurveFormat::Patches { resolution: None };

    /// This format with `resolution` as the default (`lib_set_polygonalization` of a
    /// program, which `jacks` calls with 2): patches without a resolution get it.
    pub fn with_default_resolution(self, resolution: u32) -> CurveFormat {
        match self {
            CurveFormat::Patches { resolution: None } => CurveFormat::Patches {
                resolution: Some(resolution),
            },
            f => f,
        }
    }
}

/// `OUTPUT_RESOLUTION` of `lib.h`: the default amount of polygonalization.
pub const DEFAULT_RESOLUTION: u32 = 3;

/// The resolution of patches: the one given, else [`DEFAULT_RESOLUTION`].
fn res(resolution: Option<u32>) -> u32 {
    resolution.unwrap_or(DEFAULT_RESOLUTION)
}

/// `lib_output_sphere` without a transformation: `s x y z r` (w is the radius), or its
/// patches.
pub fn sphere(s: &mut NffScene, format: CurveFormat, center: Coord4) {
    match format {
        CurveFormat::Curves => s.push(Entity::Sphere {
            center: [center[0], center[1], center[2]],
            radius: center[3],
        }),
        CurveFormat::Patches { resolution } => polygon_sphere(s, center, res(resolution), None),
    }
}

/// `lib_output_cylcone` without a transformation: `c` from `base` to `apex` (w is the radius
/// at each end), or its patches.
pub fn cylcone(s: &mut NffScene, format: CurveFormat, base: Coord4, apex: Coord4) {
    match format {
        CurveFormat::Curves => s.push(Entity::Cone {
            base: [base[0], base[1], base[2]],
            base_radius: base[3],
            apex: [apex[0], apex[1], apex[2]],
            apex_radius: apex[3],
        }),
        CurveFormat::Patches { resolution } => {
            polygon_cylcone(s, base, apex, res(resolution), None)
        }
    }
}

/// The transformation stack of `libtx.c` (`lib_tx_push`, `lib_tx_pop`, `lib_tx_rotate`,
/// `lib_tx_scale`, `lib_tx_translate`): each new operation is applied to the objects BEFORE
/// the current transformation (`current = op * current`, row vectors).
#[derive(Clone, Debug)]
pub struct TxStack {
    current: Matrix,
    stack: Vec<Matrix>,
}

impl Default for TxStack {
    fn default() -> Self {
        TxStack {
            current: super::haines_lib::identity(),
            stack: Vec::new(),
        }
    }
}

impl TxStack {
    /// `lib_tx_push`: saves the current transformation.
    pub fn push(&mut self) {
        self.stack.push(self.current);
    }

    /// `lib_tx_pop`: restores the last saved transformation (nothing if none was saved; his
    /// code prints a warning then).
    pub fn pop(&mut self) {
        if let Some(m) = self.stack.pop() {
            self.current = m;
        }
    }

    /// `lib_tx_rotate`: rotation by `angle` radians about `axis`.
    pub fn rotate(&mut self, axis: Axis, angle: f64) {
        self.current = matrix_multiply(&rotate_matrix(axis, angle), &self.current);
    }

    /// `lib_tx_scale`.
    pub fn scale(&mut self, v: [f64; 3]) {
        self.current = matrix_multiply(&scale_matrix(v), &self.current);
    }

    /// `lib_tx_translate`.
    pub fn translate(&mut self, v: [f64; 3]) {
        self.current = matrix_multiply(&translate_matrix(v), &self.current);
    }

    /// `lib_tx_active`: some element differs from the identity's by more than `EPSILON`.
    pub fn active(&self) -> bool {
        (0..4).any(|i| {
            (0..4).any(|j| {
                let id = if i == j { 1.0 } else { 0.0 };
                (self.current[i][j] - id).abs() > EPSILON
            })
        })
    }

    /// The x scale `lib_tx_unwind` finds (Thomas's "unmatrix"): the length of the first row
    /// of the upper 3x3, after dividing the matrix by its corner element when that is not 0.
    /// Its sign (flipped for a mirroring matrix) does not matter: the callers take `fabs`.
    fn scale_x(&self) -> f64 {
        let m = &self.current;
        let w = m[3][3];
        let row: [f64; 3] = if w != 0.0 {
            [m[0][0] / w, m[0][1] / w, m[0][2] / w]
        } else {
            [m[0][0], m[0][1], m[0][2]]
        };
        normalize_len(row).1
    }

    /// `lib_output_sphere` under the current transformation: the centre transformed as a
    /// point, the radius times the x scale ("this assumes uniform scaling"); in patches, the
    /// sphere's triangles transformed (see [`super::haines_patches`]).
    pub fn sphere(&self, s: &mut NffScene, format: CurveFormat, center: Coord4) {
        if !self.active() {
            return sphere(s, format, center);
        }
        match format {
            CurveFormat::Curves => {
                let c = transform_point([center[0], center[1], center[2]], &self.current);
                sphere(
                    s,
                    format,
                    [c[0], c[1], c[2], center[3] * self.scale_x().abs()],
                );
            }
            CurveFormat::Patches { resolution } => {
                let tx = PatchTx::new(&self.current);
                polygon_sphere(s, center, res(resolution), Some(&tx));
            }
        }
    }

    /// `lib_output_cylcone` under the current transformation, as [`TxStack::sphere`] for
    /// both ends; in patches, its triangles transformed.
    pub fn cylcone(&self, s: &mut NffScene, format: CurveFormat, base: Coord4, apex: Coord4) {
        if !self.active() {
            return cylcone(s, format, base, apex);
        }
        match format {
            CurveFormat::Curves => {
                let scale = self.scale_x().abs();
                let b = transform_point([base[0], base[1], base[2]], &self.current);
                let a = transform_point([apex[0], apex[1], apex[2]], &self.current);
                cylcone(
                    s,
                    format,
                    [b[0], b[1], b[2], base[3] * scale],
                    [a[0], a[1], a[2], apex[3] * scale],
                );
            }
            CurveFormat::Patches { resolution } => {
                let tx = PatchTx::new(&self.current);
                polygon_cylcone(s, base, apex, res(resolution), Some(&tx));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygon_collapses_repeated_vertices_in_place() {
        let mut s = NffScene::default();
        let mut v = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 0.0, 1e-7],
            [0.0, 1.0, 0.0],
        ];
        polygon(&mut s, &mut v);
        match &s.entities[0].node {
            Entity::Polygon { vertices, .. } => assert_eq!(vertices.len(), 3),
            e => panic!("{e:?}"),
        }
        // The caller's array moved down, its last element repeated, as in C.
        assert_eq!(v[2], [0.0, 1.0, 0.0]);
        assert_eq!(v[3], [0.0, 1.0, 0.0]);
        let mut line = [[0.0; 3], [0.0; 3], [1.0, 0.0, 0.0]];
        polygon(&mut s, &mut line);
        assert_eq!(s.entities.len(), 1, "a two-vertex polygon is dropped");
    }

    #[test]
    fn transformations_apply_the_newest_first() {
        let mut tx = TxStack::default();
        assert!(!tx.active());
        tx.push();
        tx.translate([1.0, 0.0, 0.0]);
        tx.scale([0.5, 0.5, 0.5]);
        assert!(tx.active());
        let mut s = NffScene::default();
        // Scaled first, then moved: (2, 0, 0) r 1 becomes (2, 0, 0) r 0.5.
        tx.sphere(&mut s, CurveFormat::Curves, [2.0, 0.0, 0.0, 1.0]);
        tx.pop();
        assert!(!tx.active());
        match s.entities[0].node {
            Entity::Sphere { center, radius } => {
                assert_eq!(center, [2.0, 0.0, 0.0]);
                assert_eq!(radius, 0.5);
            }
            ref e => panic!("{e:?}"),
        }
    }

    #[test]
    fn color_matches_his_phong_exponents() {
        let mut s = NffScene::default();
        color(&mut s, [1.0; 3], 0.5, 0.5, 37.0, 0.0, 1.0);
        color(&mut s, [1.0; 3], 0.5, 0.5, 0.0, 0.0, 1.0);
        color(&mut s, [1.0; 3], 0.5, 0.5, 90.0, 0.0, 1.0);
        let shine: Vec<f64> = s
            .entities
            .iter()
            .map(|e| match e.node {
                Entity::Fill(f) => f.shine,
                _ => f64::NAN,
            })
            .collect();
        assert_eq!(crate::nff::write::g(shine[0]), "3.0827");
        assert_eq!(shine[1..], [100000.0, 1.0]);
    }
}
