//! Whole-image hard cases: the same scene at scale 1e-4, 1 and 1e+4 and far from the origin
//! gives the same picture (self-intersection of shadow, reflected and refracted rays would
//! show as speckles), index-matched nested spheres are invisible, a mirror shows the reflected
//! scene, coplanar overlapping polygons resolve the same way everywhere.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

mod hard_common;

use hard_common::{assert_same_picture, render, render_with, world};
use sunray::accel::AccelKind;

/// A floor, a mirror ball, a glass ball, a diffuse ball casting a shadow, one light;
/// every coordinate multiplied by `s` and moved by `off`.
fn scaled_scene(s: f64, off: [f64; 3]) -> String {
    let p = |x: f64, y: f64, z: f64| {
        format!("{},{},{}", x * s + off[0], y * s + off[1], z * s + off[2])
    };
    format!(
        "resolution(96, 72);
background(color = 0.2,0.3,0.5);
ambient(color = 0.2,0.2,0.2);
light(position = {light} ; color = 1,1,1);
camera(position = {eye} ; at = {at} ; up = 0,1,0 ; angle = 20);
begin
  attribute(color = 0.9,0.9,0.8);
  polygon(vertices = 4; {f0} {f1} {f2} {f3});
  begin attribute(color = 0.9,0.9,0.9 ; kdr = 0.3 ; phong = 30); sphere(center = {c0} ; radius = {r}); end
  begin attribute(color = 1,1,1 ; kdr = 0.1 ; kdt = 0.1 ; refract = 1.5 ; phong = 60); sphere(center = {c1} ; radius = {r}); end
  begin attribute(color = 0.8,0.2,0.2); sphere(center = {c2} ; radius = {r2}); end
end",
        light = p(4.0, 9.0, 6.0),
        eye = p(0.0, 2.5, 9.0),
        at = p(0.0, 0.8, 0.0),
        f0 = p(-6.0, 0.0, -6.0),
        f1 = p(-6.0, 0.0, 6.0),
        f2 = p(6.0, 0.0, 6.0),
        f3 = p(6.0, 0.0, -6.0),
        c0 = p(-1.3, 1.0, 0.0),
        c1 = p(1.3, 1.0, 0.5),
        c2 = p(0.0, 0.5, -2.0),
        r = s,
        r2 = 0.5 * s,
    )
}

#[test]
fn same_scene_at_1e_minus4_and_1e4_scale_gives_the_same_image() {
    let unit = render(&world(&scaled_scene(1.0, [0.0; 3])));
    for s in [1e-4, 1e4] {
        let other = render(&world(&scaled_scene(s, [0.0; 3])));
        assert_same_picture(&unit, &other, &format!("scale {s}"));
    }
}

#[test]
fn same_scene_1e5_from_the_origin_gives_the_same_image() {
    let unit = render(&world(&scaled_scene(1.0, [0.0; 3])));
    let far = render(&world(&scaled_scene(1.0, [1e5, -3e4, 2e4])));
    assert_same_picture(&unit, &far, "moved 1e5 away");
}

/// Spheres of refractive index 1 that transmit everything (kdt = 0, colour white so shadows
/// pass unfiltered, kdr = 0 and a needle-sharp highlight), one nested in the other, must be
/// invisible: from outside, and with the camera inside both. A ray that re-hit the surface it
/// leaves would use up the depth limit and come back black.
#[test]
fn index_matched_nested_spheres_are_invisible_from_outside_and_inside() {
    let base = |extra: &str, eye: &str| {
        format!(
            "resolution(64, 48);
background(color = 0.2,0.3,0.5);
ambient(color = 0.2,0.2,0.2);
light(position = 4,9,6 ; color = 1,1,1);
camera(position = {eye} ; at = 0,0.8,0 ; up = 0,1,0 ; angle = 30);
begin
  attribute(color = 0.9,0.9,0.8);
  polygon(vertices = 4; -6,0,-6 -6,0,6 6,0,6 6,0,-6);
  begin attribute(color = 0.8,0.2,0.2); sphere(center = 0,0.5,-2 ; radius = 0.5); end
  {extra}
end"
        )
    };
    let glass =
        "begin attribute(color = 1,1,1 ; kdr = 0 ; kdt = 0 ; ka = 0 ; refract = 1 ; phong = 1e7);
      sphere(center = 0,1,0 ; radius = 1.2); sphere(center = 0.2,1,0.1 ; radius = 0.6); end";
    for eye in ["0,2.5,9", "0.1,1,0.2"] {
        let without = render(&world(&base("", eye)));
        let with = render(&world(&base(glass, eye)));
        assert_same_picture(&without, &with, &format!("eye at {eye}"));
    }
}

/// A mirror filling the view shows the scene reflected in its plane: compare with the
/// reflected scene rendered without the mirror.
#[test]
fn mirror_shows_the_reflected_scene() {
    let scene = |mirror: bool| {
        // The mirror is the plane z = 0; the camera at z = 6 looks at it; the balls sit
        // behind the camera (z > 6), seen only in the mirror. The reference moves the balls
        // and the light to z -> -z and has no mirror.
        let sz = if mirror { 1.0 } else { -1.0 };
        let m = if mirror {
            "begin attribute(color = 0,0,0 ; kdr = 0 ; ka = 0 ; phong = 1e6);
               polygon(vertices = 4; -50,-50,0 50,-50,0 50,50,0 -50,50,0); end"
        } else {
            ""
        };
        format!(
            "resolution(64, 64);
background(color = 0,0,0);
ambient(color = 0.1,0.1,0.1);
light(position = 30,20,{lz} ; color = 1,1,1);
camera(position = 0,0,6 ; at = 0,0,0 ; up = 0,1,0 ; angle = 25);
begin
  {m}
  begin attribute(color = 0.9,0.3,0.2 ; phong = 20 ; kdr = 0.7); sphere(center = -1,0.5,{z1} ; radius = 1.2); end
  begin attribute(color = 0.2,0.8,0.3); sphere(center = 1.6,-0.8,{z2} ; radius = 1.3); end
end",
            lz = 3.0 * sz,
            z1 = 8.0 * sz,
            z2 = 10.0 * sz,
        )
    };
    let mirrored = render(&world(&scene(true)));
    let reference = render(&world(&scene(false)));
    hard_common::save(&mirrored, "mirror");
    hard_common::save(&reference, "mirror_reference");
    let lit = reference
        .pixels
        .iter()
        .filter(|p| p[0].max(p[1]) > 0.2)
        .count();
    assert!(lit > 60, "the reference shows the balls ({lit} pixels)");
    assert_same_picture(&reference, &mirrored, "mirror");
}

/// Two coplanar overlapping polygons of different colours (and a third overlapping both):
/// every pixel of an overlap shows the same one (the earlier object), with every accelerator.
#[test]
fn coplanar_overlapping_polygons_resolve_consistently() {
    let w = world(
        "resolution(48, 48);
background(color = 0,0,0);
ambient(color = 1,1,1);
camera(position = 0.37,0.21,5 ; at = 0.37,0.21,0 ; up = 0,1,0 ; angle = 30);
begin
  begin attribute(color = 1,0,0 ; kdr = 0 ; ka = 1); polygon(vertices = 4; -2,-2,0 1,-2,0 1,1,0 -2,1,0); end
  begin attribute(color = 0,1,0 ; kdr = 0 ; ka = 1); polygon(vertices = 4; -1,-1,0 2,-1,0 2,2,0 -1,2,0); end
  begin attribute(color = 0,0,1 ; kdr = 0 ; ka = 1); polygon(vertices = 3; -3,-3,0 3,-3,0 0,3,0); end
end",
    );
    let films: Vec<_> = [AccelKind::Exhaustive, AccelKind::Octree, AccelKind::Bvh]
        .into_iter()
        .map(|k| render_with(&w, k))
        .collect();
    assert_eq!(films[0], films[1], "octree differs from exhaustive");
    assert_eq!(films[0], films[2], "BVH differs from exhaustive");
    let rgb = films[0].to_rgb8();
    let green = rgb.chunks(3).filter(|p| p[1] > 0 && p[0] == 0).count();
    let blue_only = rgb
        .chunks(3)
        .filter(|p| p[2] > 0 && p[0] == 0 && p[1] == 0)
        .count();
    let red = rgb.chunks(3).filter(|p| p[0] > 0).count();
    // Red (object 1) wins wherever it is; green only outside red; no pixel mixes.
    assert!(
        red > 300 && green > 100 && blue_only > 10,
        "{red} {green} {blue_only}"
    );
    let mixed = rgb
        .chunks(3)
        .filter(|p| p.iter().filter(|c| **c > 0).count() > 1)
        .count();
    assert_eq!(mixed, 0);
}
