//! The recursive Hall-model ray tracer. What every surface attribute does is documented in
//! docs/renderer.md; in short, at a hit with colour C (textured), normal N facing the viewer,
//! V towards the viewer and, per light j, L_j, I_j (after shadowing):
//!
//! ```text
//! ka Ia C                                         ambient
//! + kdr C sum I_j (N.L_j)        lights in front  diffuse reflection
//! + ksr sum I_j (N.H_j)^phong    lights in front  specular reflection highlight
//! + kdt C sum I_j (N'.L_j)       lights behind    diffuse transmission    (kst > 0 only)
//! + kst sum I_j (N'.H'_j)^phong  lights behind    specular transmission highlight (kst > 0)
//! + ksr F  I_r  T^dist                            reflected ray  (ksr > 0; F = 1 if opaque)
//! + kst (1-F) I_t T^dist                          refracted ray  (kst > 0)
//! ```

use super::media::{Media, Medium};
use super::optics::{fresnel, reflect, refract};
use crate::accel::{Accel, Scratch};
use crate::geometry::{offset_from, Ray, RayPre, Real, Vec3};
use crate::sampler::{sample_disc, SampleStream};
use crate::scene::Scene;
use crate::stats::Counters;
use crate::texture;

/// Ray-tree limits.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TraceOptions {
    /// Maximum depth of the ray tree; the eye ray is level 1 (SPD rule: 5).
    pub max_depth: u32,
    /// A secondary ray is spawned only if its weight (product of the coefficients along its
    /// path) exceeds this.
    pub min_weight: Real,
}

impl Default for TraceOptions {
    fn default() -> TraceOptions {
        TraceOptions {
            max_depth: 5,
            min_weight: 0.001,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    Eye,
    Reflected,
    Refracted,
}

/// Traces rays through one scene; holds the per-thread scratch and counters.
pub struct Tracer<'a> {
    pub scene: &'a Scene,
    pub accel: &'a Accel,
    pub opts: TraceOptions,
    pub scratch: &'a mut Scratch,
    pub counters: &'a mut Counters,
}

/// Maximum transparent surfaces a shadow ray passes through before it is treated as blocked.
const MAX_SHADOW_CROSSINGS: usize = 64;

impl Tracer<'_> {
    /// The colour seen along `ray` (unit direction). `depth` is the ray's level in the tree
    /// (eye = 1), `weight` its contribution to the pixel, `media` the transparent volumes it
    /// travels inside ([`Media::AIR`] for eye rays).
    pub fn trace(
        &mut self,
        ray: Ray,
        kind: RayKind,
        depth: u32,
        weight: Real,
        media: Media,
        rng: &mut SampleStream,
    ) -> Vec3 {
        match kind {
            RayKind::Eye => self.counters.eye += 1,
            RayKind::Reflected => self.counters.reflected += 1,
            RayKind::Refracted => self.counters.refracted += 1,
        }
        let pre = RayPre::new(ray);
        let hit = self.accel.closest(
            &self.scene.prims,
            &pre,
            Real::INFINITY,
            self.scratch,
            self.counters,
        );
        let medium = media.transmissivity();
        let Some(hit) = hit else {
            return match medium {
                Some(t) if t < 1.0 => Vec3::ZERO,
                _ => self.scene.world.background,
            };
        };
        if kind == RayKind::Eye {
            self.counters.eye_hits += 1;
        }
        let colour = self.shade(&ray, hit.t, hit.prim, depth, weight, media, rng);
        match medium {
            Some(t) if t < 1.0 => colour * t.max(0.0).powf(hit.t),
            _ => colour,
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn shade(
        &mut self,
        ray: &Ray,
        t: Real,
        prim_index: u32,
        depth: u32,
        weight: Real,
        media: Media,
        rng: &mut SampleStream,
    ) -> Vec3 {
        let scene = self.scene;
        let world = &scene.world;
        let prim = &scene.prims[prim_index as usize];
        let surf = scene.surface(prim_index);
        let p = ray.at(t);
        let mut n = prim.normal(p, ray.time);
        if n == Vec3::ZERO || !n.is_finite() {
            n = -ray.dir;
        }
        let entering = ray.dir.dot(n) < 0.0;
        let mut colour = surf.color;
        if let Some(tex) = &surf.texture {
            // Textures stick to moving objects: look up at the object's rest position.
            let (c, tn) = texture::apply(tex, surf.color, p - prim.motion * ray.time, n);
            colour = c;
            n = tn;
        }
        // N faces the viewer; geometric side decides entering/leaving.
        let nf = if ray.dir.dot(n) < 0.0 { n } else { -n };
        let v = -ray.dir;
        let (ksr, kst) = (surf.ksr(), surf.kst());
        let closed = prim.is_closed();
        // The volumes on the viewer's side and on the far side, and their refractive indices.
        // A thin sheet (an open polygon, a quadric) has air on both sides and bends nothing.
        let own = Medium {
            surface: prim.surface,
            refract: surf.refract,
            transmissivity: surf.transmissivity,
        };
        let (media_view, media_far, n_view, n_far) = match (closed, entering) {
            (true, true) => (media, media.entering(own), media.index(), surf.refract),
            (true, false) => {
                // Leaving: inside this volume, even if the ray was not known to be.
                let view = if media.contains(prim.surface) {
                    media
                } else {
                    media.entering(own)
                };
                let far = view.leaving(prim.surface);
                (view, far, surf.refract, far.index())
            }
            (false, _) => (media, media, 1.0, surf.refract),
        };

        let mut result = world.ambient * colour * surf.ka;

        for light in &world.lights {
            let mut lp = light.position;
            if light.radius > 0.0 && world.features.area_lights {
                let axis = (lp - p).normalize_or_zero();
                let u = axis.any_orthonormal_vector();
                let w = axis.cross(u);
                let (a, b) = rng.next_2d();
                let (dx, dy) = sample_disc(a, b);
                lp += (u * dx + w * dy) * light.radius;
            }
            let to_light = lp - p;
            let dist = to_light.length();
            if dist.is_nan() || dist <= 0.0 {
                continue;
            }
            let l = to_light / dist;
            let ndl = nf.dot(l);
            if ndl > 0.0 {
                let i = light.color * self.shadow(p, nf, l, dist, ray);
                if i == Vec3::ZERO {
                    continue;
                }
                result += colour * i * (surf.kdr * ndl);
                if ksr > 0.0 {
                    let h = (l + v).normalize_or_zero();
                    result += i * (ksr * h.dot(nf).max(0.0).powf(surf.phong));
                }
            } else if ndl < 0.0 && kst > 0.0 {
                self.counters.shadow_behind += 1;
                let i = light.color * self.shadow(p, -nf, l, dist, ray);
                if i == Vec3::ZERO {
                    continue;
                }
                result += colour * i * (surf.kdt * -ndl);
                // H': the normal that would refract L into V.
                let h = -(l * n_far + v * n_view);
                let cos = match h.try_normalize() {
                    Some(h) => h.dot(-nf).abs(),
                    None => 1.0,
                };
                result += i * (kst * cos.powf(surf.phong));
            }
        }

        if depth >= self.opts.max_depth {
            return result;
        }
        let cos_i = v.dot(nf).max(0.0);
        let f = if kst > 0.0 {
            fresnel(cos_i, n_view, n_far)
        } else {
            1.0
        };

        let w_refl = ksr * f;
        if ksr > 0.0 && weight * w_refl > self.opts.min_weight {
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
                media_view,
                rng,
            );
            result += c * w_refl;
        }

        let w_refr = kst * (1.0 - f);
        if kst > 0.0 && weight * w_refr > self.opts.min_weight {
            let bent = if closed {
                refract(ray.dir, nf, n_view / n_far)
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
                    media_far,
                    rng,
                );
                result += c * w_refr;
            }
        }
        result
    }

    /// The filter a shadow ray from `p` (leaving on the side of `side`) towards a light at
    /// distance `dist` in direction `l` receives: 1 if unblocked, 0 if an opaque surface is in
    /// the way, and the product of `kst * colour` of every transparent surface crossed.
    /// `ray` is the ray that found `p` (its origin scales the offset, its time is the shadow
    /// ray's).
    fn shadow(&mut self, p: Vec3, side: Vec3, l: Vec3, dist: Real, ray: &Ray) -> Vec3 {
        self.counters.shadow += 1;
        let time = ray.time;
        let origin = offset_from(p, side, ray.origin);
        let t_max = (p + l * dist - origin).dot(l);
        let ray = Ray {
            origin,
            dir: l,
            time,
        };
        let pre = RayPre::new(ray);
        let scene = self.scene;
        let opaque = |i: u32| scene.surface(i).kst() <= 0.0;
        // Most shadow rays meet nothing or an opaque surface first: one any-hit query
        // settles those (and every ray of a scene without transparency); only a ray that met
        // a transparent surface takes the long way.
        let transparency = scene.world.features.transparency;
        match self.accel.any(
            &scene.prims,
            &pre,
            t_max,
            &|_| true,
            self.scratch,
            self.counters,
        ) {
            None => return Vec3::ONE,
            Some(h) if !transparency || opaque(h.prim) => return Vec3::ZERO,
            Some(_) => {}
        }
        if self
            .accel
            .any(
                &scene.prims,
                &pre,
                t_max,
                &opaque,
                self.scratch,
                self.counters,
            )
            .is_some()
        {
            return Vec3::ZERO;
        }
        // Only transparent surfaces lie in the way: attenuate by each crossing.
        let mut filter = Vec3::ONE;
        let mut from = pre;
        let mut remaining = t_max;
        for _ in 0..MAX_SHADOW_CROSSINGS {
            let Some(h) =
                self.accel
                    .closest(&scene.prims, &from, remaining, self.scratch, self.counters)
            else {
                return filter;
            };
            let s = scene.surface(h.prim);
            filter *= s.color * s.kst();
            if filter.max_element() <= 0.0 {
                return Vec3::ZERO;
            }
            let q = from.ray.at(h.t);
            let n = scene.prims[h.prim as usize].normal(q, time);
            let push = if n.dot(l) >= 0.0 { n } else { -n };
            let o = offset_from(q, push, from.ray.origin);
            remaining -= (o - from.ray.origin).dot(l);
            from = RayPre::new(Ray {
                origin: o,
                dir: l,
                time,
            });
        }
        Vec3::ZERO
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
