//! The Hall model's direct terms at a hit: ambient, then per light the diffuse reflection and
//! its highlight (lights in front), or the diffuse transmission and its highlight (lights
//! behind a transmitting surface), each light filtered by its shadow ray ([`super::shadow`]).

use super::hall::{SurfacePoint, Tracer};
use crate::geometry::{Ray, Real, Vec3};
use crate::sampler::{sample_disc, SampleStream};

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

        for (index, light) in world.lights.iter().enumerate() {
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
                let i = light.color * self.light_reaching(at, true, index, lp, l, dist, ray);
                if i == Vec3::ZERO {
                    continue;
                }
                result += colour * i * (surf.kdr * ndl);
                if ksr > 0.0 {
                    result += i * (ksr * reflection_highlight(l, v, nf, surf.phong));
                }
            } else if ndl < 0.0 && kst > 0.0 {
                self.counters.shadow_behind += 1;
                let i = light.color * self.light_reaching(at, false, index, lp, l, dist, ray);
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

    /// The filter of the shadow ray from `at` to the light point `lp` of light number `light`
    /// (direction `l`, distance `dist` from the hit point) on the viewer's side (`front`) or
    /// the far side. On a flat
    /// surface the ray starts at the hit point and leaves along the normal; on a smooth
    /// triangle it starts at the point lifted by the shadow-terminator fix
    /// ([`SurfacePoint::shadow_origin`]), aims at `lp` from there, and leaves along the
    /// geometric normal, so it does not start inside the facet it is on.
    #[allow(clippy::too_many_arguments)]
    fn light_reaching(
        &mut self,
        at: &SurfacePoint,
        front: bool,
        light: usize,
        lp: Vec3,
        l: Vec3,
        dist: Real,
        ray: &Ray,
    ) -> Vec3 {
        let side = if front { at.ng } else { -at.ng };
        if at.smooth.is_none() {
            return self.shadow(at.face.as_ref(), at.p, side, light, l, dist, ray);
        }
        let q = at.shadow_origin(front);
        let to_light = lp - q;
        let d = to_light.length();
        if !(d > 0.0 && d.is_finite()) {
            return self.shadow(at.face.as_ref(), at.p, side, light, l, dist, ray);
        }
        self.shadow(None, q, side, light, to_light / d, d, ray)
    }
}
