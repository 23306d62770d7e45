//! The Hall terms against hand-computed values, on one-object scenes built in code.

use super::hall::RayKind;
use super::{TraceOptions, Tracer};
use crate::accel::{Accel, AccelOptions, Scratch};
use crate::geometry::{Ray, Vec3};
use crate::sampler::SampleStream;
use crate::scene::Scene;
use crate::stats::Counters;
use yari::model::{Camera, Light, Object, Shape, Surface, World};

pub(super) fn world(objects: Vec<(Shape, Surface)>, lights: Vec<Light>) -> World {
    let mut w = World {
        resolution: [8, 8],
        background: Vec3::new(0.2, 0.4, 0.6),
        ambient: Vec3::splat(0.5),
        camera: Camera {
            position: Vec3::new(0.0, 0.0, 5.0),
            at: Vec3::ZERO,
            up: Vec3::Y,
            half_angle_deg: 20.0,
            aperture: 0.0,
            focus_distance: 1.0,
        },
        lights,
        samples: 1,
        target_error: None,
        surfaces: vec![],
        objects: vec![],
        features: Default::default(),
    };
    for (shape, surface) in objects {
        w.features.transparency |= surface.kdt < 1.0;
        w.features.reflection |= surface.kdr < 1.0;
        w.objects.push(Object {
            shape,
            surface: w.surfaces.len() as u32,
            motion: Vec3::ZERO,
        });
        w.surfaces.push(surface);
    }
    w
}

/// A scene built from a world, its default accelerator and one thread's scratch and counters:
/// what a [`Tracer`] borrows.
pub(super) struct Fixture {
    scene: Scene,
    accel: Accel,
    scratch: Scratch,
    pub counters: Counters,
}

impl Fixture {
    pub(super) fn new(w: World) -> Fixture {
        let mut scene = Scene::new(w);
        let accel = Accel::build(&mut scene.prims, &AccelOptions::default());
        let scratch = Scratch::new(scene.prims.len(), true);
        Fixture {
            scene,
            accel,
            scratch,
            counters: Counters::default(),
        }
    }

    pub(super) fn tracer(&mut self, opts: TraceOptions) -> Tracer<'_> {
        Tracer {
            scene: &self.scene,
            accel: &self.accel,
            opts,
            scratch: &mut self.scratch,
            counters: &mut self.counters,
        }
    }

    /// The colour an eye ray from `from` towards `dir` (in air) sees with `opts`; what it
    /// took is added to the counters.
    pub(super) fn eye(&mut self, opts: TraceOptions, from: Vec3, dir: Vec3) -> Vec3 {
        self.tracer(opts).trace(
            Ray::new(from, dir),
            RayKind::Eye,
            1,
            1.0,
            crate::shading::Media::AIR,
            &mut SampleStream::new(0, 0, 0),
        )
    }
}

/// Traces one ray from (0, 0, 5) towards -z; returns the colour and the counters.
pub(super) fn trace(w: World, opts: TraceOptions) -> (Vec3, Counters) {
    let mut f = Fixture::new(w);
    let c = f.eye(opts, Vec3::new(0.0, 0.0, 5.0), -Vec3::Z);
    (c, f.counters)
}

fn close(a: Vec3, b: Vec3) {
    assert!((a - b).abs().max_element() < 1e-9, "{a} != {b}");
}

pub(super) fn square(z: f64) -> Shape {
    Shape::Polygon {
        vertices: vec![
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        ],
    }
}

pub(super) fn white_light(at: Vec3) -> Light {
    Light {
        position: at,
        color: Vec3::ONE,
        radius: 0.0,
    }
}

#[test]
fn ambient_diffuse_and_highlight_head_on() {
    // Light at the eye: N = L = V = H, so N.L = N.H = 1.
    let s = Surface {
        color: Vec3::new(1.0, 0.5, 0.25),
        kdr: 0.7,
        ka: 0.2,
        phong: 10.0,
        ..Surface::default()
    };
    let light = Light {
        position: Vec3::new(0.0, 0.0, 5.0),
        color: Vec3::new(1.0, 0.8, 0.6),
        radius: 0.0,
    };
    let opts = TraceOptions {
        max_depth: 1,
        min_weight: 0.0,
        spawn_all: false,
    };
    let (c, n) = trace(
        world(
            vec![(
                Shape::Sphere {
                    center: Vec3::ZERO,
                    radius: 1.0,
                },
                s.clone(),
            )],
            vec![light.clone()],
        ),
        opts,
    );
    let expect = Vec3::splat(0.5) * s.color * 0.2 + s.color * light.color * 0.7 + light.color * 0.3;
    close(c, expect);
    assert_eq!((n.eye, n.eye_hits, n.shadow, n.reflected), (1, 1, 1, 0));
}

#[test]
fn diffuse_follows_the_cosine_and_highlight_the_half_vector() {
    // Light at 60 degrees from the normal in the x-z plane, far away.
    let s = Surface {
        color: Vec3::ONE,
        kdr: 0.5,
        ka: 0.0,
        phong: 3.0,
        ..Surface::default()
    };
    let dir = Vec3::new(60f64.to_radians().sin(), 0.0, 60f64.to_radians().cos());
    let light = white_light(Vec3::new(0.0, 0.0, 0.0) + dir * 1e7);
    let (c, _) = trace(
        world(vec![(square(0.0), s)], vec![light]),
        TraceOptions {
            max_depth: 1,
            min_weight: 0.0,
            spawn_all: false,
        },
    );
    let h = (dir + Vec3::Z).normalize();
    let expect = 0.5 * 0.5 + 0.5 * h.z.powi(3);
    close(c, Vec3::splat(expect));
}

#[test]
fn opaque_mirror_reflects_with_weight_ksr() {
    let s = Surface {
        color: Vec3::ONE,
        kdr: 0.25,
        ka: 0.0,
        ..Surface::default()
    };
    let (c, n) = trace(
        world(vec![(square(0.0), s)], vec![]),
        TraceOptions::default(),
    );
    // The reflected ray goes back past the eye into the background.
    close(c, Vec3::new(0.2, 0.4, 0.6) * 0.75);
    assert_eq!(n.reflected, 1);
    assert_eq!(n.refracted, 0);
}

#[test]
fn fresnel_splits_reflection_and_transmission() {
    // A thin transparent sheet (no bending): ksr = 0.5, kst = 1, refract 1.5 -> F = 0.04.
    let s = Surface {
        color: Vec3::ONE,
        kdr: 0.5,
        kdt: 0.0,
        ka: 0.0,
        refract: 1.5,
        ..Surface::default()
    };
    let (c, n) = trace(
        world(vec![(square(0.0), s)], vec![]),
        TraceOptions {
            max_depth: 5,
            min_weight: 0.0,
            spawn_all: false,
        },
    );
    let bg = Vec3::new(0.2, 0.4, 0.6);
    close(c, bg * (0.5 * 0.04) + bg * 0.96);
    assert_eq!((n.reflected, n.refracted), (1, 1));
}

#[test]
fn haines_procedure_spawns_a_transmitters_reflection_to_count_it() {
    // Gears' glass: ksr = 0 (NFF Ks 0), kst = 0.8, refract 1.1. The Hall model reflects
    // nothing there; Haines's procedure spawns the reflected ray anyway (weight 0), and under
    // it the rays below a weight-0 ray too. The colour stays the same.
    let s = Surface {
        color: Vec3::ONE,
        kdr: 1.0,
        kdt: 0.2,
        ka: 0.0,
        refract: 1.1,
        ..Surface::default()
    };
    let mirror_behind = Surface {
        color: Vec3::ONE,
        kdr: 0.0,
        ka: 0.0,
        ..Surface::default()
    };
    let scene = || {
        world(
            vec![
                (square(0.0), s.clone()),
                (square(-1.0), mirror_behind.clone()),
            ],
            vec![],
        )
    };
    let opts = |spawn_all| TraceOptions {
        max_depth: 5,
        min_weight: 0.0,
        spawn_all,
    };
    let (hall, n) = trace(scene(), opts(false));
    // Eye ray refracts through the sheet, the mirror reflects it back up through the sheet.
    assert_eq!((n.reflected, n.refracted), (1, 2), "{n:?}");
    let (haines, m) = trace(scene(), opts(true));
    assert_eq!(hall, haines, "weight-0 rays change nothing");
    // The sheet's hits now spawn reflected rays too: off its top (depth 2, to the
    // background) and off its underside (depth 4, weight 0, down to the mirror, whose
    // reflection, depth 5, meets the sheet at the depth limit).
    assert_eq!((m.reflected, m.refracted), (4, 2), "{m:?}");
}

#[test]
fn transmissivity_attenuates_per_unit_length() {
    // A clear sphere of radius 1 with refract 1 (no Fresnel, no bending): the eye ray crosses
    // 2 units inside, so the background is seen through 0.5^2.
    let s = Surface {
        kdr: 1.0,
        kdt: 0.0,
        ka: 0.0,
        refract: 1.0,
        transmissivity: 0.5,
        ..Surface::default()
    };
    let (c, n) = trace(
        world(
            vec![(
                Shape::Sphere {
                    center: Vec3::ZERO,
                    radius: 1.0,
                },
                s,
            )],
            vec![],
        ),
        TraceOptions {
            max_depth: 5,
            min_weight: 0.0,
            spawn_all: false,
        },
    );
    close(c, Vec3::new(0.2, 0.4, 0.6) * 0.25);
    assert_eq!(n.refracted, 2);
}

#[test]
fn diffuse_and_specular_transmission_from_a_light_behind() {
    // Light straight behind a thin sheet: N'.L = 1, and with refract 1 H' is undefined (the
    // peak), so the transmission highlight is kst * I.
    let s = Surface {
        color: Vec3::new(1.0, 0.0, 0.0),
        kdr: 1.0,
        kdt: 0.5,
        ka: 0.0,
        refract: 1.0,
        phong: 5.0,
        ..Surface::default()
    };
    let (c, n) = trace(
        world(
            vec![(square(0.0), s)],
            vec![white_light(Vec3::new(0.0, 0.0, -10.0))],
        ),
        TraceOptions {
            max_depth: 5,
            min_weight: 0.0,
            spawn_all: false,
        },
    );
    let bg = Vec3::new(0.2, 0.4, 0.6);
    close(c, Vec3::new(0.5, 0.0, 0.0) + Vec3::splat(0.5) + bg * 0.5);
    assert_eq!((n.shadow, n.shadow_behind), (1, 1));
}

#[test]
fn shadows_block_and_transparent_occluders_filter() {
    let floor = Surface {
        color: Vec3::ONE,
        kdr: 1.0,
        ka: 0.0,
        ..Surface::default()
    };
    let blocker = |kdt: f64| Surface {
        color: Vec3::new(1.0, 0.5, 0.0),
        kdr: 1.0,
        kdt,
        ka: 0.0,
        refract: 1.0,
        ..Surface::default()
    };
    let light = white_light(Vec3::new(0.0, 0.0, 10.0));
    let opts = TraceOptions {
        max_depth: 1,
        min_weight: 0.0,
        spawn_all: false,
    };
    // Opaque blocker off the eye ray (a small square at z = 2 between floor and light would
    // also block the eye ray, so the eye looks from the side instead).
    let occluder = |z: f64| Shape::Polygon {
        vertices: vec![
            Vec3::new(-0.5, -0.5, z),
            Vec3::new(0.5, -0.5, z),
            Vec3::new(0.5, 0.5, z),
            Vec3::new(-0.5, 0.5, z),
        ],
    };
    let scene = |kdt: f64| {
        let mut w = world(
            vec![(square(0.0), floor.clone()), (occluder(8.0), blocker(kdt))],
            vec![light.clone()],
        );
        w.camera.position = Vec3::new(3.0, 0.0, 5.0);
        w
    };
    let shade = |w: World| {
        let from = Vec3::new(3.0, 0.0, 5.0);
        Fixture::new(w).eye(opts, from, (Vec3::ZERO - from).normalize())
    };
    close(shade(scene(1.0)), Vec3::ZERO);
    // kst = 0.6: the light arrives filtered by 0.6 * (1, 0.5, 0).
    close(shade(scene(0.4)), Vec3::new(0.6, 0.3, 0.0));
}
