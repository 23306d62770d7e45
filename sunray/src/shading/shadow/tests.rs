//! The one-walk shadow ray against the loop it replaced (one any-hit walk, one walk for an
//! opaque surface, then one closest-hit walk per transparent crossing, each from just past
//! the last crossing), on glass slabs and glass spheres with every accelerator.

use super::super::tests::{square, white_light, world, Fixture};
use super::FlatFace;
use crate::accel::{Accel, AccelKind, AccelOptions, Scratch};
use crate::geometry::{offset_from, Ray, RayPre, Real, Vec3};
use crate::sampler::SampleStream;
use crate::scene::Scene;
use crate::shading::{TraceOptions, Tracer};
use crate::stats::Counters;
use yari::model::{Shape, Surface};

/// The loop the one walk replaced (crossings capped at 64), as it was.
fn shadow_by_crossings(
    t: &mut Tracer,
    p: Vec3,
    side: Vec3,
    l: Vec3,
    dist: Real,
    ray: &Ray,
) -> Vec3 {
    let origin = offset_from(p, side, ray.origin);
    let t_max = (p + l * dist - origin).dot(l);
    let pre = RayPre::new(Ray::new(origin, l));
    let scene = t.scene;
    let opaque = |i: u32, _: Real| scene.surface(i).kst() <= 0.0;
    match t.accel.any(
        &scene.prims,
        &pre,
        t_max,
        &|_, _| true,
        t.scratch,
        t.counters,
    ) {
        None => return Vec3::ONE,
        Some(h) if opaque(h.prim, h.t) => return Vec3::ZERO,
        Some(_) => {}
    }
    if t.accel
        .any(&scene.prims, &pre, t_max, &opaque, t.scratch, t.counters)
        .is_some()
    {
        return Vec3::ZERO;
    }
    let mut filter = Vec3::ONE;
    let mut from = pre;
    let mut remaining = t_max;
    for _ in 0..64 {
        let Some(h) = t
            .accel
            .closest(&scene.prims, &from, remaining, t.scratch, t.counters)
        else {
            return filter;
        };
        let s = scene.surface(h.prim);
        filter *= s.color * s.kst();
        let q = from.ray.at(h.t);
        let n = scene.prims.normal(h.prim, q, 0.0);
        let push = if n.dot(l) >= 0.0 { n } else { -n };
        let o = offset_from(q, push, from.ray.origin);
        remaining -= (o - from.ray.origin).dot(l);
        from = RayPre::new(Ray::new(o, l));
    }
    Vec3::ZERO
}

fn glass(color: Vec3, kdt: f64) -> Surface {
    Surface {
        color,
        kdr: 1.0,
        kdt,
        refract: 1.0,
        ..Surface::default()
    }
}

/// Five glass slabs, three glass spheres (one inside a slab's span), one small opaque sphere.
fn glass_world() -> yari::model::World {
    world(
        glass_objects(),
        vec![white_light(Vec3::new(0.0, 0.0, 10.0))],
    )
}

/// The objects of [`glass_world`].
fn glass_objects() -> Vec<(Shape, Surface)> {
    let mut objects = Vec::new();
    for k in 0..5 {
        let tint = Vec3::new(1.0, 0.9 - 0.1 * k as f64, 0.8);
        objects.push((
            square(1.0 + k as f64 * 0.7),
            glass(tint, 0.3 + 0.1 * k as f64),
        ));
    }
    for (k, c) in [
        Vec3::new(0.3, 0.2, 2.2),
        Vec3::new(-0.4, 0.1, 3.6),
        Vec3::new(0.0, -0.5, 0.4),
    ]
    .into_iter()
    .enumerate()
    {
        objects.push((
            Shape::Sphere {
                center: c,
                radius: 0.25 + 0.1 * k as f64,
            },
            glass(Vec3::new(0.7, 1.0, 0.9), 0.2),
        ));
    }
    objects.push((
        Shape::Sphere {
            center: Vec3::new(0.6, 0.6, 4.5),
            radius: 0.4,
        },
        Surface::default(),
    ));
    objects
}

/// The accelerator of `kind` over `scene`, octree leaves of at most two primitives (so rays
/// cross many voxels).
fn build(scene: &mut Scene, kind: AccelKind) -> Accel {
    let opts = AccelOptions {
        kind,
        max_per_voxel: 2,
        ..AccelOptions::default()
    };
    Accel::build(&mut scene.prims, &opts)
}

/// Every accelerator, and the octree with and without the mailbox.
fn setups() -> Vec<(AccelKind, bool)> {
    vec![
        (AccelKind::Bvh, true),
        (AccelKind::Octree, true),
        (AccelKind::Octree, false),
        (AccelKind::Exhaustive, true),
    ]
}

#[test]
fn one_walk_filters_as_the_crossing_loop_did_with_fewer_tests() {
    let mut scene = Scene::new(glass_world());
    for (kind, mailbox) in setups() {
        let accel = build(&mut scene, kind);
        let mut scratch = Scratch::new(scene.prims.len(), mailbox);
        let (mut new_c, mut old_c) = (Counters::default(), Counters::default());
        let mut rng = SampleStream::new(7, 3, 0);
        let (mut filtered, mut blocked, mut clear) = (0, 0, 0);
        for _ in 0..2000 {
            let (a, b) = rng.next_2d();
            let p = Vec3::new(a * 2.4 - 1.2, b * 2.4 - 1.2, -0.5);
            let (c, d) = rng.next_2d();
            let light = Vec3::new(c * 4.0 - 2.0, d * 4.0 - 2.0, 9.0);
            let (l, dist) = ((light - p).normalize(), (light - p).length());
            let mut tracer = Tracer {
                scene: &scene,
                accel: &accel,
                opts: TraceOptions::default(),
                scratch: &mut scratch,
                counters: &mut new_c,
            };
            let ray = Ray::new(p + Vec3::new(0.0, 0.0, -1.0), Vec3::Z);
            let new = tracer.shadow(None, p, Vec3::Z, 0, l, dist, &ray);
            tracer.counters = &mut old_c;
            let old = shadow_by_crossings(&mut tracer, p, Vec3::Z, l, dist, &ray);
            assert!(
                (new - old).abs().max_element() <= 1e-12 * old.max_element().max(1.0),
                "{kind:?}, mailbox {mailbox}: from {p} to {light}: {new} != {old}"
            );
            let most = new.max_element();
            if most == 0.0 {
                blocked += 1;
            } else if most == 1.0 {
                clear += 1;
            } else {
                filtered += 1;
            }
        }
        // The rays cover every case, and the walk does less work.
        assert!(
            filtered > 500 && blocked > 20 && clear > 20,
            "{filtered} {blocked} {clear}"
        );
        eprintln!(
            "{kind:?}, mailbox {mailbox}: {} tests, the loop {}",
            new_c.intersection_tests, old_c.intersection_tests
        );
        assert!(
            new_c.intersection_tests < old_c.intersection_tests,
            "{kind:?}: {} tests, the loop {}",
            new_c.intersection_tests,
            old_c.intersection_tests
        );
    }
}

/// Shadow rays from a sweep of points (neighbours, as a scanline makes them) towards three
/// lights, past glass and opaque spheres: with the occluder cache kept between rays, each
/// gives exactly what it gives with an empty cache, and many are answered by one test. A
/// dark glass slab and a dark glass sphere end some walks by leaving too little light; the
/// cache must not take either for an opaque occluder.
#[test]
fn the_last_occluder_never_changes_a_shadow() {
    let mut objects = glass_objects();
    for (k, c) in [(0.2, 0.3), (-0.6, -0.2), (0.5, -0.7)]
        .into_iter()
        .enumerate()
    {
        let centre = Vec3::new(c.0, c.1, 1.2 + k as f64);
        objects.push((
            Shape::Sphere {
                center: centre,
                radius: 0.3,
            },
            Surface::default(),
        ));
    }
    objects.push((square(5.5), glass(Vec3::splat(1e-4), 0.0)));
    let dark = Shape::Sphere {
        center: Vec3::new(-0.3, 0.4, 6.5),
        radius: 0.5,
    };
    objects.push((dark, glass(Vec3::splat(0.01), 0.0)));
    let lights = [
        Vec3::new(0.0, 0.0, 10.0),
        Vec3::new(3.0, -2.0, 8.0),
        Vec3::new(-4.0, 1.0, 9.0),
    ];
    let mut scene = Scene::new(world(objects, lights.map(white_light).to_vec()));
    for (kind, mailbox) in setups() {
        let accel = build(&mut scene, kind);
        let mut kept = Scratch::new(scene.prims.len(), mailbox);
        let (mut c, mut answered_by_cache) = (Counters::default(), 0);
        for step in 0..3000 {
            let (a, b) = (
                (step % 60) as f64 / 25.0 - 1.2,
                (step / 60) as f64 / 21.0 - 1.2,
            );
            let p = Vec3::new(a, b, -0.5);
            let index = step % 3;
            let (l, dist) = (
                (lights[index] - p).normalize(),
                (lights[index] - p).length(),
            );
            let ray = Ray::new(p + Vec3::new(0.0, 0.0, -1.0), Vec3::Z);
            let shadow = |scratch: &mut Scratch, counters: &mut Counters| {
                Tracer {
                    scene: &scene,
                    accel: &accel,
                    opts: TraceOptions::default(),
                    scratch,
                    counters,
                }
                .shadow(None, p, Vec3::Z, index, l, dist, &ray)
            };
            let fresh = &mut Scratch::new(scene.prims.len(), mailbox);
            let want = shadow(fresh, &mut Counters::default());
            let before = c.intersection_tests;
            let got = shadow(&mut kept, &mut c);
            assert_eq!(got, want, "{kind:?}: from {p} to light {index}");
            if c.intersection_tests == before + 1 && got == Vec3::ZERO {
                answered_by_cache += 1;
            }
        }
        assert!(answered_by_cache > 100, "{kind:?}: {answered_by_cache}");
    }
}

#[test]
fn a_glass_sphere_filters_twice_and_once_from_inside() {
    let kdt = 0.4;
    let color = Vec3::new(1.0, 0.5, 0.25);
    let w = world(
        vec![(
            Shape::Sphere {
                center: Vec3::new(0.0, 0.0, 3.0),
                radius: 1.0,
            },
            glass(color, kdt),
        )],
        vec![white_light(Vec3::new(0.0, 0.0, 10.0))],
    );
    let mut fixture = Fixture::new(w);
    let mut tracer = fixture.tracer(TraceOptions::default());
    let once = color * (1.0 - kdt);
    let up = Ray::new(Vec3::new(0.0, 0.0, -1.0), Vec3::Z);
    // From below the sphere: in and out.
    let f = tracer.shadow(None, Vec3::ZERO, Vec3::Z, 0, Vec3::Z, 10.0, &up);
    assert!((f - once * once).abs().max_element() < 1e-12, "{f}");
    // From its centre: out only.
    let f = tracer.shadow(
        None,
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::Z,
        0,
        Vec3::Z,
        7.0,
        &up,
    );
    assert!((f - once).abs().max_element() < 1e-12, "{f}");
}

#[test]
fn a_stack_of_dark_glass_is_blocked_once_the_light_left_is_negligible() {
    // 30 slabs each passing 0.5: 0.5^30 < 1e-6, so the walk stops (and reports darkness)
    // before it meets them all.
    let objects = (0..30)
        .map(|k| (square(1.0 + k as f64 * 0.2), glass(Vec3::ONE, 0.5)))
        .collect();
    let mut fixture = Fixture::new(world(objects, vec![white_light(Vec3::new(0.0, 0.0, 10.0))]));
    let mut tracer = fixture.tracer(TraceOptions::default());
    let up = Ray::new(Vec3::new(0.0, 0.0, -1.0), Vec3::Z);
    assert_eq!(
        tracer.shadow(None, Vec3::ZERO, Vec3::Z, 0, Vec3::Z, 10.0, &up),
        Vec3::ZERO
    );
    // The ten above z = 4.9 pass 0.5^10.
    let f = tracer.shadow(
        None,
        Vec3::new(0.0, 0.0, 4.9),
        Vec3::Z,
        0,
        Vec3::Z,
        5.1,
        &up,
    );
    assert!(
        (f - Vec3::splat(0.5f64.powi(10))).abs().max_element() < 1e-15,
        "{f}"
    );
}

/// Shadow rays leaving a flat face skip its triangles ([`FlatFace`]) and get exactly the
/// shadow they got testing them, from a square floor under a sphere. A quad folded into a
/// valley is no flat face: its triangles shadow each other (and themselves, shaded with the
/// quad's normal), and skipping the quad would light points that are in its shadow.
#[test]
fn leaving_a_flat_face_changes_no_shadow() {
    let valley = Shape::Polygon {
        vertices: vec![
            Vec3::new(2.0, -1.0, 0.0),
            Vec3::new(4.0, -1.0, 0.0),
            Vec3::new(4.0, 1.0, 0.0),
            Vec3::new(2.0, 1.0, 2.0),
        ],
    };
    let ball = Shape::Sphere {
        center: Vec3::new(0.2, -0.1, 0.8),
        radius: 0.4,
    };
    let objects = vec![
        (square(0.0), Surface::default()),
        (valley, Surface::default()),
        (ball, Surface::default()),
    ];
    let mut scene = Scene::new(world(objects, vec![white_light(Vec3::Z)]));
    let prims = [0u32, 1, 2, 3].map(|i| (i, scene.prims.get(i)));
    let corners = |p: &crate::geometry::Primitive| match p.kind {
        crate::geometry::PrimitiveKind::Triangle { v, .. } => v,
        _ => unreachable!("the floor and the valley are triangles"),
    };
    assert_eq!(scene.prims.flat_face(0), Some([0, 2]));
    assert_eq!(scene.prims.flat_face(2), None, "the valley is not flat");
    for (kind, mailbox) in setups() {
        let accel = build(&mut scene, kind);
        let mut scratch = Scratch::new(scene.prims.len(), mailbox);
        let mut rng = SampleStream::new(11, 5, 0);
        let (mut floor_shaded, mut valley_shaded) = (0, 0);
        for _ in 0..4000 {
            let (i, prim) = &prims[(rng.next_2d().0 * 4.0) as usize % 4];
            let v = corners(prim);
            let (mut a, mut b) = rng.next_2d();
            if a + b > 1.0 {
                (a, b) = (1.0 - a, 1.0 - b);
            }
            let p = v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b;
            let (c, d) = rng.next_2d();
            let (azimuth, height) = (c * std::f64::consts::TAU, 0.1 + d * 4.0);
            let light = Vec3::new(3.0 + azimuth.cos() * 4.0, azimuth.sin() * 4.0, height);
            let (l, dist) = ((light - p).normalize(), (light - p).length());
            let n = scene.prims.normal(*i, p, 0.0);
            let side = if n.dot(l) > 0.0 { n } else { -n };
            let face = scene
                .prims
                .flat_face(*i)
                .map(|prims| FlatFace { prims, normal: n });
            let ray = Ray::new(p + side, -side);
            let mut tracer = Tracer {
                scene: &scene,
                accel: &accel,
                opts: TraceOptions::default(),
                scratch: &mut scratch,
                counters: &mut Counters::default(),
            };
            let tested = tracer.shadow(None, p, side, 0, l, dist, &ray);
            let skipped = tracer.shadow(face.as_ref(), p, side, 0, l, dist, &ray);
            assert_eq!(skipped, tested, "{kind:?}: from {p} on {i} to {light}");
            if tested == Vec3::ZERO {
                if *i < 2 {
                    floor_shaded += 1;
                } else if scene
                    .prims
                    .intersect(4, &RayPre::new(Ray::new(p, l)), 0.0, dist)
                    .is_none()
                {
                    valley_shaded += 1;
                    // Not the ball: only the valley's other triangle is in the way, and
                    // skipping the whole quad would light the point.
                    let whole = FlatFace {
                        prims: [2, 4],
                        normal: n,
                    };
                    let wrong = tracer.shadow(Some(&whole), p, side, 0, l, dist, &ray);
                    assert_eq!(wrong, Vec3::ONE, "{kind:?}: from {p} on {i} to {light}");
                }
            }
        }
        assert!(
            floor_shaded > 20 && valley_shaded > 20,
            "{kind:?}: {floor_shaded} {valley_shaded}"
        );
    }
}

/// A ray leaves a face when it starts on one side of the plane (the offset along `side`)
/// and moves further to that side: reflected and shadow rays on the viewer's side, refracted
/// rays on the far side; not a ray going back through the plane, nor one offset along a
/// normal far from the face's (a bump-mapped one).
#[test]
fn a_ray_leaves_a_face_when_offset_and_direction_agree() {
    let face = FlatFace {
        prims: [0, 2],
        normal: Vec3::Z,
    };
    let up = Vec3::new(0.3, 0.1, 0.2).normalize();
    assert!(face.left_by(Vec3::Z, up));
    assert!(face.left_by(-Vec3::Z, -up), "the far side");
    assert!(!face.left_by(Vec3::Z, -up), "back through the plane");
    assert!(!face.left_by(-Vec3::Z, up));
    assert!(!face.left_by(Vec3::Z, Vec3::X), "along the plane");
    let bumped = Vec3::new(1.0, 0.0, 0.5).normalize();
    assert!(!face.left_by(bumped, up), "offset mostly along the plane");
    let flipped = FlatFace {
        normal: -Vec3::Z,
        ..face
    };
    assert!(flipped.left_by(Vec3::Z, up), "either normal of the plane");
}
