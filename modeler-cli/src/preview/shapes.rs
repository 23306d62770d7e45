//! A compiled world as things a preview can draw: polygons (spheres and ellipsoids become
//! latitude-longitude meshes), and quadrics, which are ray cast per pixel when shaded and
//! drawn as contour slices in wireframe.

use glam::{DAffine3, DMat4, DVec3, DVec4};
use yari::model::{HalfSpace, Shape, World};

/// Rings and segments of the sphere mesh.
const SPHERE_RINGS: usize = 8;
const SPHERE_SEGMENTS: usize = 16;

/// A clipped quadric as the preview draws it.
pub struct Quadric {
    /// The quadric's matrix in world space: points p with p^T Q p = 0 (p homogeneous).
    pub q: DMat4,
    /// The half-spaces that clip it.
    pub clip: Vec<HalfSpace>,
    /// The axis-aligned box among the clipping planes, if they close one.
    pub bounds: Option<(DVec3, DVec3)>,
    /// Its surface colour.
    pub color: [f32; 3],
}

/// Everything a world's objects give the preview to draw.
#[derive(Default)]
pub struct Drawables {
    /// Polygons (world-space outlines) with their colours; spheres and ellipsoids as meshes.
    pub polygons: Vec<(Vec<DVec3>, [f32; 3])>,
    /// Clipped quadrics, ray cast when shaded.
    pub quadrics: Vec<Quadric>,
}

impl Drawables {
    /// The drawables of a compiled world.
    pub fn from_world(world: &World) -> Drawables {
        let mut d = Drawables::default();
        for obj in &world.objects {
            let color = world
                .surfaces
                .get(obj.surface as usize)
                .map(|s| s.color)
                .unwrap_or(DVec3::ONE);
            let color = [color.x as f32, color.y as f32, color.z as f32].map(|c| {
                if c.is_finite() {
                    c.clamp(0.0, 1.0)
                } else {
                    1.0
                }
            });
            match &obj.shape {
                Shape::Polygon { vertices } | Shape::SmoothPolygon { vertices, .. } => {
                    d.polygons.push((vertices.clone(), color))
                }
                Shape::Sphere { center, radius } => {
                    let m = DAffine3::from_scale_rotation_translation(
                        DVec3::splat(*radius),
                        glam::DQuat::IDENTITY,
                        *center,
                    );
                    d.polygons
                        .extend(sphere_mesh(&m).into_iter().map(|p| (p, color)));
                }
                Shape::Ellipsoid { to_world } => d
                    .polygons
                    .extend(sphere_mesh(to_world).into_iter().map(|p| (p, color))),
                Shape::Quadric(q) => d.quadrics.push(Quadric {
                    q: matrix(&q.q),
                    clip: q.clip.clone(),
                    bounds: box_of(&q.clip),
                    color,
                }),
            }
        }
        d
    }

    /// The box around everything with a finite extent (None when there is nothing).
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let mut pts: Vec<DVec3> = self
            .polygons
            .iter()
            .flat_map(|(p, _)| p.iter().copied())
            .collect();
        for q in &self.quadrics {
            if let Some((lo, hi)) = q.bounds {
                pts.push(lo);
                pts.push(hi);
            }
        }
        bounds_of(pts.iter().copied())
    }
}

/// The box around some points, skipping non-finite ones.
pub fn bounds_of(pts: impl Iterator<Item = DVec3>) -> Option<(DVec3, DVec3)> {
    pts.filter(|p| p.is_finite())
        .fold(None, |acc, p| match acc {
            None => Some((p, p)),
            Some((lo, hi)) => Some((lo.min(p), hi.max(p))),
        })
}

/// The unit sphere as quads and pole triangles, mapped by `m`, counter-clockwise outside.
fn sphere_mesh(m: &DAffine3) -> Vec<Vec<DVec3>> {
    let point = |ring: usize, seg: usize| {
        let theta = std::f64::consts::PI * ring as f64 / SPHERE_RINGS as f64;
        let phi = std::f64::consts::TAU * seg as f64 / SPHERE_SEGMENTS as f64;
        m.transform_point3(DVec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            -theta.sin() * phi.sin(),
        ))
    };
    let mut faces = Vec::new();
    for r in 0..SPHERE_RINGS {
        for s in 0..SPHERE_SEGMENTS {
            let s1 = (s + 1) % SPHERE_SEGMENTS;
            let mut f = vec![point(r, s), point(r + 1, s), point(r + 1, s1), point(r, s1)];
            if r == 0 {
                f.remove(0);
            } else if r + 1 == SPHERE_RINGS {
                f.remove(1);
            }
            faces.push(f);
        }
    }
    faces
}

fn matrix(q: &[f64; 10]) -> DMat4 {
    let [a, b, c, d, e, f, g, h, i, j] = *q;
    DMat4::from_cols(
        DVec4::new(a, b, c, d),
        DVec4::new(b, e, f, g),
        DVec4::new(c, f, h, i),
        DVec4::new(d, g, i, j),
    )
}

/// The box closed by axis-aligned clipping planes, if all six sides are present.
fn box_of(clip: &[HalfSpace]) -> Option<(DVec3, DVec3)> {
    let mut lo = DVec3::splat(f64::NEG_INFINITY);
    let mut hi = DVec3::splat(f64::INFINITY);
    for h in clip {
        for k in 0..3 {
            let mut axis = DVec3::ZERO;
            axis[k] = 1.0;
            let n = h.normal.length();
            if n == 0.0 {
                continue;
            }
            if (h.normal / n - axis).length() < 1e-12 {
                hi[k] = hi[k].min(h.offset / n);
            } else if (h.normal / n + axis).length() < 1e-12 {
                lo[k] = lo[k].max(-h.offset / n);
            }
        }
    }
    (lo.is_finite() && hi.is_finite() && lo.cmple(hi).all()).then_some((lo, hi))
}

impl Quadric {
    fn value(&self, p: DVec3) -> f64 {
        let h = p.extend(1.0);
        h.dot(self.q * h)
    }

    fn inside(&self, p: DVec3, tol: f64) -> bool {
        self.clip.iter().all(|h| h.normal.dot(p) <= h.offset + tol)
    }

    /// The nearest hit beyond t = 0 on a ray, with the surface normal there.
    pub fn hit(&self, o: DVec3, d: DVec3) -> Option<(DVec3, DVec3)> {
        let (oh, dh) = (o.extend(1.0), d.extend(0.0));
        let a = dh.dot(self.q * dh);
        let b = 2.0 * dh.dot(self.q * oh);
        let c = oh.dot(self.q * oh);
        let mut roots = if a.abs() < 1e-14 * (b.abs() + c.abs()).max(1e-300) {
            if b == 0.0 {
                return None;
            }
            vec![-c / b]
        } else {
            let disc = b * b - 4.0 * a * c;
            if disc < 0.0 {
                return None;
            }
            let s = disc.sqrt();
            let q = -0.5 * (b + b.signum() * s);
            let mut r = vec![q / a];
            if q != 0.0 {
                r.push(c / q);
            }
            r
        };
        roots.sort_by(f64::total_cmp);
        for t in roots.into_iter().filter(|t| *t > 1e-9) {
            let p = o + d * t;
            if self.inside(p, 1e-9 * (1.0 + p.length())) {
                let n = (self.q * p.extend(1.0)).truncate();
                return Some((p, n.normalize_or_zero()));
            }
        }
        None
    }

    /// Contour segments of the surface on slices across `lo..hi` along each axis
    /// (marching squares), kept where they are inside the clipping.
    pub fn slices(&self, lo: DVec3, hi: DVec3, levels: usize, grid: usize) -> Vec<(DVec3, DVec3)> {
        let mut out = Vec::new();
        let size = hi - lo;
        let tol = 1e-6 * (1.0 + size.length());
        for k in 0..3 {
            let (u, v) = ((k + 1) % 3, (k + 2) % 3);
            for l in 0..levels {
                let mut base = lo;
                base[k] = lo[k] + size[k] * (l as f64 + 0.5) / levels as f64;
                let at = |i: usize, j: usize| {
                    let mut p = base;
                    p[u] = lo[u] + size[u] * i as f64 / grid as f64;
                    p[v] = lo[v] + size[v] * j as f64 / grid as f64;
                    p
                };
                for i in 0..grid {
                    for j in 0..grid {
                        let corners = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                        let vals = corners.map(|p| self.value(p));
                        let mut cuts = Vec::new();
                        for e in 0..4 {
                            let (a, b) = (e, (e + 1) % 4);
                            if (vals[a] < 0.0) != (vals[b] < 0.0) {
                                let t = vals[a] / (vals[a] - vals[b]);
                                cuts.push(corners[a] + (corners[b] - corners[a]) * t);
                            }
                        }
                        for pair in cuts.chunks_exact(2) {
                            if self.inside(pair[0], tol) && self.inside(pair[1], tol) {
                                out.push((pair[0], pair[1]));
                            }
                        }
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_sphere_quadric() -> Quadric {
        let q = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, -1.0];
        Quadric {
            q: matrix(&q),
            clip: vec![],
            bounds: None,
            color: [1.0; 3],
        }
    }

    #[test]
    fn a_ray_hits_the_unit_sphere_quadric_at_distance_one_less() {
        let s = unit_sphere_quadric();
        let (p, n) = s.hit(DVec3::new(0.0, 0.0, 5.0), DVec3::NEG_Z).unwrap();
        assert!((p - DVec3::Z).length() < 1e-12 && (n - DVec3::Z).length() < 1e-12);
        assert!(s.hit(DVec3::new(0.0, 2.0, 5.0), DVec3::NEG_Z).is_none());
    }

    #[test]
    fn clipping_removes_the_near_half() {
        let mut s = unit_sphere_quadric();
        s.clip.push(HalfSpace {
            normal: DVec3::Z,
            offset: 0.0,
        });
        let (p, _) = s.hit(DVec3::new(0.0, 0.0, 5.0), DVec3::NEG_Z).unwrap();
        assert!((p + DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn slices_of_the_sphere_lie_on_it() {
        let s = unit_sphere_quadric();
        let segs = s.slices(DVec3::splat(-1.0), DVec3::splat(1.0), 3, 16);
        assert!(segs.len() > 30);
        for (a, b) in segs {
            assert!((a.length() - 1.0).abs() < 0.05 && (b.length() - 1.0).abs() < 0.05);
        }
    }

    #[test]
    fn a_clip_box_is_recovered_from_its_planes() {
        let planes = [
            (DVec3::X, 2.0),
            (-DVec3::X, 1.0),
            (DVec3::Y, 3.0),
            (-DVec3::Y, 0.0),
            (DVec3::Z, 1.0),
            (-DVec3::Z, 1.0),
        ];
        let clip: Vec<HalfSpace> = planes
            .iter()
            .map(|(n, o)| HalfSpace {
                normal: *n,
                offset: *o,
            })
            .collect();
        assert_eq!(
            box_of(&clip),
            Some((DVec3::new(-1.0, 0.0, -1.0), DVec3::new(2.0, 3.0, 1.0)))
        );
        assert_eq!(box_of(&clip[..5]), None);
    }

    #[test]
    fn sphere_meshes_are_closed_and_outward() {
        let faces = sphere_mesh(&DAffine3::IDENTITY);
        let mesh = crate::mesh::Mesh::from_polygons(
            faces
                .iter()
                .map(|f| f.iter().map(|p| p.to_array()).collect::<Vec<_>>())
                .collect::<Vec<_>>()
                .iter()
                .map(|f| f.as_slice()),
        );
        assert!(
            mesh.signed_volume() > 3.0 && mesh.signed_volume() < 4.0 * std::f64::consts::PI / 3.0
        );
    }
}
