//! Every accelerator against exhaustive search on random scenes and random rays.

use super::*;
use crate::geometry::{Ray, Vec3};
use crate::sampler::splitmix64;
use yari::model::{Camera, HalfSpace, Object, Quadric, Shape, Surface, World};

fn rand(state: &mut u64) -> f64 {
    (splitmix64(state) >> 11) as f64 / (1u64 << 53) as f64
}

fn random_world(n: usize, seed: u64) -> World {
    let mut s = seed;
    let mut objects = Vec::new();
    for i in 0..n {
        let c = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 20.0 - 10.0;
        let shape = match i % 3 {
            0 => Shape::Sphere {
                center: c,
                radius: 0.2 + rand(&mut s),
            },
            1 => Shape::Polygon {
                vertices: (0..3)
                    .map(|_| c + Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 3.0)
                    .collect(),
            },
            _ => Shape::Polygon {
                // Shared edges: a quad split in two by the triangulator.
                vertices: vec![
                    c,
                    c + Vec3::X * 2.0,
                    c + Vec3::new(2.0, 2.0, 0.5),
                    c + Vec3::Y * 2.0,
                ],
            },
        };
        objects.push(Object {
            shape,
            surface: 0,
            motion: Vec3::ZERO,
        });
    }
    // One unbounded quadric (an infinite cylinder) and one capped cylinder.
    objects.push(Object {
        shape: Shape::Quadric(Quadric {
            q: [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -0.25],
            clip: vec![],
        }),
        surface: 0,
        motion: Vec3::ZERO,
    });
    objects.push(Object {
        shape: Shape::Quadric(Quadric {
            q: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0],
            clip: vec![
                HalfSpace {
                    normal: Vec3::Z,
                    offset: 3.0,
                },
                HalfSpace {
                    normal: -Vec3::Z,
                    offset: 1.0,
                },
            ],
        }),
        surface: 0,
        motion: Vec3::ZERO,
    });
    World {
        resolution: [1, 1],
        background: Vec3::ZERO,
        ambient: Vec3::ZERO,
        camera: Camera {
            position: Vec3::ZERO,
            at: Vec3::Z,
            up: Vec3::Y,
            half_angle_deg: 30.0,
            aperture: 0.0,
            focus_distance: 1.0,
        },
        lights: vec![],
        samples: 1,
        target_error: None,
        surfaces: vec![Surface::default()],
        objects,
        features: Default::default(),
    }
}

#[test]
fn octree_and_bvh_agree_with_exhaustive() {
    let world = random_world(300, 42);
    let mut scene = crate::scene::Scene::new(world);
    let mut build = |kind, max_per_voxel| {
        Accel::build(
            &mut scene.prims,
            &AccelOptions {
                kind,
                max_per_voxel,
                max_depth: 8,
            },
        )
    };
    let ex = build(AccelKind::Exhaustive, 10);
    let others = [
        build(AccelKind::Octree, 10),
        build(AccelKind::Octree, 2),
        build(AccelKind::Bvh, 10),
    ];
    let prims = &scene.prims;
    assert_eq!(ex.unbounded_count(), 1);
    let mut s = 7u64;
    let mut scratch = Scratch::new(prims.len(), true);
    let mut c = Counters::default();
    let mut hits = 0;
    for _ in 0..3000 {
        let o = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 30.0 - 15.0;
        let d = (Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) - 0.5).normalize();
        let r = RayPre::new(Ray::new(o, d));
        let t_max = if rand(&mut s) < 0.3 {
            5.0
        } else {
            f64::INFINITY
        };
        let want = ex.closest(prims, &r, t_max, &mut scratch, &mut c);
        hits += usize::from(want.is_some());
        for a in &others {
            assert_eq!(
                a.closest(prims, &r, t_max, &mut scratch, &mut c),
                want,
                "{:?}",
                a.kind
            );
            let any = a.any(prims, &r, t_max, &|_, _| true, &mut scratch, &mut c);
            assert_eq!(any.is_some(), want.is_some());
        }
    }
    assert!(hits > 300, "too few hits ({hits}) to mean anything");
}

#[test]
fn octree_splits_until_voxels_are_small() {
    let world = random_world(500, 3);
    let mut scene = crate::scene::Scene::new(world);
    let a = Accel::build(
        &mut scene.prims,
        &AccelOptions {
            kind: AccelKind::Octree,
            max_per_voxel: 10,
            max_depth: 8,
        },
    );
    let Structure::Octree(o) = &a.structure else {
        panic!("not an octree")
    };
    assert!(o.node_count() > 8 * 8);
}

#[test]
fn auto_picks_by_size() {
    assert_eq!(AccelKind::Auto.resolve(3), AccelKind::Exhaustive);
    assert_eq!(AccelKind::Auto.resolve(1000), AccelKind::Bvh);
    assert_eq!(AccelKind::Octree.resolve(3), AccelKind::Octree);
}

/// The footprint's cut through the BVH ([`bvh::Bvh::cut_boxes`]): within its bound (or the
/// root's children when they are more), deeper as the bound grows, and every primitive with
/// bounds inside one of its boxes, so a ray missing them all reaches no primitive.
#[test]
fn the_cut_through_the_bvh_holds_every_primitive_within_its_bound() {
    let mut scene = crate::scene::Scene::new(random_world(300, 7));
    let tree = bvh::Bvh::build(&mut scene.prims);
    let inside = |outer: &crate::geometry::Aabb, b: &crate::geometry::Aabb| {
        (b.min - outer.min).min_element() >= 0.0 && (outer.max - b.max).min_element() >= 0.0
    };
    let mut sizes = Vec::new();
    for most in [1, 4, 16, 64, 256] {
        let cut = tree.cut_boxes(most);
        assert!(
            cut.len() <= most.max(4),
            "{} boxes for at most {most}",
            cut.len()
        );
        for i in 0..scene.prims.len() as u32 {
            if let Some(b) = scene.prims.bounds(i) {
                assert!(
                    cut.iter().any(|c| inside(c, &b)),
                    "primitive {i} outside the cut of {most}"
                );
            }
        }
        sizes.push(cut.len());
    }
    assert!(sizes[1] <= 4 && sizes[4] > 64, "cut sizes {sizes:?}");
}
