//! Watertight meshes (Woop, Benthin and Wald 2013): rays through the shared edges and vertices
//! of closed triangle meshes must hit, from inside every ray hits, and no pixel leaks the
//! background through a closed surface, with every accelerator (so also rays running exactly
//! along octree voxel boundaries, which the centred cameras below produce).
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

mod hard_common;

use glam::DVec3;
use hard_common::{count_colour, render_with};
use sunray::accel::{Accel, AccelKind, AccelOptions, Scratch};
use sunray::geometry::{Ray, RayPre};
use sunray::scene::Scene;
use sunray::stats::Counters;
use yari::model::{Camera, Light, Object, Shape, Surface, World};

const KINDS: [AccelKind; 3] = [AccelKind::Exhaustive, AccelKind::Octree, AccelKind::Bvh];

fn tri(a: DVec3, b: DVec3, c: DVec3) -> Object {
    Object {
        shape: Shape::Polygon {
            vertices: vec![a, b, c],
        },
        surface: 0,
        motion: DVec3::ZERO,
    }
}

/// The cube [-1, 1]^3, each face an n x n grid of quads split into two triangles.
fn grid_cube(n: u32) -> Vec<Object> {
    let mut out = Vec::new();
    for axis in 0..3 {
        for side in [-1.0, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let p = |i: u32, j: u32| {
                let mut p = DVec3::ZERO;
                p[axis] = side;
                p[u] = -1.0 + 2.0 * i as f64 / n as f64;
                p[v] = -1.0 + 2.0 * j as f64 / n as f64;
                p
            };
            for i in 0..n {
                for j in 0..n {
                    out.push(tri(p(i, j), p(i + 1, j), p(i + 1, j + 1)));
                    out.push(tri(p(i, j), p(i + 1, j + 1), p(i, j + 1)));
                }
            }
        }
    }
    out
}

/// A latitude-longitude sphere of triangles (poles shared by `slices` triangles each).
fn lat_long_sphere(stacks: u32, slices: u32) -> Vec<Object> {
    let pt = |i: u32, j: u32| {
        let th = std::f64::consts::PI * i as f64 / stacks as f64;
        let ph = 2.0 * std::f64::consts::PI * (j % slices) as f64 / slices as f64;
        if i == 0 {
            return DVec3::Z;
        }
        if i == stacks {
            return -DVec3::Z;
        }
        DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos())
    };
    let mut out = Vec::new();
    for i in 0..stacks {
        for j in 0..slices {
            let (a, b, c, d) = (pt(i, j), pt(i + 1, j), pt(i + 1, j + 1), pt(i, j + 1));
            if i != 0 {
                out.push(tri(a, b, d));
            }
            if i + 1 != stacks {
                out.push(tri(b, c, d));
            }
        }
    }
    out
}

/// A magenta background, a grey surface lit from where the camera is.
fn inside_world(objects: Vec<Object>, position: DVec3, at: DVec3, up: DVec3) -> World {
    let mut w = World {
        resolution: [33, 33],
        background: DVec3::new(1.0, 0.0, 1.0),
        ambient: DVec3::splat(0.3),
        camera: Camera {
            position,
            at,
            up,
            half_angle_deg: 45.0,
            aperture: 0.0,
            focus_distance: 1.0,
        },
        lights: vec![Light {
            position,
            color: DVec3::splat(0.5),
            radius: 0.0,
        }],
        samples: 1,
        target_error: None,
        surfaces: vec![Surface {
            color: DVec3::splat(0.8),
            ka: 0.5,
            ..Surface::default()
        }],
        objects,
        features: Default::default(),
    };
    w.features.polygons = w.objects.len();
    w
}

#[test]
fn camera_inside_a_grid_cube_never_sees_the_background() {
    let views = [
        (DVec3::ZERO, DVec3::X, DVec3::Y),
        (DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::Z),
        (DVec3::ZERO, DVec3::new(1.0, 1.0, 1.0), DVec3::Y),
        (
            DVec3::new(0.25, -0.5, 0.125),
            DVec3::new(0.25, -0.5, -1.0),
            DVec3::Y,
        ),
        (
            DVec3::new(0.5, 0.5, 0.5),
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::X,
        ),
    ];
    for (pos, at, up) in views {
        let w = inside_world(grid_cube(8), pos, at, up);
        for kind in KINDS {
            let film = render_with(&w, kind);
            let leaks = count_colour(&film, [255, 0, 255]);
            assert_eq!(
                leaks, 0,
                "{kind:?} from {pos} towards {at}: {leaks} pixels leak"
            );
        }
    }
}

#[test]
fn camera_inside_a_triangle_sphere_sees_no_hole_at_its_poles() {
    for (at, up) in [
        (DVec3::Z, DVec3::Y),
        (-DVec3::Z, DVec3::X),
        (DVec3::X, DVec3::Z),
    ] {
        let w = inside_world(lat_long_sphere(12, 24), DVec3::ZERO, at, up);
        for kind in KINDS {
            let film = render_with(&w, kind);
            assert_eq!(
                count_colour(&film, [255, 0, 255]),
                0,
                "{kind:?} towards {at}"
            );
        }
    }
}

fn closest(scene: &Scene, accel: &Accel, ray: Ray) -> Option<f64> {
    let mut scratch = Scratch::new(scene.prims.len(), true);
    let mut c = Counters::default();
    accel
        .closest(
            &scene.prims,
            &RayPre::new(ray),
            f64::INFINITY,
            &mut scratch,
            &mut c,
        )
        .map(|h| h.t)
}

/// SPD tetra 4: every small tetrahedron is a closed mesh whose vertices sit on a 1/32 grid.
/// Rays from its centroid through its vertices, edge midpoints, face centres and along the
/// axes all hit it; rays from outside aimed through the same points hit no later than them.
#[test]
fn spd_tetra_is_watertight_through_vertices_edges_and_axes() {
    let world = sunray::bench::spd_world(yari::spd::Database::Tetra, 4).unwrap();
    let tris: Vec<[DVec3; 3]> = world
        .objects
        .iter()
        .filter_map(|o| match &o.shape {
            Shape::Polygon { vertices } if vertices.len() == 3 => {
                Some([vertices[0], vertices[1], vertices[2]])
            }
            _ => None,
        })
        .collect();
    assert_eq!(tris.len(), 4 * 64, "tetra 4 has 64 tetrahedra of 4 faces");
    let mut scene = Scene::new(world.clone());
    for kind in KINDS {
        let accel = Accel::build(
            &mut scene.prims,
            &AccelOptions {
                kind,
                ..AccelOptions::default()
            },
        );
        let mut rays = 0;
        for tet in tris.chunks(4) {
            let mut verts: Vec<DVec3> = Vec::new();
            for t in tet {
                for v in t {
                    if !verts.contains(v) {
                        verts.push(*v);
                    }
                }
            }
            assert_eq!(verts.len(), 4, "faces 4k..4k+3 form one tetrahedron");
            for v in &verts {
                let scaled = *v * 32.0;
                assert_eq!(scaled, scaled.round(), "vertex {v} is on the 1/32 grid");
            }
            let c = (verts[0] + verts[1] + verts[2] + verts[3]) / 4.0;
            let mut targets = verts.clone();
            for i in 0..4 {
                for j in i + 1..4 {
                    targets.push((verts[i] + verts[j]) / 2.0);
                }
            }
            for t in tet {
                targets.push((t[0] + t[1] + t[2]) / 3.0);
            }
            for target in targets {
                let d = target - c;
                let reach = d.length() * (1.0 + 1e-9);
                let t = closest(&scene, &accel, Ray::new(c, d.normalize()));
                assert!(
                    t.is_some_and(|t| t <= reach),
                    "{kind:?}: from inside through {target}: {t:?}"
                );
                let from = target + d * 2.0;
                let t = closest(&scene, &accel, Ray::new(from, -d.normalize()));
                assert!(
                    t.is_some_and(|t| t <= 2.0 * reach),
                    "{kind:?}: from outside through {target}: {t:?}"
                );
                rays += 2;
            }
            for axis in [
                DVec3::X,
                DVec3::Y,
                DVec3::Z,
                -DVec3::X,
                -DVec3::Y,
                -DVec3::Z,
            ] {
                assert!(
                    closest(&scene, &accel, Ray::new(c, axis)).is_some(),
                    "{kind:?}: along {axis} from inside"
                );
                // Through each vertex along the axis, from outside towards the inside half.
                for v in &verts {
                    let inward = (c - *v).dot(axis) > 0.0;
                    if inward {
                        let t = closest(&scene, &accel, Ray::new(*v - axis, axis));
                        assert!(
                            t.is_some_and(|t| t <= 1.0 + 1e-9),
                            "{kind:?}: along {axis} through vertex {v}: {t:?}"
                        );
                    }
                }
            }
        }
        assert!(rays > 1000);
    }
}
