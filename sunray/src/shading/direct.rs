//! The Hall model's direct terms at a hit: ambient, then per light the diffuse reflection and
//! its highlight (lights in front), or the diffuse transmission and its highlight (lights
//! behind a transmitting surface), each light filtered by its shadow ray.

use super::hall::{SurfacePoint, Tracer};
use crate::geometry::{offset_from, Ray, RayPre, Real, Vec3};
use crate::sampler::{sample_disc, SampleStream};

/// Maximum transparent surfaces a shadow ray passes through before it is treated as blocked.
const MAX_SHADOW_CROSSINGS: usize = 64;

/// The reflection highlight (Phong's on the halfway vector): (N.H)^phong, H between L and V.
fn reflection_highlight(l: Vec3, v: Vec3, nf: Vec3, phong: Real) -> Real {
    let h = (l + v).normalize_or_zero();
    h.dot(nf).max(0.0).powf(phong)
}

/// The transmission highlight (Hall's): (N'.H')^phong, H' the normal that would refract L
/// into V between indices `n_view` and `n_far`.
fn transmission_highlight(
    l: Vec3,
    v: Vec3,
    nf: Vec3,
    n_view: Real,
    n_far: Real,
    phong: Real,
) -> Real {
    let h = -(l * n_far + v * n_view);
    let cos = match h.try_normalize() {
        Some(h) => h.dot(-nf).abs(),
        None => 1.0,
    };
    cos.powf(phong)
}

impl Tracer<'_> {
    /// Ambient plus every light's diffuse and highlight terms at `at`.
    pub(super) fn direct_light(
        &mut self,
        at: &SurfacePoint,
        ray: &Ray,
        rng: &mut SampleStream,
    ) -> Vec3 {
        let world = &self.scene.world;
        let (p, nf, v, colour, surf) = (at.p, at.nf, at.v, at.colour, at.surf);
        let (ksr, kst) = (surf.ksr(), surf.kst());
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
                let i = light.color * self.light_reaching(at, true, lp, l, dist, ray);
                if i == Vec3::ZERO {
                    continue;
                }
                result += colour * i * (surf.kdr * ndl);
                if ksr > 0.0 {
                    result += i * (ksr * reflection_highlight(l, v, nf, surf.phong));
                }
            } else if ndl < 0.0 && kst > 0.0 {
                self.counters.shadow_behind += 1;
                let i = light.color * self.light_reaching(at, false, lp, l, dist, ray);
                if i == Vec3::ZERO {
                    continue;
                }
                result += colour * i * (surf.kdt * -ndl);
                let highlight = transmission_highlight(l, v, nf, at.n_view, at.n_far, surf.phong);
                result += i * (kst * highlight);
            }
        }
        result
    }

    /// The filter of the shadow ray from `at` to the light point `lp` (direction `l`, distance
    /// `dist` from the hit point) on the viewer's side (`front`) or the far side. On a flat
    /// surface the ray starts at the hit point and leaves along the normal; on a smooth
    /// triangle it starts at the point lifted by the shadow-terminator fix
    /// ([`SurfacePoint::shadow_origin`]), aims at `lp` from there, and leaves along the
    /// geometric normal, so it does not start inside the facet it is on.
    #[allow(clippy::too_many_arguments)]
    fn light_reaching(
        &mut self,
        at: &SurfacePoint,
        front: bool,
        lp: Vec3,
        l: Vec3,
        dist: Real,
        ray: &Ray,
    ) -> Vec3 {
        let side = if front { at.ng } else { -at.ng };
        if at.smooth.is_none() {
            return self.shadow(at.p, side, l, dist, ray);
        }
        let q = at.shadow_origin(front);
        let to_light = lp - q;
        let d = to_light.length();
        if !(d > 0.0 && d.is_finite()) {
            return self.shadow(at.p, side, l, dist, ray);
        }
        self.shadow(q, side, to_light / d, d, ray)
    }

    /// The filter a shadow ray from `p` (leaving on the side of `side`) towards a light at
    /// distance `dist` in direction `l` receives: 1 if unblocked, 0 if an opaque surface is in
    /// the way, and the product of `kst * colour` of every transparent surface crossed.
    /// `ray` is the ray that found `p` (its origin scales the offset, its time is the shadow
    /// ray's).
    pub(super) fn shadow(&mut self, p: Vec3, side: Vec3, l: Vec3, dist: Real, ray: &Ray) -> Vec3 {
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
            let n = scene.prims.normal(h.prim, q, time);
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
