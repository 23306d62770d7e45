//! `modeler show`: the project as a readable listing, or one object or skeleton in full.

use crate::error::ModelError;
use crate::project::{Color, Object, Primitive, Project, Surface, Transform};
use crate::skeleton::{Skeleton, SkeletonKind};
use std::fmt::Write;

fn v(a: &[f64; 3]) -> String {
    format!("{},{},{}", a[0], a[1], a[2])
}

fn color(c: &Color) -> String {
    match c {
        Color::Named(n) => n.clone(),
        Color::Rgb(a) => v(a),
    }
}

pub fn surface(s: &Surface) -> String {
    let mut parts = Vec::new();
    if let Some(c) = &s.color {
        parts.push(format!("color={}", color(c)));
    }
    for (name, val) in [
        ("kdr", s.kdr),
        ("kdt", s.kdt),
        ("ka", s.ka),
        ("phong", s.phong),
        ("refract", s.refract),
    ] {
        if let Some(x) = val {
            parts.push(format!("{name}={x}"));
        }
    }
    if let Some(t) = &s.texture {
        parts.push(format!("texture={} {} {}", t.id, v(&t.color), v(&t.scale)));
    }
    for (name, val) in [
        ("gloss", s.gloss),
        ("translucency", s.translucency),
        ("transmissivity", s.transmissivity),
    ] {
        if let Some(x) = val {
            parts.push(format!("{name}={x}"));
        }
    }
    if s.texture_space.is_some() {
        parts.push("texture_space=...".into());
    }
    if parts.is_empty() {
        "defaults".into()
    } else {
        parts.join(" ")
    }
}

fn transform(t: &Transform) -> String {
    match t {
        Transform::Translate(a) => format!("translate({})", v(a)),
        Transform::Scale(a) => format!("scale({})", v(a)),
        Transform::Rotate(a) => format!("rotate({})", v(a)),
        Transform::Motion(a) => format!("motion({})", v(a)),
        Transform::Matrix(_) => "transform(...)".into(),
    }
}

fn summary(o: &Object) -> String {
    let mut s = if o.is_group() {
        format!(
            "composite of {} ({} primitives)",
            o.children.len(),
            o.primitive_count()
        )
    } else {
        let (mut spheres, mut polygons, mut quadrics, mut meshes) = (0, 0, 0, 0);
        for p in &o.primitives {
            match p {
                Primitive::Sphere { .. } => spheres += 1,
                Primitive::Polygon { .. } => polygons += 1,
                Primitive::Quadric { .. } => quadrics += 1,
                Primitive::Mesh { .. } => meshes += 1,
            }
        }
        let kinds: Vec<String> = [
            (spheres, "sphere"),
            (polygons, "polygon"),
            (quadrics, "quadric"),
            (meshes, "mesh"),
        ]
        .iter()
        .filter(|(n, _)| *n > 0)
        .map(|(n, k)| {
            let plural = match (*n, *k) {
                (1, _) => "",
                (_, "mesh") => "es",
                _ => "s",
            };
            format!("{n} {k}{plural}")
        })
        .collect();
        if kinds.is_empty() {
            "empty".into()
        } else {
            kinds.join(", ")
        }
    };
    if let Some(surf) = &o.surface {
        let _ = write!(s, "; surface {}", surface(surf));
    }
    if !o.transforms.is_empty() {
        let ts: Vec<String> = o.transforms.iter().map(transform).collect();
        let _ = write!(s, "; {}", ts.join(" "));
    }
    s
}

fn skeleton_line(s: &Skeleton) -> String {
    let kind = match s.kind {
        SkeletonKind::Points => "points".to_string(),
        SkeletonKind::Lines => "lines".to_string(),
        SkeletonKind::Bezier => format!("bezier degree {} smoothness {}", s.degree, s.smoothness),
    };
    format!(
        "{}: plane {} at {}, {}{}, {} points",
        s.name,
        s.plane.name(),
        s.depth,
        kind,
        if s.closed { ", closed" } else { "" },
        s.points.len()
    )
}

/// The listing of the whole project, or of one named object or skeleton.
pub fn show(p: &Project, name: Option<&str>) -> Result<String, ModelError> {
    let mut out = String::new();
    if let Some(name) = name {
        if let Some(s) = p.skeletons.iter().find(|s| s.name == name) {
            let _ = writeln!(out, "skeleton {}", skeleton_line(s));
            for (i, pt) in s.points.iter().enumerate() {
                let _ = writeln!(out, "  {:>3}  {},{}", i + 1, pt[0], pt[1]);
            }
            return Ok(out);
        }
        let o = p.object(name)?;
        o.walk(
            &mut |o, depth| {
                let _ = writeln!(out, "{}{}: {}", "  ".repeat(depth), o.name, summary(o));
            },
            0,
        );
        return Ok(out);
    }
    let st = &p.settings;
    if let Some([w, h]) = st.resolution {
        let _ = writeln!(out, "resolution {w}x{h}");
    }
    if let Some(n) = st.samples {
        let _ = writeln!(out, "samples {n}");
    }
    if let Some(c) = &st.camera {
        let _ = writeln!(
            out,
            "camera at {} looking at {} up {} half angle {}",
            v(&c.position),
            v(&c.at),
            v(&c.up),
            c.angle
        );
    }
    if let Some(vw) = &st.view {
        let _ = writeln!(
            out,
            "view from {} at {} (preview only)",
            v(&vw.from),
            v(&vw.at)
        );
    }
    if let Some(c) = &st.background {
        let _ = writeln!(out, "background {}", color(c));
    }
    if let Some(c) = &st.ambient {
        let _ = writeln!(out, "ambient {}", color(c));
    }
    for l in &st.lights {
        let _ = writeln!(
            out,
            "light {} at {} colour {}",
            l.name,
            v(&l.position),
            color(&l.color)
        );
    }
    let _ = writeln!(out, "objects ({}):", p.objects.len());
    for o in &p.objects {
        o.walk(
            &mut |o, depth| {
                let _ = writeln!(out, "  {}{}: {}", "  ".repeat(depth), o.name, summary(o));
            },
            0,
        );
    }
    let _ = writeln!(out, "skeletons ({}):", p.skeletons.len());
    for s in &p.skeletons {
        let _ = writeln!(out, "  {}", skeleton_line(s));
    }
    Ok(out)
}
