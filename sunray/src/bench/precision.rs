//! `sunray bench precision`: the cost of precision. The renderer's own hot-path kernels
//! (watertight triangle test, stable sphere test, slab test of boxes;
//! [`crate::geometry::kernels`], written once by a macro and instantiated in f32 (glam `Vec3`)
//! and f64 (`DVec3`, what the renderer runs)), timed on the same rays and primitives, and run
//! on hard cases: the hit point's distance from the true surface, the smallest
//! self-intersection offset that stops secondary rays from re-hitting a sphere, and rays
//! through the shared edges of SPD tetra.

use std::fmt::Write;
use std::time::Instant;

use super::hot_path::{p32, p64};

fn v32(v: glam::DVec3) -> glam::Vec3 {
    v.as_vec3()
}

/// The corners of a world's triangles (SPD tetra is nothing else).
fn triangles(world: &yari::model::World) -> Vec<[glam::DVec3; 3]> {
    world
        .objects
        .iter()
        .filter_map(|o| match &o.shape {
            yari::model::Shape::Polygon { vertices } if vertices.len() == 3 => {
                Some([vertices[0], vertices[1], vertices[2]])
            }
            _ => None,
        })
        .collect()
}

/// Deterministic points and directions.
fn rng(seed: &mut u64) -> f64 {
    (crate::sampler::splitmix64(seed) >> 11) as f64 / (1u64 << 53) as f64
}

fn unit(seed: &mut u64) -> glam::DVec3 {
    let z = 2.0 * rng(seed) - 1.0;
    let phi = 2.0 * std::f64::consts::PI * rng(seed);
    let r = (1.0 - z * z).sqrt();
    glam::DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Runs the measurements and returns a Markdown report.
pub fn run() -> String {
    let mut out = String::new();
    speed(&mut out);
    surface_error(&mut out);
    offsets(&mut out);
    watertight(&mut out);
    out
}

/// The hot path's speed in f64 and f32, on the inputs of [`SpeedInputs::tetra`].
fn speed(out: &mut String) {
    let Some(inputs) = SpeedInputs::tetra() else {
        out.push_str("(could not generate tetra 6)\n");
        return;
    };
    let _ = writeln!(
        out,
        "### Speed of the hot path (one thread, best of 3)\n\n\
         | test | count | f64 (ns/test) | f32 (ns/test) | f32 speed-up | hits f64 / f32 |\n|---|---:|---:|---:|---:|---|"
    );
    for (name, count, a, b) in inputs.time_kernels() {
        let _ = writeln!(
            out,
            "| {name} | {count} | {:.2} | {:.2} | {:.2}x | {} / {} |",
            a.0 * 1e9 / count as f64,
            b.0 * 1e9 / count as f64,
            a.0 / b.0,
            a.1,
            b.1
        );
    }
}

/// What the speed test runs: SPD tetra 6's 4096 triangles, 2000 rays from its camera through
/// them, 1000 spheres and the triangles' 4096 boxes, in f64 and f32.
struct SpeedInputs {
    rays: Vec<(glam::DVec3, glam::DVec3)>,
    tris: Vec<[glam::DVec3; 3]>,
    spheres: Vec<(glam::DVec3, f64)>,
    boxes: Vec<(glam::DVec3, glam::DVec3)>,
    t32: Vec<[glam::Vec3; 3]>,
    s32: Vec<(glam::Vec3, f32)>,
    b32: Vec<(glam::Vec3, glam::Vec3)>,
}

impl SpeedInputs {
    /// The inputs, or None if tetra 6 cannot be generated.
    fn tetra() -> Option<SpeedInputs> {
        let world = super::spd_world(yari::spd::Database::Tetra, 6).ok()?;
        let tris = triangles(&world);
        let eye = world.camera.position;
        let mut seed = 42;
        let rays: Vec<(glam::DVec3, glam::DVec3)> = (0..2000)
            .map(|_| {
                let t = &tris[(rng(&mut seed) * tris.len() as f64) as usize % tris.len()];
                let target = (t[0] + t[1] + t[2]) / 3.0 + unit(&mut seed) * 0.02;
                (eye, (target - eye).normalize())
            })
            .collect();
        let spheres: Vec<(glam::DVec3, f64)> = (0..1000)
            .map(|_| {
                (
                    unit(&mut seed) * rng(&mut seed),
                    0.01 + 0.05 * rng(&mut seed),
                )
            })
            .collect();
        let t32: Vec<[glam::Vec3; 3]> = tris.iter().map(|t| t.map(v32)).collect();
        let s32: Vec<(glam::Vec3, f32)> = spheres.iter().map(|s| (v32(s.0), s.1 as f32)).collect();
        let boxes: Vec<(glam::DVec3, glam::DVec3)> = tris
            .iter()
            .map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
            .collect();
        let b32: Vec<(glam::Vec3, glam::Vec3)> =
            boxes.iter().map(|b| (v32(b.0), v32(b.1))).collect();
        Some(SpeedInputs {
            rays,
            tris,
            spheres,
            boxes,
            t32,
            s32,
            b32,
        })
    }

    /// Every ray against every triangle, sphere and box, in f64 and f32: per kernel its
    /// name, the number of tests, and (best seconds, hits) in f64 and in f32.
    #[allow(clippy::type_complexity)]
    fn time_kernels(&self) -> [(&'static str, usize, (f64, usize), (f64, usize)); 3] {
        let (rays, tris, spheres, boxes) = (&self.rays, &self.tris, &self.spheres, &self.boxes);
        let (t32, s32, b32) = (&self.t32, &self.s32, &self.b32);
        let tri64 = best_of_3(&mut || {
            let mut n = 0;
            for (o, d) in rays {
                let p = p64::pre(*o, *d);
                n += tris
                    .iter()
                    .filter(|t| p64::triangle(&p, t).is_some())
                    .count();
            }
            n
        });
        let tri32 = best_of_3(&mut || {
            let mut n = 0;
            for (o, d) in rays {
                let p = p32::pre(v32(*o), v32(*d));
                n += t32
                    .iter()
                    .filter(|t| p32::triangle(&p, t).is_some())
                    .count();
            }
            n
        });
        let sph64 = best_of_3(&mut || {
            let mut n = 0;
            for (o, d) in rays {
                n += spheres
                    .iter()
                    .filter(|s| p64::sphere(*o, *d, s.0, s.1).is_some())
                    .count();
            }
            n
        });
        let sph32 = best_of_3(&mut || {
            let mut n = 0;
            for (o, d) in rays {
                let (o, d) = (v32(*o), v32(*d));
                n += s32
                    .iter()
                    .filter(|s| p32::sphere(o, d, s.0, s.1).is_some())
                    .count();
            }
            n
        });
        let box64 = best_of_3(&mut || {
            let mut n = 0;
            for (o, d) in rays {
                let p = p64::pre(*o, *d);
                n += boxes.iter().filter(|b| p64::slab(&p, b.0, b.1)).count();
            }
            n
        });
        let box32 = best_of_3(&mut || {
            let mut n = 0;
            for (o, d) in rays {
                let p = p32::pre(v32(*o), v32(*d));
                n += b32.iter().filter(|b| p32::slab(&p, b.0, b.1)).count();
            }
            n
        });
        [
            ("triangle (Woop)", rays.len() * tris.len(), tri64, tri32),
            ("sphere (stable)", rays.len() * spheres.len(), sph64, sph32),
            ("box (slabs)", rays.len() * boxes.len(), box64, box32),
        ]
    }
}

/// The best time of three runs of `f`, in seconds, and what the last returned (its hits).
fn best_of_3(f: &mut dyn FnMut() -> usize) -> (f64, usize) {
    let mut best = f64::MAX;
    let mut hits = 0;
    for _ in 0..3 {
        let t = Instant::now();
        hits = std::hint::black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
    }
    (best, hits)
}

/// Relative distance of computed sphere hits from the true surface.
fn surface_error(out: &mut String) {
    let _ = writeln!(
        out,
        "\n### Hit point error on spheres (max over 2000 rays of ||p - c| - r| / r)\n\n\
         | case | f64 | f32 |\n|---|---:|---:|"
    );
    for (name, centre, radius) in cases() {
        let mut seed = 7;
        let (mut e64, mut e32): (f64, f64) = (0.0, 0.0);
        for _ in 0..2000 {
            let aim = centre + unit(&mut seed) * (0.8 * radius);
            let eye = aim + unit(&mut seed) * (10.0 * radius);
            let d = (aim - eye).normalize();
            if let Some(t) = p64::sphere(eye, d, centre, radius) {
                e64 = e64.max((((eye + d * t) - centre).length() - radius).abs() / radius);
            }
            if let Some(t) = p32::sphere(v32(eye), v32(d), v32(centre), radius as f32) {
                // Measured exactly, in f64, from the f32 hit point.
                let p = (v32(eye) + v32(d) * t).as_dvec3();
                e32 = e32.max(((p - centre).length() - radius).abs() / radius);
            }
        }
        let _ = writeln!(out, "| {name} | {e64:.1e} | {e32:.1e} |");
    }
}

fn cases() -> [(&'static str, glam::DVec3, f64); 4] {
    [
        ("r = 1 at the origin", glam::DVec3::ZERO, 1.0),
        ("r = 1e-4 at 1e-4", glam::DVec3::splat(1e-4), 1e-4),
        ("r = 1e4 at 3e4", glam::DVec3::new(3e4, -2e4, 1e4), 1e4),
        ("r = 1 at 1e5", glam::DVec3::new(1e5, 0.0, 0.0), 1.0),
    ]
}

/// The smallest offset (relative to the largest coordinate, as `geometry::offset_from`)
/// for which no reflected ray re-hits its sphere.
fn offsets(out: &mut String) {
    let _ = writeln!(
        out,
        "\n### Smallest safe self-intersection offset (relative to the coordinates' magnitude; \
         the renderer uses 1e-9 in f64)\n\n| case | f64 | f32 |\n|---|---:|---:|"
    );
    for (name, centre, radius) in cases() {
        let safe64 = (4..=40)
            .rev()
            .map(|k| 10f64.powi(-k))
            .find(|&eps| rehits(centre, radius, eps, false) == 0);
        let safe32 = (1..=20)
            .rev()
            .map(|k| 10f64.powi(-k))
            .find(|&eps| rehits(centre, radius, eps, true) == 0);
        let f = |x: Option<f64>| x.map_or("none".to_string(), |x| format!("{x:.0e}"));
        let _ = writeln!(out, "| {name} | {} | {} |", f(safe64), f(safe32));
    }
}

fn rehits(centre: glam::DVec3, radius: f64, eps: f64, single: bool) -> usize {
    let mut seed = 11;
    let mut n = 0;
    for _ in 0..2000 {
        let aim = centre + unit(&mut seed) * (0.8 * radius);
        let eye = aim + unit(&mut seed) * (10.0 * radius);
        let d = (aim - eye).normalize();
        if single {
            let (e, d, c, r) = (v32(eye), v32(d), v32(centre), radius as f32);
            let Some(t) = p32::sphere(e, d, c, r) else {
                continue;
            };
            let p = e + d * t;
            let nrm = (p - c).normalize();
            let refl = d - nrm * (2.0 * d.dot(nrm));
            let scale = p.abs().max_element().max(e.abs().max_element()) as f64;
            let o = p + nrm * (scale * eps) as f32;
            n += usize::from(p32::sphere(o, refl, c, r).is_some());
        } else {
            let Some(t) = p64::sphere(eye, d, centre, radius) else {
                continue;
            };
            let p = eye + d * t;
            let nrm = (p - centre).normalize();
            let refl = d - nrm * (2.0 * d.dot(nrm));
            let scale = p.abs().max_element().max(eye.abs().max_element());
            let o = p + nrm * (scale * eps);
            n += usize::from(p64::sphere(o, refl, centre, radius).is_some());
        }
    }
    n
}

/// Rays from outside each tetrahedron of SPD tetra 4 through its edge midpoints and vertices
/// (on the 1/32 grid) that miss all four of its faces.
fn watertight(out: &mut String) {
    let Ok(world) = super::spd_world(yari::spd::Database::Tetra, 4) else {
        return;
    };
    let tris = triangles(&world);
    let (mut rays, mut miss64, mut miss32) = (0, 0, 0);
    let mut seed = 5;
    for tet in tris.chunks(4) {
        let mut verts: Vec<glam::DVec3> = tet.iter().flatten().copied().collect();
        verts.sort_by(|a, b| {
            a.to_array()
                .partial_cmp(&b.to_array())
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        verts.dedup();
        let c = verts.iter().copied().sum::<glam::DVec3>() / verts.len() as f64;
        let mut targets = verts.clone();
        for i in 0..verts.len() {
            for j in i + 1..verts.len() {
                targets.push((verts[i] + verts[j]) / 2.0);
            }
        }
        for target in targets {
            for _ in 0..8 {
                // From a random point outside, through the target towards the inside.
                let from = target + ((target - c).normalize() + unit(&mut seed) * 0.3) * 3.0;
                let d = (c - from).normalize();
                let p = p64::pre(from, (target - from).normalize());
                let _ = d;
                rays += 1;
                miss64 += usize::from(tet.iter().all(|t| p64::triangle(&p, t).is_none()));
                let p = p32::pre(v32(from), v32((target - from).normalize()));
                miss32 += usize::from(tet.iter().all(|t| p32::triangle(&p, &t.map(v32)).is_none()));
            }
        }
    }
    let _ = writeln!(
        out,
        "\n### Watertightness: rays through SPD tetra 4's vertices and edge midpoints\n\n\
         | rays | misses f64 | misses f32 |\n|---:|---:|---:|\n| {rays} | {miss64} | {miss32} |"
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_precisions_agree_on_a_simple_hit() {
        let tri = [glam::DVec3::ZERO, glam::DVec3::X, glam::DVec3::Y];
        let p = p64::pre(glam::DVec3::new(0.2, 0.2, 1.0), -glam::DVec3::Z);
        assert_eq!(p64::triangle(&p, &tri), Some(1.0));
        let p = p32::pre(glam::Vec3::new(0.2, 0.2, 1.0), -glam::Vec3::Z);
        assert_eq!(p32::triangle(&p, &tri.map(v32)), Some(1.0));
        assert_eq!(
            p64::sphere(
                glam::DVec3::Z * 5.0,
                -glam::DVec3::Z,
                glam::DVec3::ZERO,
                1.0
            ),
            Some(4.0)
        );
    }

    #[test]
    fn f32_needs_a_far_larger_offset_far_from_the_origin() {
        let (c, r) = (glam::DVec3::new(1e5, 0.0, 0.0), 1.0);
        assert_eq!(
            rehits(c, r, 1e-9, false),
            0,
            "f64 with the renderer's offset"
        );
        assert!(
            rehits(c, r, 1e-9, true) > 0,
            "f32 with the same offset re-hits"
        );
    }
}
