//! Skeletons (thesis section 2.4.1): points, line segments and Bézier curves drawn in one
//! principal plane, from which primitives are created and which revolve and extrude sweep.
//!
//! A skeleton's points are two-dimensional, in the plane's own axes: plane `xy` takes
//! `x,y` (the front view), `xz` takes `x,z` (the top view) and `yz` takes `y,z` (the side
//! view); the third coordinate is the skeleton's `depth`. A Bézier skeleton is a chain of
//! Bézier pieces of one degree (default cubic): an open chain of n pieces has `degree*n + 1`
//! control points, a closed one `degree*n` (the last piece ends at the first point). Each
//! piece is flattened into `smoothness` line segments.

use crate::error::ModelError;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// The default number of line segments per Bézier piece.
pub const DEFAULT_SMOOTHNESS: u32 = 8;
/// The most line segments per Bézier piece (keeps a typo from making millions of polygons).
pub const MAX_SMOOTHNESS: u32 = 256;

/// A principal plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Plane {
    /// x,y (the front view); depth is z.
    Xy,
    /// x,z (the top view); depth is y.
    Xz,
    /// y,z (the side view); depth is x.
    Yz,
}

impl Plane {
    /// The world axes (0 = x, 1 = y, 2 = z) of the plane's u and v, and its normal axis.
    pub fn axes(self) -> (usize, usize, usize) {
        match self {
            Plane::Xy => (0, 1, 2),
            Plane::Xz => (0, 2, 1),
            Plane::Yz => (1, 2, 0),
        }
    }
    /// The 3D point of plane coordinates (u, v) at `depth`.
    pub fn to_3d(self, p: [f64; 2], depth: f64) -> DVec3 {
        let (a, b, n) = self.axes();
        let mut out = [0.0; 3];
        out[a] = p[0];
        out[b] = p[1];
        out[n] = depth;
        DVec3::from_array(out)
    }
    pub fn name(self) -> &'static str {
        match self {
            Plane::Xy => "xy",
            Plane::Xz => "xz",
            Plane::Yz => "yz",
        }
    }
}

/// What a skeleton's points mean.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SkeletonKind {
    /// Separate points (a sphere's centre and surface point, for instance).
    Points,
    /// Line segments joining the points in order.
    Lines,
    /// A chain of Bézier pieces with the points as control points.
    Bezier,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Skeleton {
    pub name: String,
    pub plane: Plane,
    /// The coordinate along the plane's normal axis.
    #[serde(default)]
    pub depth: f64,
    pub kind: SkeletonKind,
    /// Whether the outline returns to its first point.
    #[serde(default)]
    pub closed: bool,
    pub points: Vec<[f64; 2]>,
    /// Degree of each Bézier piece.
    #[serde(default = "default_degree")]
    pub degree: u32,
    /// Line segments per Bézier piece.
    #[serde(default = "default_smoothness")]
    pub smoothness: u32,
}

fn default_degree() -> u32 {
    3
}
fn default_smoothness() -> u32 {
    DEFAULT_SMOOTHNESS
}

impl Skeleton {
    pub fn new(name: &str, plane: Plane, kind: SkeletonKind) -> Skeleton {
        Skeleton {
            name: name.into(),
            plane,
            depth: 0.0,
            kind,
            closed: false,
            points: Vec::new(),
            degree: 3,
            smoothness: DEFAULT_SMOOTHNESS,
        }
    }

    /// The points in 3D.
    pub fn points_3d(&self) -> Vec<DVec3> {
        self.points
            .iter()
            .map(|p| self.plane.to_3d(*p, self.depth))
            .collect()
    }

    /// The skeleton as a polyline in plane coordinates: the points themselves, or the
    /// flattened Bézier chain with `smoothness` (or the skeleton's own) segments per piece.
    /// A closed outline does not repeat its first point at the end.
    pub fn curve_2d(&self, smoothness: Option<u32>) -> Result<Vec<[f64; 2]>, ModelError> {
        match self.kind {
            SkeletonKind::Points | SkeletonKind::Lines => Ok(self.points.clone()),
            SkeletonKind::Bezier => self.flatten_bezier(smoothness.unwrap_or(self.smoothness)),
        }
    }

    /// [`Skeleton::curve_2d`] in 3D.
    pub fn curve_3d(&self, smoothness: Option<u32>) -> Result<Vec<DVec3>, ModelError> {
        Ok(self
            .curve_2d(smoothness)?
            .into_iter()
            .map(|p| self.plane.to_3d(p, self.depth))
            .collect())
    }

    fn flatten_bezier(&self, smoothness: u32) -> Result<Vec<[f64; 2]>, ModelError> {
        let d = self.degree as usize;
        if d == 0 {
            return Err(ModelError::skeleton(
                &self.name,
                "the Bézier degree must be at least 1",
            ));
        }
        if smoothness == 0 || smoothness > MAX_SMOOTHNESS {
            return Err(ModelError::skeleton(
                &self.name,
                format!("smoothness must be 1..={MAX_SMOOTHNESS}"),
            ));
        }
        let n = self.points.len();
        let mut control = self.points.clone();
        let pieces = if self.closed {
            if n < d || !n.is_multiple_of(d) {
                return Err(ModelError::skeleton(
                    &self.name,
                    format!("a closed Bézier chain of degree {d} needs a multiple of {d} control points (has {n})"),
                ));
            }
            control.push(self.points[0]);
            n / d
        } else {
            if n < d + 1 || !(n - 1).is_multiple_of(d) {
                return Err(ModelError::skeleton(
                    &self.name,
                    format!(
                        "an open Bézier chain of degree {d} needs {d}*k+1 control points (has {n})"
                    ),
                ));
            }
            (n - 1) / d
        };
        let mut out = vec![control[0]];
        for piece in 0..pieces {
            let cps = &control[piece * d..=piece * d + d];
            for s in 1..=smoothness {
                out.push(de_casteljau(cps, s as f64 / smoothness as f64));
            }
        }
        if self.closed {
            out.pop();
        }
        Ok(out)
    }
}

/// A point on a Bézier curve by de Casteljau's algorithm.
pub fn de_casteljau(control: &[[f64; 2]], t: f64) -> [f64; 2] {
    let mut pts = control.to_vec();
    let n = pts.len();
    for level in 1..n {
        for i in 0..n - level {
            pts[i] = [
                pts[i][0] + (pts[i + 1][0] - pts[i][0]) * t,
                pts[i][1] + (pts[i + 1][1] - pts[i][1]) * t,
            ];
        }
    }
    pts[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bez(points: &[[f64; 2]], closed: bool) -> Skeleton {
        let mut s = Skeleton::new("c", Plane::Xy, SkeletonKind::Bezier);
        s.points = points.to_vec();
        s.closed = closed;
        s
    }

    #[test]
    fn planes_place_points_on_their_axes() {
        assert_eq!(Plane::Xy.to_3d([1.0, 2.0], 3.0), DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(Plane::Xz.to_3d([1.0, 2.0], 3.0), DVec3::new(1.0, 3.0, 2.0));
        assert_eq!(Plane::Yz.to_3d([1.0, 2.0], 3.0), DVec3::new(3.0, 1.0, 2.0));
    }

    #[test]
    fn a_cubic_passes_through_its_ends_and_its_midpoint_formula() {
        let p = [[0.0, 0.0], [1.0, 2.0], [3.0, 2.0], [4.0, 0.0]];
        let mut s = bez(&p, false);
        s.smoothness = 4;
        let c = s.curve_2d(None).unwrap();
        assert_eq!(c.len(), 5);
        assert_eq!(c[0], p[0]);
        assert_eq!(c[4], p[3]);
        // B(1/2) = (P0 + 3 P1 + 3 P2 + P3) / 8.
        let mid = [(0.0 + 3.0 + 9.0 + 4.0) / 8.0, (0.0 + 6.0 + 6.0 + 0.0) / 8.0];
        assert!((c[2][0] - mid[0]).abs() < 1e-12 && (c[2][1] - mid[1]).abs() < 1e-12);
    }

    #[test]
    fn smoothness_sets_the_segment_count() {
        let p = [
            [0.0, 0.0],
            [1.0, 1.0],
            [2.0, 1.0],
            [3.0, 0.0],
            [4.0, -1.0],
            [5.0, -1.0],
            [6.0, 0.0],
        ];
        let s = bez(&p, false);
        assert_eq!(s.curve_2d(Some(2)).unwrap().len(), 2 * 2 + 1);
        assert_eq!(s.curve_2d(Some(10)).unwrap().len(), 2 * 10 + 1);
        let closed = bez(&p[..6], true);
        assert_eq!(closed.curve_2d(Some(3)).unwrap().len(), 2 * 3);
    }

    #[test]
    fn a_wrong_control_point_count_is_explained() {
        let s = bez(&[[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]], false);
        let e = s.curve_2d(None).unwrap_err().to_string();
        assert!(e.contains("3*k+1") && e.contains("has 3"), "{e}");
    }
}
