use super::*;
use crate::skeleton::{Plane, SkeletonKind};

fn skel(plane: Plane, kind: SkeletonKind, closed: bool, points: &[[f64; 2]]) -> Skeleton {
    let mut s = Skeleton::new("s", plane, kind);
    s.points = points.to_vec();
    s.closed = closed;
    s
}

fn assert_solid(m: &Mesh) {
    m.check_closed().unwrap();
    m.check_welded().unwrap();
    assert!(m.signed_volume() > 0.0, "volume {}", m.signed_volume());
}

/// Volume of a prism over a regular n-gon inscribed in a circle of radius r.
fn ngon_prism(n: usize, r: f64, h: f64) -> f64 {
    0.5 * n as f64 * r * r * (std::f64::consts::TAU / n as f64).sin() * h
}

#[test]
fn a_revolved_cylinder_profile_is_a_closed_prism_of_the_right_volume() {
    // (0,0) -> (1,0) -> (1,2) -> (0,2) in the xy plane, about y.
    let p = skel(
        Plane::Xy,
        SkeletonKind::Lines,
        false,
        &[[0.0, 0.0], [1.0, 0.0], [1.0, 2.0], [0.0, 2.0]],
    );
    for step in [120.0, 45.0, 10.0, 7.5] {
        let m = revolve(&p, 1, step, None, None).unwrap();
        assert_solid(&m);
        let n = (360.0 / step) as usize;
        assert!(
            (m.signed_volume() - ngon_prism(n, 1.0, 2.0)).abs() < 1e-9,
            "step {step}"
        );
        // n triangles at each pole and n quads on the side.
        assert_eq!(m.faces.len(), 3 * n);
    }
}

#[test]
fn open_profile_ends_off_the_axis_get_caps() {
    // A tube wall from radius 1 at y=0 to radius 2 at y=1, on the negative x side, about y.
    let p = skel(
        Plane::Xy,
        SkeletonKind::Lines,
        false,
        &[[-1.0, 0.0], [-2.0, 1.0]],
    );
    let m = revolve(&p, 1, 30.0, None, None).unwrap();
    assert_solid(&m);
    assert_eq!(m.faces.len(), 12 + 2);
}

#[test]
fn a_closed_profile_sweeps_a_closed_ring() {
    // A square cross-section in the yz plane, about z: a square torus.
    let p = skel(
        Plane::Yz,
        SkeletonKind::Lines,
        true,
        &[[2.0, 0.0], [3.0, 0.0], [3.0, 1.0], [2.0, 1.0]],
    );
    let m = revolve(&p, 2, 15.0, None, None).unwrap();
    assert_solid(&m);
    let n = 24;
    let expected = ngon_prism(n, 3.0, 1.0) - ngon_prism(n, 2.0, 1.0);
    assert!((m.signed_volume() - expected).abs() < 1e-9);
}

#[test]
fn bezier_profiles_stay_closed_at_every_smoothness_and_step() {
    // A king-like bulb: cubic pieces from the axis at the bottom to the axis at the top.
    let pts = [
        [0.0, 0.0],
        [2.0, 0.0],
        [2.0, 0.5],
        [1.0, 1.0],
        [0.3, 1.5],
        [0.3, 3.0],
        [1.0, 3.5],
        [1.2, 3.8],
        [0.5, 4.0],
        [0.0, 4.0],
    ];
    let mut p = skel(Plane::Xy, SkeletonKind::Bezier, false, &pts);
    for smooth in [1, 2, 5, 12] {
        p.smoothness = smooth;
        for step in [90.0, 45.0, 20.0] {
            let m = revolve(&p, 1, step, None, None).unwrap();
            assert_solid(&m);
        }
    }
    let blocky = revolve(&p, 1, 90.0, Some(1), None).unwrap();
    let smooth = revolve(&p, 1, 10.0, Some(12), None).unwrap();
    assert!(smooth.faces.len() > 10 * blocky.faces.len());
}

#[test]
fn revolve_refuses_bad_profiles_with_reasons() {
    let crosses = skel(
        Plane::Xy,
        SkeletonKind::Lines,
        false,
        &[[-1.0, 0.0], [1.0, 1.0]],
    );
    assert!(revolve(&crosses, 1, 45.0, None, None)
        .unwrap_err()
        .to_string()
        .contains("crosses"));
    let wrong_plane = skel(
        Plane::Xz,
        SkeletonKind::Lines,
        false,
        &[[1.0, 0.0], [1.0, 1.0]],
    );
    assert!(revolve(&wrong_plane, 1, 45.0, None, None)
        .unwrap_err()
        .to_string()
        .contains("does not contain"));
    let ok = skel(
        Plane::Xy,
        SkeletonKind::Lines,
        false,
        &[[1.0, 0.0], [1.0, 1.0]],
    );
    assert!(revolve(&ok, 1, 0.0, None, None)
        .unwrap_err()
        .to_string()
        .contains("--step"));
    assert!(revolve(&ok, 1, 200.0, None, None)
        .unwrap_err()
        .to_string()
        .contains("--step"));
    let on_axis = skel(
        Plane::Xy,
        SkeletonKind::Lines,
        false,
        &[[0.0, 0.0], [0.0, 1.0]],
    );
    assert!(revolve(&on_axis, 1, 45.0, None, None).is_err());
}

#[test]
fn an_extruded_concave_outline_is_closed_with_area_times_length() {
    // An L shape of area 3 in the xy plane, extruded by 2 along z (and tilted in x).
    let l = [
        [0.0, 0.0],
        [2.0, 0.0],
        [2.0, 1.0],
        [1.0, 1.0],
        [1.0, 2.0],
        [0.0, 2.0],
    ];
    for (closed, by) in [
        (false, DVec3::new(0.0, 0.0, 2.0)),
        (true, DVec3::new(0.5, 0.0, -2.0)),
    ] {
        let o = skel(Plane::Xy, SkeletonKind::Lines, closed, &l);
        let m = extrude(&o, by, true, false, None).unwrap();
        assert_solid(&m);
        assert!((m.signed_volume() - 6.0).abs() < 1e-12);
        assert_eq!(m.faces.len(), 6 + 2);
    }
}

#[test]
fn extrude_centred_straddles_the_plane_and_bezier_outlines_work() {
    let mut o = skel(
        Plane::Xz,
        SkeletonKind::Bezier,
        true,
        &[
            [1.0, 0.0],
            [1.0, 1.0],
            [-1.0, 1.0],
            [-1.0, 0.0],
            [-1.0, -1.0],
            [1.0, -1.0],
        ],
    );
    o.depth = 5.0;
    let m = extrude(&o, DVec3::new(0.0, 2.0, 0.0), true, true, Some(6)).unwrap();
    assert_solid(&m);
    let ys: Vec<f64> = m.vertices.iter().map(|v| v.y).collect();
    assert_eq!(ys.iter().cloned().fold(f64::INFINITY, f64::min), 4.0);
    assert_eq!(ys.iter().cloned().fold(f64::NEG_INFINITY, f64::max), 6.0);
}

#[test]
fn extrude_without_caps_is_open_and_a_flat_vector_is_refused() {
    let sq = skel(
        Plane::Xy,
        SkeletonKind::Lines,
        true,
        &[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
    );
    let open = extrude(&sq, DVec3::Z, false, false, None).unwrap();
    assert!(open.check_closed().is_err());
    let e = extrude(&sq, DVec3::X, true, false, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("--by"), "{e}");
}

#[test]
fn a_smooth_revolved_sphere_has_nearly_radial_outward_normals() {
    // A half circle of radius 2 from pole to pole in 8 pieces, on the +x side, about y.
    let pts: Vec<[f64; 2]> = (0..=8)
        .map(|i| {
            let t = std::f64::consts::PI * i as f64 / 8.0;
            [2.0 * t.sin(), -2.0 * t.cos()]
        })
        .collect();
    let p = skel(Plane::Xy, SkeletonKind::Lines, false, &pts);
    let flat = revolve(&p, 1, 30.0, None, None).unwrap();
    assert!(flat.normals.is_empty());
    let m = revolve(&p, 1, 30.0, None, Some(45.0)).unwrap();
    assert_solid(&m);
    assert_eq!(m.faces, flat.faces, "the same geometry");
    assert_eq!(m.normals.len(), m.faces.len());
    let mut worst: f64 = 0.0;
    for (f, n) in m.faces.iter().zip(&m.normals) {
        let n = n.as_ref().expect("every side face is smooth (no caps)");
        assert_eq!(n.len(), f.len());
        for (&v, n) in f.iter().zip(n) {
            let radial = m.vertices[v].normalize();
            assert!((n.length() - 1.0).abs() < 1e-12);
            worst = worst.max(n.angle_between(radial).to_degrees());
        }
    }
    // Averaged profile normals are within a few degrees of the sphere's; poles exact.
    assert!(worst < 3.0, "{worst} degrees");
    let pole = m
        .vertices
        .iter()
        .position(|v| *v == DVec3::new(0.0, 2.0, 0.0))
        .unwrap();
    for (f, n) in m.faces.iter().zip(&m.normals) {
        if let Some(k) = f.iter().position(|&v| v == pole) {
            assert_eq!(n.as_ref().unwrap()[k], DVec3::Y);
        }
    }
    // The primitives carry the normals, and YARI text with them compiles to smooth polygons.
    let prims = m.to_primitives();
    assert!(prims.iter().all(|p| matches!(
        p,
        crate::project::Primitive::Polygon {
            normals: Some(_),
            ..
        }
    )));
}

#[test]
fn a_smooth_cylinder_keeps_its_rims_sharp_and_its_caps_flat() {
    // Radius 1, height 2, from the axis at the bottom to the axis at the top: the two
    // right-angle rims turn by 90 degrees, more than the crease angle.
    let p = skel(
        Plane::Xy,
        SkeletonKind::Lines,
        false,
        &[[0.0, 0.0], [1.0, 0.0], [1.0, 2.0], [0.0, 2.0]],
    );
    let m = revolve(&p, 1, 45.0, None, Some(45.0)).unwrap();
    for (f, n) in m.faces.iter().zip(&m.normals) {
        let n = n.as_ref().unwrap();
        let verts: Vec<DVec3> = f.iter().map(|&v| m.vertices[v]).collect();
        let side = verts.iter().all(|v| v.y == verts[0].y);
        for (v, n) in verts.iter().zip(n) {
            if side {
                // A bottom or top disc (made of triangles to the pole): straight down or up.
                assert!((n.y.abs() - 1.0).abs() < 1e-12, "{v} {n}");
            } else {
                // The wall: horizontal and radial, even at the rims.
                assert!(
                    n.y.abs() < 1e-12 && (n.dot(DVec3::new(v.x, 0.0, v.z)) - 1.0).abs() < 1e-12
                );
            }
        }
    }
    // With a crease of 90 degrees the rims are rounded: the normals there lean at 45.
    let round = revolve(&p, 1, 45.0, None, Some(90.0)).unwrap();
    let leaning = round
        .normals
        .iter()
        .flatten()
        .flatten()
        .filter(|n| (n.y.abs() - 0.5f64.sqrt()).abs() < 1e-12)
        .count();
    assert!(leaning > 0);
    assert!(revolve(&p, 1, 45.0, None, Some(200.0)).is_err());
}
