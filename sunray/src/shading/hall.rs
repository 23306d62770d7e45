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
use crate::accel::{Accel, Hit, Scratch};
use crate::geometry::smooth::SmoothHit;
use crate::geometry::{Ray, RayPre, Real, Vec3};
use crate::sampler::SampleStream;
use crate::scene::Scene;
use crate::stats::Counters;
use crate::texture;
use yari::model::Surface;

/// Ray-tree limits.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TraceOptions {
    /// Maximum depth of the ray tree; the eye ray is level 1 (SPD rule: 5).
    pub max_depth: u32,
    /// A secondary ray is spawned only if its weight (product of the coefficients along its
    /// path) exceeds this.
    pub min_weight: Real,
    /// Haines's SPD testing procedure (his README, rules 8 and 9), for counting rays: every
    /// ray that hits a reflecting *or transmitting* surface spawns a reflected ray (total
    /// internal reflection included), and every ray is spawned to the depth limit whatever
    /// its weight. A transmitting surface with ksr = 0 reflects nothing in the Hall model, so
    /// its reflected ray has weight 0 and leaves the image as it is; it is traced only to be
    /// counted (`--spd-corners`).
    #[serde(default)]
    pub spawn_all: bool,
}

impl TraceOptions {
    /// The deepest ray tree traced whatever `max_depth` and `min_weight` say: 64 levels (eye
    /// ray = 1). Each level is a few stack frames of the recursive tracer, so two facing
    /// mirrors with `min_weight` 0 (or negative) cannot overflow a render thread's stack.
    /// `render::settings::MAX_DEPTH` refuses deeper settings up front; this is the tracer's
    /// own guard for options built any other way.
    pub const MAX_DEPTH: u32 = 64;

    /// The depth at which no secondary ray is spawned: `max_depth`, at most [`Self::MAX_DEPTH`].
    pub fn depth_limit(&self) -> u32 {
        self.max_depth.min(Self::MAX_DEPTH)
    }
}

impl Default for TraceOptions {
    fn default() -> TraceOptions {
        TraceOptions {
            max_depth: 5,
            min_weight: 0.001,
            spawn_all: false,
        }
    }
}

/// What a traced ray is: which counter it adds to (an eye ray also counts its hit).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayKind {
    /// A primary ray from the camera (its hit counts as an eye hit).
    Eye,
    /// A secondary ray in the mirror direction.
    Reflected,
    /// A secondary ray through a transmitting surface.
    Refracted,
}

/// Traces rays through one scene; holds the per-thread scratch and counters.
pub struct Tracer<'a> {
    /// The scene: primitives, surfaces, lights, textures.
    pub scene: &'a Scene,
    /// The accelerator built over `scene`'s primitives.
    pub accel: &'a Accel,
    /// Depth and weight limits of the ray tree.
    pub opts: TraceOptions,
    /// This thread's mailbox; saves work, never changes a result.
    pub scratch: &'a mut Scratch,
    /// Where this thread counts rays, tests and voxels.
    pub counters: &'a mut Counters,
}

impl<'a> Tracer<'a> {
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
        self.trace_pre(RayPre::new(ray), kind, depth, weight, media, rng)
    }

    /// [`Tracer::trace`] of a prepared ray (a secondary ray may know a face it leaves,
    /// [`RayPre::leaving`]).
    pub(super) fn trace_pre(
        &mut self,
        pre: RayPre,
        kind: RayKind,
        depth: u32,
        weight: Real,
        media: Media,
        rng: &mut SampleStream,
    ) -> Vec3 {
        let hit = self.accel.closest(
            &self.scene.prims,
            &pre,
            Real::INFINITY,
            self.scratch,
            self.counters,
        );
        self.colour_of(&pre.ray, hit, kind, depth, weight, media, rng)
    }

    /// The colours seen along up to [`PACKET`](crate::accel::bvh::packet::PACKET) eye rays (unit directions), the rays of
    /// neighbouring pixels, whose closest hits the accelerator finds together
    /// ([`Accel::closest_packet`]); `rngs[k]` is ray `k`'s stream. Each colour is the one
    /// [`Tracer::trace`] gives that ray alone, and the rays are shaded in order.
    pub fn trace_eye_packet(
        &mut self,
        rays: &[RayPre],
        rngs: &mut [SampleStream],
        colours: &mut [Vec3],
    ) {
        let hits = self.accel.closest_packet(
            &self.scene.prims,
            rays,
            Real::INFINITY,
            self.scratch,
            self.counters,
        );
        let air = Media::AIR;
        for ((pre, hit), (rng, colour)) in rays.iter().zip(hits).zip(rngs.iter_mut().zip(colours)) {
            *colour = self.colour_of(&pre.ray, hit, RayKind::Eye, 1, 1.0, air, rng);
        }
    }

    /// The colour of `ray` of `kind`, whose closest hit is `hit` (counted as a ray of its
    /// kind): the background or what the medium leaves of it on a miss, the hit shaded
    /// otherwise.
    #[allow(clippy::too_many_arguments)]
    fn colour_of(
        &mut self,
        ray: &Ray,
        hit: Option<Hit>,
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
        let colour = self.shade(ray, hit.t, hit.prim, depth, weight, media, rng);
        match medium {
            Some(t) if t < 1.0 => colour * t.max(0.0).powf(hit.t),
            _ => colour,
        }
    }

    /// The colour of the hit at distance `t` along `ray` on primitive `prim_index`: the Hall
    /// model's direct terms ([`Tracer::direct_light`]), then the reflected and refracted rays
    /// ([`Tracer::secondary_rays`]), added in that order.
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
        let at = self.surface_point(ray, t, prim_index, media);
        let result = self.direct_light(&at, ray, rng);
        if depth >= self.opts.depth_limit() {
            return result;
        }
        self.secondary_rays(&at, ray, depth, weight, rng, result)
    }

    /// What shading needs of a hit: the point, its textured colour and normal facing the
    /// viewer, and the transparent volumes on either side of the surface (media tracking).
    fn surface_point(&self, ray: &Ray, t: Real, prim_index: u32, media: Media) -> SurfacePoint<'a> {
        let scene = self.scene;
        let prims = &scene.prims;
        let surf = scene.surface(prim_index);
        let p = ray.at(t);
        let mut n = prims.normal(prim_index, p, ray.time);
        let valid_normal = n != Vec3::ZERO && n.is_finite();
        if !valid_normal {
            n = -ray.dir;
        }
        let entering = ray.dir.dot(n) < 0.0;
        // A smooth triangle is shaded with its interpolated normal (on the side of the
        // geometric one); everything else with the geometric normal.
        let smooth = prims.smooth_hit(prim_index, p, ray.time);
        let geometric = n;
        let face = match smooth {
            None if valid_normal => prims
                .flat_face(prim_index)
                .map(|prims| FlatFace { prims, normal: n }),
            _ => None,
        };
        if let Some(s) = &smooth {
            n = s.normal().unwrap_or(n);
        }
        let mut colour = surf.color;
        if let Some(tex) = &surf.texture {
            // Textures stick to moving objects: look up at the object's rest position.
            let motion = prims.motion(prim_index);
            let (c, tn) = texture::apply(tex, surf.color, p - motion * ray.time, n);
            colour = c;
            n = tn;
        }
        // N faces the viewer; the geometric side decides entering/leaving. On a smooth
        // triangle N is turned with the geometric normal (not by itself), and the geometric
        // normal facing the viewer (`ng`) says where secondary and shadow rays start.
        let (nf, ng, facing) = match smooth {
            None => {
                let nf = if ray.dir.dot(n) < 0.0 { n } else { -n };
                (nf, nf, 1.0)
            }
            Some(_) => {
                let facing = if entering { 1.0 } else { -1.0 };
                (n * facing, geometric * facing, facing)
            }
        };
        let closed = prims.is_closed(prim_index);
        let surface = prims.surface(prim_index);
        // The volumes on the viewer's side and on the far side, and their refractive indices.
        // A thin sheet (an open polygon, a quadric) has air on both sides and bends nothing.
        let own = Medium {
            surface,
            refract: surf.refract,
            transmissivity: surf.transmissivity,
        };
        let (media_view, media_far, n_view, n_far) = match (closed, entering) {
            (true, true) => (media, media.entering(own), media.index(), surf.refract),
            (true, false) => {
                // Leaving: inside this volume, even if the ray was not known to be.
                let view = if media.contains(surface) {
                    media
                } else {
                    media.entering(own)
                };
                let far = view.leaving(surface);
                (view, far, surf.refract, far.index())
            }
            (false, _) => (media, media, 1.0, surf.refract),
        };
        SurfacePoint {
            p,
            nf,
            ng,
            smooth: smooth.map(|s| (s, facing)),
            face,
            v: -ray.dir,
            colour,
            surf,
            closed,
            media_view,
            media_far,
            n_view,
            n_far,
        }
    }
}

/// The flat face a point is on ([`crate::geometry::Primitives::flat_face`]): its primitives and
/// its geometric unit normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlatFace {
    /// Primitive numbers `[first, end)`.
    pub prims: [u32; 2],
    /// The plane's unit normal (either side).
    pub normal: Vec3,
}

impl FlatFace {
    /// Whether a ray that starts at a point of the face, offset along `side`, and goes along
    /// `dir` moves away from the face's plane: the offset and the direction on the same side
    /// of it. `side` must be close to the normal (a bump-mapped normal may not be).
    pub fn left_by(&self, side: Vec3, dir: Vec3) -> bool {
        let (s, d) = (self.normal.dot(side), self.normal.dot(dir));
        (s > 0.5 && d > 0.0) || (s < -0.5 && d < 0.0)
    }
}

/// A hit as shading sees it.
pub(super) struct SurfacePoint<'a> {
    /// The point.
    pub p: Vec3,
    /// The (textured, on a smooth triangle interpolated) normal, facing the viewer.
    pub nf: Vec3,
    /// The normal that says which side is which: where secondary and shadow rays start and
    /// which side they must leave into. `nf` itself, except on a smooth triangle, where it
    /// is the geometric normal facing the viewer.
    pub ng: Vec3,
    /// On a smooth triangle, the hit on it and the side of its normals the viewer is on
    /// (+1 or -1), for the shadow rays' origins ([`SurfacePoint::shadow_origin`]).
    pub smooth: Option<(SmoothHit, Real)>,
    /// The flat face the point is on, if it is on one (not on a smooth triangle): shadow
    /// rays that leave it skip its primitives ([`crate::geometry::RayPre::leaving`]).
    pub face: Option<FlatFace>,
    /// Towards the viewer.
    pub v: Vec3,
    /// The surface colour there (textured).
    pub colour: Vec3,
    /// The surface's attributes.
    pub surf: &'a Surface,
    /// A closed volume's surface (bends rays) rather than a thin sheet.
    pub closed: bool,
    /// The volumes on the viewer's side.
    pub media_view: Media,
    /// The volumes on the far side.
    pub media_far: Media,
    /// Refractive index on the viewer's side.
    pub n_view: Real,
    /// Refractive index on the far side.
    pub n_far: Real,
}

impl SurfacePoint<'_> {
    /// Where a shadow ray towards the viewer's side (`front`) or the far side starts before
    /// its offset: the hit point, or on a smooth triangle the hit point lifted by Hanika's
    /// shadow-terminator fix ([`SmoothHit::shadow_origin`]).
    pub fn shadow_origin(&self, front: bool) -> Vec3 {
        match &self.smooth {
            None => self.p,
            Some((hit, facing)) => {
                let side = if front { *facing } else { -*facing };
                hit.shadow_origin(self.p, side)
            }
        }
    }
}
