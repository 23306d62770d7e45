//! A compiled world written as POV-Ray 3.7 scene description language (SDL), so the same
//! scene can be rendered by POV-Ray and the two renderers compared side by side
//! (`sunray convert IN -o OUT.pov`, bench/pov/run.sh).
//!
//! The mapping keeps the geometry and the ray tree exact and the shading close:
//! - camera: explicit `location`/`direction`/`right`/`up` vectors giving SunRay's pixel grid
//!   (YARI's half angle spans the image centre to the centre of the top row) for the world's
//!   resolution; render with `+W` `+H` equal to it;
//! - lights: point `light_source`s, no distance fall-off (as in the Hall model); an area
//!   light's radius becomes an `area_light` of 5x5 jittered samples;
//! - surfaces: `ambient ka` (times `ambient_light`), `diffuse kdr`, `specular ksr` with
//!   `roughness 1/phong` (Blinn's (N.H)^phong), `reflection ksr` (with `fresnel` when the
//!   surface transmits), `transmit kst` and `interior { ior refract }`;
//! - triangles are gathered per surface into one `mesh` (POV-Ray's fast path), larger
//!   polygons become `polygon`s, smooth polygons `smooth_triangle`s of the mesh (cut and
//!   with normals as the renderer has them, [`crate::polygon`]), ellipsoids a unit `sphere` under a `matrix`, quadrics a
//!   `quadric` clipped by `plane`s;
//! - `global_settings`: `max_trace_level 5` and `adc_bailout 0.001` (SunRay's defaults),
//!   `assumed_gamma 1` (both write linear values).
//!
//! Not carried over: solid textures (the base colour is written), motion blur and depth of
//! field (noted in a comment).

use crate::model::{Object, Quadric, Shape, Surface, World};
use glam::DVec3;
use std::fmt::Write;

/// Formats a vector as POV's `<x, y, z>`.
fn v(p: DVec3) -> String {
    format!("<{}, {}, {}>", p.x, p.y, p.z)
}

/// The world as POV-Ray SDL for an image of the world's own resolution.
pub fn write_pov(world: &World) -> String {
    let mut out = String::new();
    let [w, h] = world.resolution;
    let (w, h) = (w.max(1), h.max(1));
    let _ = writeln!(
        out,
        "// Written by `sunray convert` (yari::pov); render with +W{w} +H{h}."
    );
    let _ = writeln!(out, "#version 3.7;");
    let a = world.ambient;
    let _ = writeln!(
        out,
        "global_settings {{ assumed_gamma 1.0 max_trace_level 5 adc_bailout 0.001 ambient_light rgb {} }}",
        v(a)
    );
    let _ = writeln!(out, "background {{ color rgb {} }}", v(world.background));
    write_camera(&mut out, world, w, h);
    write_lights(&mut out, world);
    write_surfaces(&mut out, world);
    // Triangles, gathered per surface into meshes.
    let mut meshes: Vec<String> = vec![String::new(); world.surfaces.len().max(1)];
    for obj in &world.objects {
        write_object(&mut out, &mut meshes, world, obj);
    }
    for (k, body) in meshes.iter().enumerate() {
        if body.is_empty() {
            continue;
        }
        let (tex, int) = surface_ref(world, k as u32);
        let _ = writeln!(out, "mesh {{\n{body}  {tex}{int}\n}}");
    }
    out
}

/// The lights as `light_source`s (an area light with 5x5 jittered samples).
fn write_lights(out: &mut String, world: &World) {
    for l in &world.lights {
        if l.radius > 0.0 && world.features.area_lights {
            let _ = writeln!(
                out,
                "light_source {{ {} color rgb {} area_light <{d}, 0, 0>, <0, {d}, 0>, 5, 5 jitter circular orient }}",
                v(l.position),
                v(l.color),
                d = 2.0 * l.radius
            );
        } else {
            let _ = writeln!(
                out,
                "light_source {{ {} color rgb {} }}",
                v(l.position),
                v(l.color)
            );
        }
    }
}

/// Every surface as `#declare SurfaceI` (its texture) and, if it transmits, `InteriorI`.
fn write_surfaces(out: &mut String, world: &World) {
    for (i, s) in world.surfaces.iter().enumerate() {
        let _ = writeln!(out, "#declare Surface{i} = {};", texture(s));
        if s.kst() > 0.0 {
            let _ = writeln!(
                out,
                "#declare Interior{i} = interior {{ ior {} }};",
                s.refract
            );
        }
    }
}

/// The texture and interior (empty unless it transmits) an object of surface `i` refers to.
fn surface_ref(world: &World, i: u32) -> (String, String) {
    let i = (i as usize).min(world.surfaces.len().saturating_sub(1));
    let tex = if world.surfaces.is_empty() {
        "texture { pigment { color rgb 1 } }".to_string()
    } else {
        format!("texture {{ Surface{i} }}")
    };
    let int = match world.surfaces.get(i) {
        Some(s) if s.kst() > 0.0 => format!(" interior {{ Interior{i} }}"),
        _ => String::new(),
    };
    (tex, int)
}

/// One object: written to `out`, or, a triangle or smooth polygon, to its surface's mesh.
fn write_object(out: &mut String, meshes: &mut [String], world: &World, obj: &Object) {
    let (tex, int) = surface_ref(world, obj.surface);
    let moving = if obj.motion != DVec3::ZERO {
        " // motion blur not carried over"
    } else {
        ""
    };
    match &obj.shape {
        Shape::Sphere { center, radius } => {
            let _ = writeln!(
                out,
                "sphere {{ {}, {radius} {tex}{int} }}{moving}",
                v(*center)
            );
        }
        Shape::Ellipsoid { to_world } => {
            let m = to_world.matrix3;
            let t = to_world.translation;
            let _ = writeln!(
                out,
                "sphere {{ 0, 1 matrix <{}, {}, {}, {}, {}, {}, {}, {}, {}, {}, {}, {}> {tex}{int} }}{moving}",
                m.x_axis.x, m.x_axis.y, m.x_axis.z, m.y_axis.x, m.y_axis.y, m.y_axis.z,
                m.z_axis.x, m.z_axis.y, m.z_axis.z, t.x, t.y, t.z
            );
        }
        Shape::Polygon { vertices } if vertices.len() == 3 => {
            let k = (obj.surface as usize).min(meshes.len() - 1);
            let _ = writeln!(
                meshes[k],
                "  triangle {{ {}, {}, {} }}",
                v(vertices[0]),
                v(vertices[1]),
                v(vertices[2])
            );
        }
        Shape::SmoothPolygon { vertices, normals } => {
            let k = (obj.surface as usize).min(meshes.len() - 1);
            smooth_triangles(&mut meshes[k], vertices, normals);
        }
        Shape::Polygon { vertices } => {
            let pts: Vec<String> = vertices
                .iter()
                .chain(vertices.first())
                .map(|p| v(*p))
                .collect();
            let _ = writeln!(
                out,
                "polygon {{ {}, {} {tex}{int} }}{moving}",
                pts.len(),
                pts.join(", ")
            );
        }
        Shape::Quadric(q) => write_quadric(out, q, &tex, &int, moving),
    }
}

/// A quadric as POV's `quadric`, clipped by its half-spaces' `plane`s.
fn write_quadric(out: &mut String, q: &Quadric, tex: &str, int: &str, moving: &str) {
    let [a, b, c, d, e, f, g, hh, i, j] = q.q;
    let _ = write!(
        out,
        "quadric {{ <{a}, {e}, {hh}>, <{}, {}, {}>, <{}, {}, {}>, {j}",
        2.0 * b,
        2.0 * c,
        2.0 * f,
        2.0 * d,
        2.0 * g,
        2.0 * i
    );
    if !q.clip.is_empty() {
        out.push_str(" clipped_by {");
        for hs in &q.clip {
            let _ = write!(out, " plane {{ {}, {} }}", v(hs.normal), hs.offset);
        }
        out.push_str(" }");
    }
    let _ = writeln!(out, " {tex}{int} }}{moving}");
}

/// A smooth polygon as `smooth_triangle`s of a mesh: cut as the renderer cuts it
/// ([`crate::polygon::triangulate`]), each corner with its vertex normal as the renderer
/// shades with it ([`crate::polygon::shading_normals`]). A degenerate polygon (which the
/// renderer drops too) writes nothing.
fn smooth_triangles(mesh: &mut String, vertices: &[DVec3], normals: &[DVec3]) {
    let Ok(t) = crate::polygon::triangulate(vertices) else {
        return;
    };
    let Some(normals) = crate::polygon::shading_normals(normals, t.normal) else {
        return;
    };
    for tri in &t.triangles {
        let corner = |k: usize| format!("{}, {}", v(vertices[tri[k]]), v(normals[tri[k]]));
        let _ = writeln!(
            mesh,
            "  smooth_triangle {{ {}, {}, {} }}",
            corner(0),
            corner(1),
            corner(2)
        );
    }
}

/// SunRay's camera (see `sunray::camera`) as explicit POV vectors: the view frame both
/// make from the world's camera ([`crate::model::Camera::frame`]).
fn write_camera(out: &mut String, world: &World, w: u32, h: u32) {
    let c = &world.camera;
    let frame = c.frame(h);
    let _ = writeln!(
        out,
        "camera {{ perspective location {} direction {} right {} up {} }}",
        v(c.position),
        v(frame.forward),
        v(frame.right * (frame.pixel * w as f64)),
        v(frame.up * (frame.pixel * h as f64))
    );
    if c.aperture > 0.0 {
        let _ = writeln!(
            out,
            "// depth of field (aperture {}) not carried over",
            c.aperture
        );
    }
}

/// A surface as a POV texture. POV scales a transmitting surface's own light by
/// (1 - transmit), so the diffuse and ambient factors are divided by it to keep SunRay's.
fn texture(s: &Surface) -> String {
    let kst = s.kst();
    let ksr = s.ksr();
    let keep = if kst < 1.0 { 1.0 / (1.0 - kst) } else { 1.0 };
    let mut t = format!(
        "texture {{ pigment {{ color rgb {}{} }} finish {{ ambient {} diffuse {}",
        v(s.color),
        if kst > 0.0 {
            format!(" transmit {kst}")
        } else {
            String::new()
        },
        s.ka * keep,
        s.kdr * keep,
    );
    if ksr > 0.0 {
        let _ = write!(t, " specular {ksr} roughness {}", 1.0 / s.phong.max(1e-3));
        if kst > 0.0 {
            let _ = write!(t, " reflection {{ 0, {ksr} fresnel on }} conserve_energy");
        } else {
            let _ = write!(t, " reflection {ksr}");
        }
    }
    t.push_str(" } }");
    if s.texture.is_some() {
        t.push_str(" /* solid texture not carried over */");
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::ColourTable;

    fn world(text: &str) -> World {
        let src = crate::span::Source::new("t.yari", text);
        let scene = crate::parse::parse(&src).unwrap();
        crate::compile::compile(&scene, &ColourTable::builtin())
            .unwrap()
            .world
    }

    #[test]
    fn writes_camera_lights_and_every_shape() {
        let w = world(
            "resolution(64, 32); background(color = 0.1,0.2,0.3);
             light(position = 1,2,3 ; color = 1,1,1);
             camera(position = 0,0,5 ; at = 0,0,0 ; up = 0,1,0 ; angle = 30);
             begin
               attribute(color = 1,0,0 ; kdr = 0.7 ; phong = 20);
               sphere(center = 0,0,0 ; radius = 1);
               polygon(vertices = 3; 0,0,0 1,0,0 0,1,0);
               polygon(vertices = 4; 0,0,0 1,0,0 1,1,0 0,1,0);
               begin attribute(kdt = 0.2 ; refract = 1.5); sphere(center = 2,0,0 ; radius = 0.5); end
               begin scale(2,1,1); sphere(center = 0,0,0 ; radius = 1); end
               quadric(1 0 0 0 1 0 0 0 0 -1 ; clip = -1,-1,-1 1,1,1);
             end",
        );
        let pov = write_pov(&w);
        for want in [
            "#version 3.7;",
            "background { color rgb <0.1, 0.2, 0.3> }",
            "light_source { <1, 2, 3> color rgb <1, 1, 1> }",
            "mesh {",
            "triangle { <0, 0, 0>, <1, 0, 0>, <0, 1, 0> }",
            "polygon { 5,",
            "sphere { <0, 0, 0>, 1 texture",
            "interior { Interior",
            "ior 1.5",
            "matrix <2, 0, 0,",
            "quadric { <1, 1, 0>",
            "clipped_by { plane",
            "specular 0.30000000000000004 roughness 0.05 reflection 0.30000000000000004",
        ] {
            assert!(pov.contains(want), "missing {want:?} in\n{pov}");
        }
        // The camera's vertical extent: up has length pixel * height, pixel = 2 tan(30)/31.
        let pixel = 2.0 * 30f64.to_radians().tan() / 31.0;
        let up_len = pixel * 32.0;
        assert!(pov.contains(&format!("up <0, {}, 0>", up_len)), "{pov}");
    }

    #[test]
    fn smooth_polygons_become_smooth_triangles_cut_as_the_renderer_cuts_them() {
        let w = world(
            "begin
               polygon(vertices = 3; 0,0,0 1,0,0 0,1,0; normals = 0,0,2 0,0,1 0,0,1);
               polygon(vertices = 4; 0,0,1 1,0,1 1,1,1 0,1,1; normals = 0,0,-1 1,0,-1 1,1,-1 0,1,-1);
               polygon(vertices = 3; 0,0,0 1,0,0 2,0,0; normals = 0,0,1 0,0,1 0,0,1);
             end",
        );
        let pov = write_pov(&w);
        let smooth: Vec<&str> = pov
            .lines()
            .filter(|l| l.contains("smooth_triangle"))
            .collect();
        // The triangle, then the square fanned from its first corner; the degenerate one
        // (which the renderer drops) is not written. The square's normals point against its
        // plane normal (+z), so they are turned over, and every normal has unit length.
        assert_eq!(
            smooth,
            vec![
                "  smooth_triangle { <0, 0, 0>, <0, 0, 1>, <1, 0, 0>, <0, 0, 1>, <0, 1, 0>, <0, 0, 1> }",
                "  smooth_triangle { <0, 0, 1>, <-0, -0, 1>, <1, 0, 1>, <-0.7071067811865475, -0, 0.7071067811865475>, <1, 1, 1>, <-0.5773502691896258, -0.5773502691896258, 0.5773502691896258> }",
                "  smooth_triangle { <0, 0, 1>, <-0, -0, 1>, <1, 1, 1>, <-0.5773502691896258, -0.5773502691896258, 0.5773502691896258>, <0, 1, 1>, <-0, -0.7071067811865475, 0.7071067811865475> }",
            ],
            "{pov}"
        );
        assert_eq!(pov.matches("mesh {").count(), 1);
    }
}
