//! SunRay's single-ray work with no shading (`sunray bench limit SCENE`): one eye ray through
//! each pixel's centre and, from each hit, one shadow ray to each light the surface faces,
//! through the renderer's own accelerator, ray set-up and shadow shortcuts (the offset
//! origin, the flat face a shadow ray leaves, each light's last occluder tried first). It is
//! the work a render cannot avoid, measured beside Embree 3's single-ray kernels doing the
//! same rays (`bench/limit/embree_limit.c`, run side by side by `bench/limit/run.sh`).
//!
//! The camera, the facing test and the offset are the renderer's; Embree's program follows
//! the same conventions, so both count the same eye hits.

use crate::accel::{Accel, AccelOptions, Scratch};
use crate::camera::Camera;
use crate::geometry::{offset_from, Ray, RayPre, Real, Vec3};
use crate::scene::Scene;
use crate::stats::Counters;
use std::time::Instant;

/// What one scene's eye + shadow rays cost: the best times of the repeats and the counts of
/// one (every repeat traces the same rays).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LimitRun {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Primitives in the scene.
    pub primitives: usize,
    /// Seconds to build the accelerator (best of the repeats).
    pub build_s: f64,
    /// Seconds to trace every ray, one thread (best of the repeats).
    pub trace_s: f64,
    /// Eye rays.
    pub eye: u64,
    /// Eye rays that hit something.
    pub eye_hits: u64,
    /// Shadow rays traced.
    pub shadow: u64,
    /// Shadow rays that met an occluder.
    pub shadow_blocked: u64,
    /// Lights behind the surface hit (no ray traced).
    pub shadow_behind: u64,
    /// Ray / primitive intersection tests made.
    pub intersection_tests: u64,
    /// Accelerator nodes visited.
    pub nodes_visited: u64,
}

/// The counts of one pass over the image.
#[derive(Default)]
struct Tally {
    eye_hits: u64,
    shadow: u64,
    blocked: u64,
    behind: u64,
    counters: Counters,
}

/// Builds `scene`'s accelerator and traces its eye and shadow rays at `width x height`,
/// `repeat` times (at least once), one thread.
pub fn run(scene: &Scene, opts: &AccelOptions, width: u32, height: u32, repeat: usize) -> LimitRun {
    let mut best = LimitRun {
        width,
        height,
        primitives: scene.prims.len(),
        build_s: f64::INFINITY,
        trace_s: f64::INFINITY,
        eye: u64::from(width) * u64::from(height),
        eye_hits: 0,
        shadow: 0,
        shadow_blocked: 0,
        shadow_behind: 0,
        intersection_tests: 0,
        nodes_visited: 0,
    };
    for _ in 0..repeat.max(1) {
        let mut prims = scene.prims.clone();
        let t0 = Instant::now();
        let accel = Accel::build(&mut prims, opts);
        best.build_s = best.build_s.min(t0.elapsed().as_secs_f64());
        let scene = Scene::from_parts(scene.world.clone(), prims, scene.objects, Vec::new());
        let t1 = Instant::now();
        let tally = trace(&scene, &accel, width, height);
        best.trace_s = best.trace_s.min(t1.elapsed().as_secs_f64());
        best.eye_hits = tally.eye_hits;
        best.shadow = tally.shadow;
        best.shadow_blocked = tally.blocked;
        best.shadow_behind = tally.behind;
        best.intersection_tests = tally.counters.intersection_tests;
        best.nodes_visited = tally.counters.voxels;
    }
    best
}

/// One pass: every pixel's eye ray, and the shadow rays of its hit. Never inlined, so a
/// profiler can count its instructions alone (`valgrind --tool=callgrind
/// --toggle-collect='*limit::trace*'`) without the scene's loading and build.
#[inline(never)]
fn trace(scene: &Scene, accel: &Accel, width: u32, height: u32) -> Tally {
    let prims = &scene.prims;
    let camera = Camera::new(&scene.world.camera, width, height);
    let mut scratch = Scratch::new(prims.len(), false);
    let mut c = Counters::default();
    let mut tally = Tally::default();
    for j in 0..height {
        for i in 0..width {
            let ray = camera.ray(Real::from(i) + 0.5, Real::from(j) + 0.5, 0.0, None);
            let pre = RayPre::new(ray);
            let Some(hit) = accel.closest(prims, &pre, Real::INFINITY, &mut scratch, &mut c) else {
                continue;
            };
            tally.eye_hits += 1;
            let p = ray.at(hit.t);
            let n = prims.normal(hit.prim, p, 0.0);
            let n = if n.dot(ray.dir) > 0.0 { -n } else { n };
            let face = prims.flat_face(hit.prim);
            for (k, light) in scene.world.lights.iter().enumerate() {
                let to = light.position - p;
                let dist = to.length();
                let l = to / dist;
                if n.dot(l) <= 0.0 {
                    tally.behind += 1;
                    continue;
                }
                tally.shadow += 1;
                let from = ShadowFrom {
                    p,
                    n,
                    eye: ray.origin,
                    face,
                };
                tally.blocked += u64::from(shadow(
                    prims,
                    accel,
                    &mut scratch,
                    &mut c,
                    k,
                    &from,
                    l,
                    dist,
                ));
            }
        }
    }
    tally.counters = c;
    tally
}

/// Where a shadow ray starts: the hit point, the normal facing the eye, the eye (whose
/// distance scales the offset) and the flat face hit, if any.
struct ShadowFrom {
    p: Vec3,
    n: Vec3,
    eye: Vec3,
    face: Option<[u32; 2]>,
}

/// Whether an opaque occluder lies between the point and light `light` at `dist` along `l`,
/// found as the renderer finds it in an opaque scene ([`Accel::occluded`]); the ray skips the
/// flat face it leaves (it leaves on the eye's side).
#[allow(clippy::too_many_arguments)]
fn shadow(
    prims: &crate::geometry::Primitives,
    accel: &Accel,
    scratch: &mut Scratch,
    c: &mut Counters,
    light: usize,
    from: &ShadowFrom,
    l: Vec3,
    dist: Real,
) -> bool {
    let origin = offset_from(from.p, from.n, from.eye);
    let t_max = (from.p + l * dist - origin).dot(l);
    let mut pre = RayPre::new(Ray::new(origin, l));
    if let Some(face) = from.face {
        pre = pre.leaving(face);
    }
    accel.occluded(prims, &pre, t_max, light, scratch, c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;

    /// The counts by brute force: every primitive tested against every ray, no shortcut.
    fn brute_force(scene: &Scene, width: u32, height: u32) -> (u64, u64, u64, u64) {
        let prims = &scene.prims;
        let nearest = |r: &RayPre, t_max: Real| {
            (0..prims.len() as u32)
                .filter_map(|i| prims.intersect(i, r, 0.0, t_max).map(|t| (t, i)))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        };
        let camera = Camera::new(&scene.world.camera, width, height);
        let (mut hits, mut shadow, mut blocked, mut behind) = (0, 0, 0, 0);
        for j in 0..height {
            for i in 0..width {
                let ray = camera.ray(Real::from(i) + 0.5, Real::from(j) + 0.5, 0.0, None);
                let Some((t, prim)) = nearest(&RayPre::new(ray), Real::INFINITY) else {
                    continue;
                };
                hits += 1;
                let p = ray.at(t);
                let n = prims.normal(prim, p, 0.0);
                let n = if n.dot(ray.dir) > 0.0 { -n } else { n };
                for light in &scene.world.lights {
                    let to = light.position - p;
                    let (dist, l) = (to.length(), to / to.length());
                    if n.dot(l) <= 0.0 {
                        behind += 1;
                        continue;
                    }
                    shadow += 1;
                    let origin = offset_from(p, n, ray.origin);
                    let t_max = (p + l * dist - origin).dot(l);
                    blocked +=
                        u64::from(nearest(&RayPre::new(Ray::new(origin, l)), t_max).is_some());
                }
            }
        }
        (hits, shadow, blocked, behind)
    }

    #[test]
    fn eye_and_shadow_rays_are_counted_as_brute_force_counts_them() {
        let world = crate::bench::spd_world(yari::spd::Database::Mount, 2).unwrap();
        let scene = Scene::new(world);
        let (w, h) = (40, 32);
        let want = brute_force(&scene, w, h);
        assert!(want.0 > 100 && want.2 > 10 && want.3 > 0, "{want:?}");
        for kind in [AccelKind::Bvh, AccelKind::Octree] {
            let opts = AccelOptions {
                kind,
                ..AccelOptions::default()
            };
            let run = run(&scene, &opts, w, h, 2);
            let got = (
                run.eye_hits,
                run.shadow,
                run.shadow_blocked,
                run.shadow_behind,
            );
            assert_eq!(got, want, "{}", kind.name());
            assert_eq!(run.eye, u64::from(w * h));
            assert!(run.trace_s > 0.0 && run.build_s >= 0.0);
        }
    }
}
