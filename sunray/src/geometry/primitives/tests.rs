//! The compact tables answer every query exactly as the plain [`Primitive`] of the same
//! primitive does, on scenes with every kind: a triangle mesh, quads, a closed glass box
//! (solid faces, both windings), spheres, an ellipsoid, a quadric, moving shapes.

use super::*;
use crate::geometry::Ray;
use crate::sampler::unit_f64 as rand;
use glam::DAffine3;
use yari::model::{Object, Shape, Surface, World};

fn bits(v: Vec3) -> [u64; 3] {
    v.to_array().map(f64::to_bits)
}

/// A world of every kind of object: surface 0 opaque, surface 1 glass.
fn mixed_world() -> World {
    let mut w = crate::bench::spd_world(yari::spd::Database::Tetra, 2).unwrap();
    w.surfaces = vec![
        Surface::default(),
        Surface {
            kdt: 0.0,
            refract: 1.5,
            ..Surface::default()
        },
    ];
    for o in &mut w.objects {
        o.surface = 0;
    }
    let poly = |vertices: Vec<Vec3>, surface: u32, motion: Vec3| Object {
        shape: Shape::Polygon { vertices },
        surface,
        motion,
    };
    // A glass box wound outward, one wound inward: their faces are solid.
    for (lo, outward) in [
        (Vec3::new(3.0, 0.0, 0.0), true),
        (Vec3::new(6.0, 0.0, 0.0), false),
    ] {
        for f in crate::geometry::solid::tests::box_faces(lo, lo + Vec3::ONE, outward) {
            w.objects.push(poly(f, 1, Vec3::ZERO));
        }
    }
    // An opaque quad, a concave pentagon, a moving triangle, an open glass sheet.
    let quad = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.2), Vec3::Y];
    w.objects.push(poly(quad.clone(), 0, Vec3::ZERO));
    w.objects.push(poly(
        vec![
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(1.0, 0.5, 2.0),
            Vec3::new(2.0, 2.0, 2.0),
            Vec3::new(0.0, 2.0, 2.0),
        ],
        0,
        Vec3::ZERO,
    ));
    w.objects
        .push(poly(quad[..3].to_vec(), 0, Vec3::new(0.0, 0.5, 0.0)));
    w.objects.push(poly(quad, 1, Vec3::ZERO));
    w.objects.push(Object {
        shape: Shape::Sphere {
            center: Vec3::new(-2.0, 0.0, 0.0),
            radius: 0.7,
        },
        surface: 1,
        motion: Vec3::ZERO,
    });
    w.objects.push(Object {
        shape: Shape::Sphere {
            center: Vec3::new(-2.0, 2.0, 0.0),
            radius: 0.5,
        },
        surface: 0,
        motion: Vec3::new(0.3, 0.0, 0.0),
    });
    w.objects.push(Object {
        shape: Shape::Ellipsoid {
            to_world: DAffine3::from_translation(Vec3::new(0.0, -3.0, 0.0))
                * DAffine3::from_scale(Vec3::new(2.0, 0.5, 1.0)),
        },
        surface: 0,
        motion: Vec3::ZERO,
    });
    w
}

#[test]
fn every_query_matches_the_plain_primitive() {
    let w = mixed_world();
    let scene = crate::scene::Scene::new(w.clone());
    let prims = &scene.prims;
    let faces = crate::geometry::solid::closed_faces(&w);
    assert_eq!(
        faces
            .iter()
            .filter(|f| **f != crate::geometry::solid::Face::Open)
            .count(),
        12
    );
    let (triangles, corners) = prims.mesh_counts();
    assert!(
        corners < triangles,
        "{corners} corners for {triangles} triangles"
    );
    let solid = (0..prims.len() as u32)
        .filter(|&i| prims.get(i).is_closed())
        .count();
    let kinds: Vec<String> = (0..prims.len() as u32)
        .filter(|&i| prims.get(i).is_closed())
        .map(|i| {
            format!("{:?}", prims.get(i).kind)
                .chars()
                .take(12)
                .collect()
        })
        .collect();
    assert_eq!(
        solid,
        24 + 1 + 1 + 1,
        "box triangles, two spheres, the ellipsoid: {kinds:?}"
    );
    let mut s = 7u64;
    let mut hits = 0;
    for _ in 0..400 {
        let o = Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) * 16.0 - 8.0;
        // Towards a point near some primitive, so that most rays hit something.
        let aim = (rand(&mut s) * prims.len() as f64) as u32 % prims.len() as u32;
        let target = prims.bounds(aim).unwrap().centre();
        let d = target + (Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) - 0.5) * 0.2 - o;
        let mut ray = Ray::new(o, d);
        ray.time = rand(&mut s);
        let r = RayPre::new(ray);
        for i in 0..prims.len() as u32 {
            let plain = prims.get(i);
            let t = prims.intersect(i, &r, 0.0, Real::INFINITY);
            assert_eq!(
                t.map(f64::to_bits),
                plain.intersect(&r, 0.0, Real::INFINITY).map(f64::to_bits)
            );
            assert_eq!(prims.intersect_slot(prims.slot(i), &r, 0.0, 1e300), t);
            if let Some(t) = t {
                hits += 1;
                let p = ray.at(t);
                assert_eq!(
                    bits(prims.normal(i, p, ray.time)),
                    bits(plain.normal(p, ray.time))
                );
            }
        }
    }
    assert!(hits > 200, "{hits}");
    for i in 0..prims.len() as u32 {
        let plain = prims.get(i);
        assert_eq!(prims.prim_of(prims.slot(i)), i);
        assert_eq!(prims.is_closed(i), plain.is_closed());
        assert_eq!(prims.surface(i), plain.surface);
        assert_eq!(prims.motion(i), plain.motion);
        assert_eq!(prims.bounds(i), plain.bounds());
        for k in 0..8 {
            let c = plain.bounds().unwrap().centre();
            let at = c + Vec3::new(rand(&mut s), rand(&mut s), rand(&mut s)) - 0.5;
            let half = Vec3::splat(0.05 + 0.1 * f64::from(k));
            let b = crate::geometry::Aabb::new(at - half, at + half);
            assert_eq!(
                prims.overlaps_box(i, &b),
                plain.overlaps_box(&b),
                "{i} {b:?}"
            );
        }
    }
}

#[test]
fn a_polygons_normal_is_its_own_to_the_bit() {
    // The triangles of a quad share the quad's Newell normal (stored); a triangle's is
    // recomputed from its corners; an inward glass face's is negated.
    let w = mixed_world();
    let scene = crate::scene::Scene::new(w.clone());
    let mut prim = 0u32;
    let faces = crate::geometry::solid::closed_faces(&w);
    for (k, o) in w.objects.iter().enumerate() {
        let Shape::Polygon { vertices } = &o.shape else {
            prim += 1;
            continue;
        };
        let t = crate::geometry::polygon::triangulate(vertices).unwrap();
        let want = match faces[k] {
            crate::geometry::solid::Face::Inward => -t.normal,
            _ => t.normal,
        };
        for _ in &t.triangles {
            let got = scene.prims.normal(prim, Vec3::ZERO, 0.0);
            assert_eq!(bits(got), bits(want), "object {k}");
            prim += 1;
        }
    }
    assert_eq!(prim as usize, scene.prims.len());
}

#[test]
fn a_model_read_as_a_stream_is_the_same_scene() {
    let w = mixed_world();
    let bytes = yari::modelfile::to_bytes(&w).unwrap();
    let whole = crate::scene::Scene::new(w);
    let streamed = crate::scene::Scene::read_model(&mut &bytes[..]).unwrap();
    let mut pieces = crate::scene::SceneStream::new();
    for p in bytes.chunks(13) {
        pieces.feed(p).unwrap();
    }
    let pieces = pieces.finish().unwrap();
    for s in [&streamed, &pieces] {
        assert_eq!(s.objects, whole.objects);
        assert_eq!(s.prims.len(), whole.prims.len());
        for i in 0..whole.prims.len() as u32 {
            assert_eq!(
                format!("{:?}", s.prims.get(i)),
                format!("{:?}", whole.prims.get(i))
            );
        }
    }
    let mut cut = crate::scene::SceneStream::new();
    cut.feed(&bytes[..bytes.len() - 3]).unwrap();
    assert!(cut.finish().is_err());
}

#[test]
fn the_tables_hold_about_forty_bytes_a_triangle() {
    let w = crate::bench::spd_world(yari::spd::Database::Tetra, 6).unwrap();
    let scene = crate::scene::Scene::new(w);
    let n = scene.prims.len();
    assert_eq!(n, 4096);
    let per = scene.prims.bytes() as f64 / n as f64;
    assert!(per < 48.0, "{per} bytes a triangle");
}

#[test]
fn smooth_polygons_keep_their_corner_normals_in_a_side_table() {
    let mut w = mixed_world();
    let flat = Primitives::from_list(Vec::new());
    assert_eq!(flat.smooth_counts(), (0, 0));
    let before = {
        let mut b = PrimitivesBuilder::new();
        for o in &w.objects {
            b.add(&w.surfaces, o);
        }
        b.finish().0
    };
    assert_eq!(
        before.smooth_counts(),
        (0, 0),
        "no vertex normals, no table"
    );
    // A static smooth quad (two triangles) with normals leaning out from its centre, given
    // against its winding (they are turned over), and a moving smooth triangle.
    let quad = vec![
        Vec3::new(0.0, 0.0, 9.0),
        Vec3::new(2.0, 0.0, 9.0),
        Vec3::new(2.0, 2.0, 9.0),
        Vec3::new(0.0, 2.0, 9.0),
    ];
    let lean = |x: f64, y: f64| -Vec3::new(x, y, 2.0);
    let normals = vec![
        lean(-1.0, -1.0),
        lean(1.0, -1.0),
        lean(1.0, 1.0),
        lean(-1.0, 1.0),
    ];
    w.objects.push(Object {
        shape: Shape::SmoothPolygon {
            vertices: quad,
            normals,
        },
        surface: 0,
        motion: Vec3::ZERO,
    });
    w.objects.push(Object {
        shape: Shape::SmoothPolygon {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::Z, Vec3::X + Vec3::Z, Vec3::Y + Vec3::Z],
        },
        surface: 0,
        motion: Vec3::new(0.0, 0.0, 1.0),
    });
    let mut b = PrimitivesBuilder::new();
    for o in &w.objects {
        b.add(&w.surfaces, o);
    }
    let (mut prims, dropped) = b.finish();
    assert!(dropped.is_empty());
    let n = prims.len() as u32;
    assert_eq!(n, before.len() as u32 + 3);
    assert_eq!(prims.smooth_counts(), (3, 7));
    // The quad's centre (on the diagonal shared by its two triangles): the normals average
    // to +z there, from either triangle.
    let (q0, q1) = (n - 3, n - 2);
    for t in [q0, q1] {
        let h = prims.smooth_hit(t, Vec3::new(1.0, 1.0, 9.0), 0.0).unwrap();
        let g = prims.normal(t, Vec3::new(1.0, 1.0, 9.0), 0.0);
        assert_eq!(g, Vec3::Z);
        let s = h.normal().unwrap();
        assert!((s - Vec3::Z).length() < 1e-12, "{s}");
        // At a corner: that corner's normal, turned to +z.
        let c = h.corners[0];
        let hc = prims.smooth_hit(t, c, 0.0).unwrap();
        let want = Vec3::new(c.x - 1.0, c.y - 1.0, 2.0).normalize();
        assert!((hc.normal().unwrap() - want).length() < 1e-12);
    }
    // The moving triangle at time 1 is one unit up; its centroid's normal by hand:
    // (z + (x+z)/sqrt2 + (y+z)/sqrt2) / 3, normalised.
    let m = n - 1;
    let h = prims
        .smooth_hit(m, Vec3::new(1.0 / 3.0, 1.0 / 3.0, 1.0), 1.0)
        .unwrap();
    let r = 0.5f64.sqrt();
    let want = Vec3::new(r, r, 1.0 + 2.0 * r).normalize();
    assert!((h.normal().unwrap() - want).length() < 1e-12);
    // Flat primitives have none; the accelerator's order (which moves triangles in the
    // mesh) changes nothing: the table is keyed by primitive number.
    assert!(prims.smooth_hit(0, Vec3::ZERO, 0.0).is_none());
    let at = Vec3::new(0.5, 1.5, 9.0);
    let was = prims
        .smooth_hit(q1, at, 0.0)
        .or(prims.smooth_hit(q0, at, 0.0));
    let order: Vec<u32> = (0..n).rev().collect();
    assert!(prims.adopt_order(&order));
    let now = prims
        .smooth_hit(q1, at, 0.0)
        .or(prims.smooth_hit(q0, at, 0.0));
    assert_eq!(was, now);
    assert!(was.is_some());
}

#[test]
fn flat_faces_are_a_flat_polygons_triangles_or_a_triangle_alone() {
    let surfaces: Vec<Surface> = Vec::new();
    let mut b = PrimitivesBuilder::new();
    let poly = |vertices: Vec<Vec3>, motion: Vec3| Object {
        shape: Shape::Polygon { vertices },
        surface: 0,
        motion,
    };
    let square = |z: f64| {
        vec![
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        ]
    };
    // A triangle (0); a square in a tilted plane (1, 2); a quad with one corner lifted by a
    // millionth of its size (3, 4: warped, shaded with the quad's normal, not their own); a
    // sphere (5); a moving square (6, 7); a flat pentagon (8, 9, 10).
    let tilt = DAffine3::from_rotation_x(0.3) * DAffine3::from_rotation_z(0.7);
    let objects = vec![
        poly(vec![Vec3::ZERO, Vec3::X, Vec3::Y], Vec3::ZERO),
        poly(
            square(3.0)
                .iter()
                .map(|&v| tilt.transform_point3(v))
                .collect(),
            Vec3::ZERO,
        ),
        poly(
            {
                let mut q = square(0.0);
                q[3].z += 2e-6;
                q
            },
            Vec3::ZERO,
        ),
        Object {
            shape: Shape::Sphere {
                center: Vec3::ZERO,
                radius: 1.0,
            },
            surface: 0,
            motion: Vec3::ZERO,
        },
        poly(square(1.0), Vec3::X),
        poly(
            (0..5)
                .map(|k| {
                    let a = k as f64 * std::f64::consts::TAU / 5.0;
                    Vec3::new(a.cos(), 5.0, a.sin())
                })
                .collect(),
            Vec3::ZERO,
        ),
    ];
    for o in &objects {
        b.add(&surfaces, o);
    }
    // Triangles given with a normal: their plane's (11), another (12).
    for normal in [Vec3::Z, Vec3::new(0.0, 0.6, 0.8)] {
        b.add_primitive(Primitive {
            kind: PrimitiveKind::Triangle {
                v: [Vec3::ZERO, Vec3::X, Vec3::Y],
                normal,
                solid: false,
            },
            object: 6,
            surface: 0,
            motion: Vec3::ZERO,
        });
    }
    let (mut prims, dropped) = b.finish();
    assert!(dropped.is_empty());
    assert_eq!(prims.len(), 13);
    let want = [
        Some([0, 1]),
        Some([1, 3]),
        Some([1, 3]),
        None,
        None,
        None,
        None,
        None,
        Some([8, 11]),
        Some([8, 11]),
        Some([8, 11]),
        Some([11, 12]),
        None,
    ];
    let got: Vec<_> = (0..13).map(|i| prims.flat_face(i)).collect();
    assert_eq!(got, want);
    // The accelerator's order moves the mesh's triangles, not the primitive numbers.
    assert!(prims.adopt_order(&(0..13).rev().collect::<Vec<u32>>()));
    assert_eq!(
        (0..13).map(|i| prims.flat_face(i)).collect::<Vec<_>>(),
        want
    );
    assert_eq!(prims.flat_face(13), None);
}

#[test]
fn a_ray_leaving_a_face_misses_its_triangles_and_nothing_else() {
    let mut b = PrimitivesBuilder::new();
    let surfaces: Vec<Surface> = Vec::new();
    for z in [0.0, 1.0] {
        b.add(
            &surfaces,
            &Object {
                shape: Shape::Polygon {
                    vertices: vec![
                        Vec3::new(-1.0, -1.0, z),
                        Vec3::new(1.0, -1.0, z),
                        Vec3::new(1.0, 1.0, z),
                        Vec3::new(-1.0, 1.0, z),
                    ],
                },
                surface: 0,
                motion: Vec3::ZERO,
            },
        );
    }
    let prims = b.finish().0;
    // A ray up through both squares, from below: it meets each at one of its two triangles.
    let r = RayPre::new(Ray::new(Vec3::new(0.3, 0.1, -1.0), Vec3::Z));
    let hits = |r: &RayPre| -> Vec<u32> {
        (0..4)
            .filter(|&i| prims.intersect(i, r, 0.0, 10.0).is_some())
            .collect()
    };
    let all = hits(&r);
    assert_eq!(all.len(), 2, "{all:?}");
    assert!(all[0] < 2 && all[1] >= 2);
    let skipping = r.clone().leaving(prims.flat_face(all[0]).unwrap());
    assert!(skipping.skips(0) && skipping.skips(1) && !skipping.skips(2));
    assert_eq!(hits(&skipping), vec![all[1]]);
    assert!(!r.skips(0), "a new ray skips nothing");
}
