//! The secondary rays at a hit: the reflected ray (weighted by ksr and, on a transmitting
//! surface, Fresnel's F) and the refracted ray (kst (1 - F)), each spawned only above the
//! weight threshold and within the depth limit, with gloss and translucency perturbing them.
//! Under Haines's procedure ([`super::TraceOptions::spawn_all`]) every ray is spawned.

use super::hall::{RayKind, SurfacePoint, Tracer};
use super::optics::{fresnel, reflect, refract};
use crate::geometry::{offset_from, Ray, Real, Vec3};
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
        let (p, nf, v, surf) = (at.p, at.nf, at.v, at.surf);
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
            let mut dir = reflect(ray.dir, nf);
            if surf.gloss > 0.0 && world.features.gloss {
                dir = perturb(dir, surf.gloss, rng);
                if dir.dot(nf) <= 0.0 {
                    dir = reflect(ray.dir, nf);
                }
            }
            let r = Ray {
                origin: offset_from(p, nf, ray.origin),
                dir,
                time: ray.time,
            };
            let c = self.trace(
                r,
                RayKind::Reflected,
                depth + 1,
                weight * w_refl,
                at.media_view,
                rng,
            );
            result += c * w_refl;
        }

        let w_refr = kst * (1.0 - f);
        if kst > 0.0 && (every || weight * w_refr > self.opts.min_weight) {
            let bent = if at.closed {
                refract(ray.dir, nf, at.n_view / at.n_far)
            } else {
                Some(ray.dir)
            };
            if let Some(mut dir) = bent {
                if surf.translucency > 0.0 && world.features.translucency {
                    let d = perturb(dir, surf.translucency, rng);
                    if d.dot(nf) < 0.0 {
                        dir = d;
                    }
                }
                let r = Ray {
                    origin: offset_from(p, -nf, ray.origin),
                    dir,
                    time: ray.time,
                };
                let c = self.trace(
                    r,
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
