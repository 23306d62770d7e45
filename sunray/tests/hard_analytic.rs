//! Analytic checks: a diffuse sphere under one point light against the closed form of the
//! Hall diffuse term; refraction through a glass sphere, a glass slab and a glass ball inside
//! a water sphere against Snell's law and Fresnel's equations; total internal reflection keeps light inside; bad input gives a diagnostic and
//! never a NaN pixel.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

mod hard_common;

use glam::DVec3;
use hard_common::{assert_finite, render, world};
use sunray::accel::{Accel, AccelOptions, Scratch};
use sunray::camera::Camera;
use sunray::geometry::Ray;
use sunray::sampler::SampleStream;
use sunray::scene::Scene;
use sunray::shading::hall::RayKind;
use sunray::shading::{TraceOptions, Tracer};
use sunray::stats::Counters;

/// Hall diffuse term, kdr C I (N.L), with nothing else: every pixel of the sphere equals the
/// closed form computed here independently of the renderer's shading code.
#[test]
fn diffuse_sphere_matches_the_closed_form() {
    let w = world(
        "resolution(65, 65);
background(color = 0,0,0);
ambient(color = 0,0,0);
light(position = 3,4,5 ; color = 0.9,0.9,0.9);
camera(position = 0,0,6 ; at = 0,0,0 ; up = 0,1,0 ; angle = 12);
begin attribute(color = 1,0.5,0.25 ; kdr = 1 ; ka = 0); sphere(center = 0,0,0 ; radius = 1); end",
    );
    let film = render(&w);
    let cam = Camera::new(&w.camera, 65, 65);
    let light = DVec3::new(3.0, 4.0, 5.0);
    let mut checked = 0;
    for y in 0..65u32 {
        for x in 0..65u32 {
            let d = cam.direction(x as f64 + 0.5, y as f64 + 0.5).normalize();
            let o = w.camera.position;
            // |o + t d|^2 = 1
            let b = o.dot(d);
            let disc = b * b - (o.length_squared() - 1.0);
            let got = film.pixels[(y * 65 + x) as usize];
            if disc < 1e-3 {
                if disc < -1e-3 {
                    assert_eq!(got, [0.0; 3], "background at ({x}, {y})");
                }
                continue;
            }
            let t = -b - disc.sqrt();
            let p = o + d * t;
            let n = p.normalize();
            let ndl = n.dot((light - p).normalize()).max(0.0);
            let want = [0.9 * ndl, 0.45 * ndl, 0.225 * ndl];
            for c in 0..3 {
                assert!(
                    (got[c] as f64 - want[c]).abs() < 1e-6,
                    "pixel ({x}, {y}) channel {c}: {} vs {}",
                    got[c],
                    want[c]
                );
            }
            checked += 1;
        }
    }
    assert!(checked > 1500, "{checked}");
}

struct Probe {
    scene: Scene,
    accel: Accel,
}

impl Probe {
    fn new(text: &str) -> Probe {
        let mut scene = Scene::new(world(text));
        let accel = Accel::build(&mut scene.prims, &AccelOptions::default());
        Probe { scene, accel }
    }
    fn trace(&self, ray: Ray, max_depth: u32) -> DVec3 {
        self.trace_counted(ray, max_depth).0
    }
    /// The ray's colour and what tracing it counted.
    fn trace_counted(&self, ray: Ray, max_depth: u32) -> (DVec3, Counters) {
        let mut scratch = Scratch::new(self.scene.prims.len(), true);
        let mut counters = Counters::default();
        let mut tracer = Tracer {
            scene: &self.scene,
            accel: &self.accel,
            opts: TraceOptions {
                max_depth,
                min_weight: 0.0,
                spawn_all: false,
            },
            scratch: &mut scratch,
            counters: &mut counters,
        };
        let mut rng = SampleStream::new(0, 0, 0);
        let c = tracer.trace(
            ray,
            RayKind::Eye,
            1,
            1.0,
            sunray::shading::Media::AIR,
            &mut rng,
        );
        (c, counters)
    }
}

/// Fresnel reflectance for unpolarised light, written out here independently.
fn fresnel(cos_i: f64, n1: f64, n2: f64) -> f64 {
    let sin_t = n1 / n2 * (1.0 - cos_i * cos_i).sqrt();
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = ((n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t)).powi(2);
    let rp = ((n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i)).powi(2);
    0.5 * (rs + rp)
}

/// The light and the detector of the refraction tests: a white diffuse plane z = -10 lit by a
/// light 1 above it at y = 8, so the brightness where a ray lands tells where that is.
const DETECTOR_LIGHT: &str = "light(position = 0,8,-9 ; color = 1,1,1);";
const DETECTOR_PLANE: &str = "begin attribute(color = 1,1,1 ; kdr = 1 ; ka = 0); polygon(vertices = 4; -90,-90,-10 90,-90,-10 90,90,-10 -90,90,-10); end";

/// N.L on the detector plane at height `y` (the light is 1 above the plane at y = 8).
fn detector(y: f64) -> f64 {
    let r = (y - 8.0).abs();
    1.0 / (1.0 + r * r).sqrt()
}

/// A ray parallel to the axis at height b enters a glass sphere (n = 1.5) at incidence
/// asin(b), bends to asin(b / n), leaves deviated by 2 (theta_i - theta_t) and lands on a
/// diffuse detector plane lit from 1 above it (off to the side, so the light itself is not
/// seen through the glass), whose brightness tells where the ray landed.
/// The traced colour must equal (1 - F_in)(1 - F_out) times the detector's N.L there.
#[test]
fn refraction_through_a_sphere_follows_snell_and_fresnel() {
    let probe = Probe::new(&format!(
        "background(color = 0,0,0);
ambient(color = 0,0,0);
{DETECTOR_LIGHT}
begin
  begin attribute(color = 0,0,0 ; kdr = 1 ; kdt = 0 ; ka = 0 ; refract = 1.5 ; phong = 1e7); sphere(center = 0,0,0 ; radius = 1); end
  {DETECTOR_PLANE}
end"
    ));
    let n = 1.5_f64;
    for b in [0.05_f64, 0.2, 0.35, 0.5, 0.6] {
        let ti = b.asin();
        let tt = (b / n).asin();
        let dev = 2.0 * (ti - tt);
        // Exit point: the chord inside subtends pi - 2 theta_t at the centre; the entry point
        // is at angle ti from +z in the y-z plane.
        let entry_angle = ti; // measured from +z towards +y
        let exit_angle = entry_angle + (std::f64::consts::PI - 2.0 * tt);
        let exit = DVec3::new(0.0, exit_angle.sin(), exit_angle.cos());
        let dir = DVec3::new(0.0, -dev.sin(), -dev.cos());
        let t = (-10.0 - exit.z) / dir.z;
        let land = exit + dir * t;
        let ndl = detector(land.y);
        let f_in = fresnel(ti.cos(), 1.0, n);
        let f_out = fresnel(tt.cos(), n, 1.0);
        let want = (1.0 - f_in) * (1.0 - f_out) * ndl;
        let got = probe.trace(Ray::new(DVec3::new(0.0, b, 5.0), -DVec3::Z), 3);
        assert!(
            (got.x - want).abs() < 1e-9,
            "b = {b}: traced {} vs Snell/Fresnel {want} (lands at y = {})",
            got.x,
            land.y
        );
    }
}

/// A glass slab (a closed box of six polygons, n = 1.5, 2 thick) bends a ray by Snell's law
/// on the way in and back on the way out: it leaves parallel to itself, shifted sideways by
/// 2 (tan theta_i - tan theta_t) cos theta_i, and lands on the lit detector plane of the
/// sphere test. With one face removed the polygons are thin sheets and the ray goes straight.
#[test]
fn refraction_through_a_slab_follows_snell_and_fresnel() {
    let glass =
        "attribute(color = 0,0,0 ; kdr = 1 ; kdt = 0 ; ka = 0 ; refract = 1.5 ; phong = 1e7)";
    // Faces wound with their normals out of the box [-50, 50] x [-50, 50] x [-1, 1].
    let faces = [
        "-50,-50,-1 -50,50,-1 50,50,-1 50,-50,-1",
        "-50,-50,1 50,-50,1 50,50,1 -50,50,1",
        "-50,-50,-1 50,-50,-1 50,-50,1 -50,-50,1",
        "-50,50,-1 -50,50,1 50,50,1 50,50,-1",
        "-50,-50,-1 -50,-50,1 -50,50,1 -50,50,-1",
        "50,-50,-1 50,50,-1 50,50,1 50,-50,1",
    ];
    let scene = |faces: &[&str]| {
        let polys: String = faces
            .iter()
            .map(|f| format!("polygon(vertices = 4; {f});\n"))
            .collect();
        Probe::new(&format!(
            "background(color = 0,0,0);
ambient(color = 0,0,0);
{DETECTOR_LIGHT}
begin
  begin {glass}; {polys} end
  {DETECTOR_PLANE}
end"
        ))
    };
    let slab = scene(&faces);
    let sheets = scene(&faces[..5]);
    let n = 1.5_f64;
    for ti in [0.1_f64, 0.3, 0.5, 0.7] {
        let tt = (ti.sin() / n).asin();
        // From (0, y0, 5) heading down and towards -y; it meets z = 1 at y = 0.
        let y0 = 4.0 * ti.tan();
        let dir = DVec3::new(0.0, -ti.sin(), -ti.cos());
        let ray = Ray::new(DVec3::new(0.0, y0, 5.0), dir);
        let exit_y = -2.0 * tt.tan();
        let bent = exit_y - 9.0 * ti.tan();
        let f_in = fresnel(ti.cos(), 1.0, n);
        let f_out = fresnel(tt.cos(), n, 1.0);
        let want = (1.0 - f_in) * (1.0 - f_out) * detector(bent);
        let got = slab.trace(ray, 3);
        assert!(
            (got.x - want).abs() < 1e-9,
            "theta {ti}: traced {} vs Snell/Fresnel {want} (lands at y = {bent})",
            got.x
        );
        // Snell's law makes the in and out Fresnel terms equal for a slab.
        assert!((f_in - f_out).abs() < 1e-12);
        let straight = -11.0 * ti.tan();
        let want = (1.0 - f_in).powi(2) * detector(straight);
        let got = sheets.trace(ray, 3);
        assert!(
            (got.x - want).abs() < 1e-9,
            "theta {ti}, thin sheets: traced {} vs straight {want}",
            got.x
        );
    }
}

/// A glass ball (n = 1.5, radius 1) inside a water sphere (n = 1.33, radius 2), both centred
/// at the origin: a ray crosses four interfaces, air to water, water to glass, glass to water
/// and water to air, bending by Snell's law at each with the indices on both sides (not via
/// air), and lands on the lit detector plane. The path is computed here in the plane of the
/// ray, independently of the renderer.
#[test]
fn nested_media_refract_between_their_own_indices() {
    let probe = Probe::new(&format!(
        "background(color = 0,0,0);
ambient(color = 0,0,0);
{DETECTOR_LIGHT}
begin
  begin attribute(color = 0,0,0 ; kdr = 1 ; kdt = 0 ; ka = 0 ; refract = 1.33 ; phong = 1e7); sphere(center = 0,0,0 ; radius = 2); end
  begin attribute(color = 0,0,0 ; kdr = 1 ; kdt = 0 ; ka = 0 ; refract = 1.5 ; phong = 1e7); sphere(center = 0,0,0 ; radius = 1); end
  {DETECTOR_PLANE}
end"
    ));
    // (y, z) plane: refract d at a sphere point p (outward normal p / |p|) from n1 into n2.
    let bend = |d: DVec3, p: DVec3, n1: f64, n2: f64| {
        let mut n = p.normalize();
        if d.dot(n) > 0.0 {
            n = -n;
        }
        let cos_i = -d.dot(n);
        let eta = n1 / n2;
        let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
        assert!(k > 0.0, "no total internal reflection on these paths");
        let t = d * eta + n * (eta * cos_i - k.sqrt());
        (t.normalize(), fresnel(cos_i, n1, n2))
    };
    // Where a ray from o along unit d meets the sphere of radius r: nearest t > 1e-9.
    let meet = |o: DVec3, d: DVec3, r: f64| {
        let b = o.dot(d);
        let c = o.length_squared() - r * r;
        let s = (b * b - c).sqrt();
        let t = if -b - s > 1e-9 { -b - s } else { -b + s };
        o + d * t
    };
    for b in [0.1_f64, 0.4, 0.7] {
        let o = DVec3::new(0.0, b, 5.0);
        let mut d = -DVec3::Z;
        let mut weight = 1.0;
        let mut p = o;
        for (r, n1, n2) in [
            (2.0, 1.0, 1.33),
            (1.0, 1.33, 1.5),
            (1.0, 1.5, 1.33),
            (2.0, 1.33, 1.0),
        ] {
            p = meet(p, d, r);
            let (nd, f) = bend(d, p, n1, n2);
            d = nd;
            weight *= 1.0 - f;
        }
        let land = p + d * ((-10.0 - p.z) / d.z);
        let want = weight * detector(land.y);
        let got = probe.trace(Ray::new(o, -DVec3::Z), 6);
        assert!(
            (got.x - want).abs() < 1e-9,
            "b = {b}: traced {} vs four Snell refractions {want} (lands at y = {})",
            got.x,
            land.y
        );
    }
}

/// Inside a lossless glass sphere, a ray beyond the critical angle is totally reflected and
/// never leaks out (white background, so any leak shows); below it, light gets out.
#[test]
fn total_internal_reflection_traps_the_ray() {
    let probe = Probe::new(
        "background(color = 1,1,1);
ambient(color = 0,0,0);
begin attribute(color = 1,1,1 ; kdr = 0 ; kdt = 0 ; ka = 0 ; refract = 1.5); sphere(center = 0,0,0 ; radius = 1); end",
    );
    // sin(incidence) = 0.9 > 1/1.5: every bounce inside a sphere has the same incidence.
    let (trapped, n) = probe.trace_counted(Ray::new(DVec3::new(0.0, 0.9, 0.0), DVec3::X), 30);
    assert_eq!(trapped, DVec3::ZERO, "TIR leaked {trapped}");
    // Every hit with depth left (depths 1 to 29) is a total internal reflection, counted
    // whatever the weights (Haines's "refract rays" counts them).
    assert_eq!((n.refracted, n.total_internal), (0, 29), "{n:?}");
    let (escapes, n) = probe.trace_counted(Ray::new(DVec3::new(0.0, 0.3, 0.0), DVec3::X), 30);
    assert!(escapes.x > 0.95 && escapes.x <= 1.0 + 1e-12, "{escapes}");
    assert_eq!(n.total_internal, 0, "{n:?}");
    assert!(n.refracted > 0, "{n:?}");
}

/// NaN, infinity, a zero `up` and `at == position` are diagnosed by the compiler.
#[test]
fn bad_numbers_and_views_are_diagnosed() {
    let cases = [
        (
            "camera(position = 0,0,5 ; at = 0,0,0 ; up = 0,0,0 ; angle = 20); begin end",
            "`up` must not be the zero vector",
        ),
        (
            "camera(position = 1,2,3 ; at = 1,2,3 ; up = 0,1,0 ; angle = 20); begin end",
            "`at` must differ",
        ),
        (
            "camera(position = 0,0,1e999 ; at = 0,0,0 ; up = 0,1,0 ; angle = 20); begin end",
            "infinity",
        ),
        (
            "begin sphere(center = 0,1e400,0 ; radius = 1); end",
            "infinity",
        ),
        ("begin sphere(center = 0,0,0 ; radius = 0); end", "radius"),
        (
            "light(position = 0,0,1e999 ; color = 1,1,1); begin end",
            "infinity",
        ),
        ("background(color = 1e309,0,0); begin end", "infinity"),
    ];
    for (text, what) in cases {
        let r = yari::load::load_str(
            "bad.yari",
            text,
            yari::load::InputKind::Yari,
            &yari::colour::ColourTable::builtin(),
        );
        let Err(e) = r else {
            panic!("{text}: accepted");
        };
        let msg = e.to_string();
        assert!(
            msg.contains(what),
            "{text}: diagnostic {msg:?} does not mention {what}"
        );
    }
}

/// A model built without the compiler (as a .model file or a program could) with NaN and
/// infinite numbers and a degenerate view still renders finite pixels only.
#[test]
fn non_finite_model_renders_no_nan() {
    let mut w = world(
        "resolution(24, 16);
light(position = 3,4,5 ; color = 1,1,1);
camera(position = 0,0,6 ; at = 0,0,0 ; up = 0,1,0 ; angle = 20);
begin sphere(center = 0,0,0 ; radius = 1); sphere(center = 2,0,0 ; radius = 1);
  polygon(vertices = 3; 0,0,0 1,0,0 0,1,0); end",
    );
    if let yari::model::Shape::Sphere { center, .. } = &mut w.objects[0].shape {
        center.x = f64::NAN;
    }
    if let yari::model::Shape::Polygon { vertices } = &mut w.objects[2].shape {
        vertices[1].y = f64::INFINITY;
    }
    w.lights.push(yari::model::Light {
        position: DVec3::new(f64::NAN, 0.0, 0.0),
        color: DVec3::ONE,
        radius: 0.0,
    });
    for (at, up) in [
        (w.camera.position, DVec3::Y),
        (DVec3::ZERO, DVec3::ZERO),
        (DVec3::ZERO, DVec3::Z),
    ] {
        let mut v = w.clone();
        v.camera.at = at;
        v.camera.up = up;
        let scene = Scene::new(v.clone());
        assert_eq!(
            scene.dropped.len(),
            2,
            "the NaN sphere and infinite polygon are dropped"
        );
        assert_finite(&render(&v));
    }
}
