//! The secondary rays at a hit: the reflected ray (weighted by ksr and, on a transmitting
//! surface, Fresnel's F) and the refracted ray (kst (1 - F)), each spawned only above the
//! weight threshold and within the depth limit, with gloss and translucency perturbing them.
//! Under Haines's procedure ([`super::TraceOptions::spawn_all`]) every ray is spawned.
//! On a smooth triangle the directions come from the shading normal but must leave on the
//! right side of the geometric surface ([`mirror_direction`], [`refracted_direction`]), and
//! the rays start off the geometric surface.

use super::hall::{RayKind, SurfacePoint, Tracer};
use super::optics::{fresnel, reflect, refract};
use crate::geometry::{offset_from, Ray, RayPre, Real, Vec3};
use crate::sampler::SampleStream;

impl Tracer<'_> {
    /// `result` plus the reflected and refracted rays' contributions at `at`.
    pub(super) fn secondary_rays(
        &mut self,
        at: &SurfacePoint,
        ray: &Ray,
        depth: u32,
        weight: Real,
        rng: &mut SampleStream,
        mut result: Vec3,
    ) -> Vec3 {
        let world = &self.scene.world;
        let (p, nf, ng, v, surf) = (at.p, at.nf, at.ng, at.v, at.surf);
        let (ksr, kst) = (surf.ksr(), surf.kst());
        let cos_i = v.dot(nf).max(0.0);
        let f = if kst > 0.0 {
            fresnel(cos_i, at.n_view, at.n_far)
        } else {
            1.0
        };

        // Haines's procedure spawns what the Hall model weighs 0 (a transmitter's reflection
        // when ksr = 0, rays below an ancestor of weight 0), to count it.
        let every = self.opts.spawn_all;
        let w_refl = ksr * f;
        if (ksr > 0.0 || (every && kst > 0.0)) && (every || weight * w_refl > self.opts.min_weight)
        {
            let mirror = mirror_direction(ray.dir, nf, ng);
            let mut dir = mirror;
            if surf.gloss > 0.0 && world.features.gloss {
                dir = perturb(dir, surf.gloss, rng);
                if dir.dot(ng) <= 0.0 {
                    dir = mirror;
                }
            }
            let r = Ray {
                origin: offset_from(p, ng, ray.origin),
                dir,
                time: ray.time,
            };
            let c = self.trace_pre(
                leaving(at, ng, r),
                RayKind::Reflected,
                depth + 1,
                weight * w_refl,
                at.media_view,
                rng,
            );
            result += c * w_refl;
        }

        // Total internal reflection (F = 1) is counted whatever the weights, as Haines's
        // "refract rays" counts it.
        let w_refr = kst * (1.0 - f);
        let spawn = every || weight * w_refr > self.opts.min_weight;
        if kst > 0.0 && (spawn || f >= 1.0) {
            let bent = if at.closed {
                refracted_direction(ray.dir, nf, ng, at.n_view / at.n_far)
            } else {
                Some(ray.dir)
            };
            if bent.is_none() {
                self.counters.total_internal += 1;
            }
            if let Some(mut dir) = bent.filter(|_| spawn) {
                if surf.translucency > 0.0 && world.features.translucency {
                    let d = perturb(dir, surf.translucency, rng);
                    if d.dot(ng) < 0.0 {
                        dir = d;
                    }
                }
                let r = Ray {
                    origin: offset_from(p, -ng, ray.origin),
                    dir,
                    time: ray.time,
                };
                let c = self.trace_pre(
                    leaving(at, -ng, r),
                    RayKind::Refracted,
                    depth + 1,
                    weight * w_refr,
                    at.media_far,
                    rng,
                );
                result += c * w_refr;
            }
        }
        result
    }
}

/// Secondary ray `r` from `at`, offset along `side`, prepared: it skips the flat face it
/// leaves ([`super::hall::FlatFace`]), as shadow rays do.
fn leaving(at: &SurfacePoint, side: Vec3, r: Ray) -> RayPre {
    let pre = RayPre::new(r);
    match &at.face {
        Some(face) if face.left_by(side, r.dir) => pre.leaving(face.prims),
        _ => pre,
    }
}

/// The mirror direction of `d` about the shading normal `nf`; if that points below the
/// geometric surface (`ng`, facing the viewer, as `nf` does; they differ only on smooth
/// triangles), the mirror direction about `ng` instead, which always leaves on the viewer's
/// side. (Flipping the bad direction's normal component would also leave on that side, but
/// would send grazing rays along the surface; the geometric mirror is what the flat facet
/// itself does.)
pub fn mirror_direction(d: Vec3, nf: Vec3, ng: Vec3) -> Vec3 {
    let dir = reflect(d, nf);
    if nf == ng || dir.dot(ng) > 0.0 {
        dir
    } else {
        reflect(d, ng)
    }
}

/// The refraction of `d` through the shading normal `nf` with `eta` = n_view / n_far; if
/// that does not cross the geometric surface (`ng`, facing the viewer), the refraction
/// through `ng` instead. `None` on total internal reflection.
pub fn refracted_direction(d: Vec3, nf: Vec3, ng: Vec3, eta: Real) -> Option<Vec3> {
    let dir = refract(d, nf, eta)?;
    if nf == ng || dir.dot(ng) < 0.0 {
        Some(dir)
    } else {
        refract(d, ng, eta)
    }
}

/// A direction within a cone of half angle `deg` degrees around the unit vector `d`
/// (uniform in solid angle).
fn perturb(d: Vec3, deg: Real, rng: &mut SampleStream) -> Vec3 {
    let cos_max = deg.min(90.0).to_radians().cos();
    let (a, b) = rng.next_2d();
    let cos = 1.0 - a * (1.0 - cos_max);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * std::f64::consts::PI * b;
    let u = d.any_orthonormal_vector();
    let w = d.cross(u);
    (d * cos + u * (sin * phi.cos()) + w * (sin * phi.sin())).normalize()
}
