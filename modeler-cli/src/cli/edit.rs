//! The editing commands applied to a project in memory. A command either succeeds or
//! returns an error naming what was wrong; the caller saves only after success, so a failed
//! command never reaches the project file.

use super::commands::*;
use crate::error::{check_name, ModelError};
use crate::mesh::{dedup_points, scale_of};
use crate::project::{Clip, Color, Light, Object, Primitive, Project, Transform, View};
use crate::skeleton::{Skeleton, MAX_SMOOTHNESS};
use crate::sweep;
use glam::DVec3;
use yari::colour::ColourTable;

/// Checks that a named colour exists in the table the renderer will use.
pub fn check_color(c: &Color, table: &ColourTable, arg: &str) -> Result<(), ModelError> {
    if let Color::Named(n) = c {
        if table.get(n).is_none() {
            let hint = table
                .suggest(n)
                .map(|s| format!(" (did you mean `{s}`?)"))
                .unwrap_or_default();
            return Err(ModelError::bad_arg(
                arg,
                format!("unknown colour name `{n}`{hint}; give a known name or r,g,b"),
            ));
        }
    }
    Ok(())
}

pub fn skeleton<'a>(p: &'a Project, name: &str) -> Result<&'a Skeleton, ModelError> {
    p.skeletons.iter().find(|s| s.name == name).ok_or_else(|| {
        ModelError::not_found(
            "skeleton",
            name,
            p.skeletons.iter().map(|s| s.name.as_str()),
        )
    })
}

fn skeleton_mut<'a>(p: &'a mut Project, name: &str) -> Result<&'a mut Skeleton, ModelError> {
    skeleton(p, name)?;
    p.skeletons
        .iter_mut()
        .find(|s| s.name == name)
        .ok_or_else(|| ModelError::not_found("skeleton", name, std::iter::empty()))
}

fn check_smoothness(arg: &str, n: u32) -> Result<(), ModelError> {
    if n == 0 || n > MAX_SMOOTHNESS {
        return Err(ModelError::bad_arg(
            arg,
            format!("smoothness must be 1..={MAX_SMOOTHNESS} (got {n})"),
        ));
    }
    Ok(())
}

/// A 1-based point index as a 0-based one, checked against `len` (+1 when inserting).
fn point_index(s: &Skeleton, index: usize, inserting: bool) -> Result<usize, ModelError> {
    let max = s.points.len() + usize::from(inserting);
    if index == 0 || index > max {
        return Err(ModelError::bad_arg(
            "INDEX",
            format!(
                "skeleton `{}` has {} points; give 1..={max} (points count from 1)",
                s.name,
                s.points.len()
            ),
        ));
    }
    Ok(index - 1)
}

pub fn skeleton_cmd(p: &mut Project, cmd: SkeletonCmd) -> Result<(), ModelError> {
    match cmd {
        SkeletonCmd::New(a) => {
            check_name(&a.name)?;
            if p.skeletons.iter().any(|s| s.name == a.name) {
                return Err(ModelError::Duplicate {
                    kind: "skeleton",
                    name: a.name,
                });
            }
            check_smoothness("--smoothness", a.smoothness)?;
            let mut s = Skeleton::new(&a.name, a.plane, a.kind);
            s.closed = a.closed;
            s.depth = a.depth;
            s.degree = a.degree;
            s.smoothness = a.smoothness;
            s.points = a.points;
            p.skeletons.push(s);
        }
        SkeletonCmd::Add(a) => {
            let s = skeleton_mut(p, &a.name)?;
            let at = match a.at {
                Some(i) => point_index(s, i, true)?,
                None => s.points.len(),
            };
            s.points.splice(at..at, a.points);
        }
        SkeletonCmd::Move(a) => {
            let s = skeleton_mut(p, &a.name)?;
            let i = point_index(s, a.index, false)?;
            s.points[i] = a.point;
        }
        SkeletonCmd::Remove(a) => {
            let s = skeleton_mut(p, &a.name)?;
            let i = point_index(s, a.index, false)?;
            s.points.remove(i);
        }
        SkeletonCmd::Smooth(a) => {
            check_smoothness("SMOOTHNESS", a.smoothness)?;
            skeleton_mut(p, &a.name)?.smoothness = a.smoothness;
        }
        SkeletonCmd::Set(a) => {
            let s = skeleton_mut(p, &a.name)?;
            if let Some(k) = a.kind {
                s.kind = k;
            }
            if let Some(c) = a.closed {
                s.closed = c;
            }
            if let Some(d) = a.depth {
                s.depth = d;
            }
            if let Some(d) = a.degree {
                s.degree = d;
            }
            if let Some(pl) = a.plane {
                s.plane = pl;
            }
        }
        SkeletonCmd::Delete(a) => {
            skeleton(p, &a.name)?;
            p.skeletons.retain(|s| s.name != a.name);
        }
    }
    Ok(())
}

fn part(name: String, primitives: Vec<Primitive>) -> Object {
    Object {
        name,
        primitives,
        ..Object::default()
    }
}

pub fn add_cmd(p: &mut Project, cmd: AddCmd) -> Result<(), ModelError> {
    match cmd {
        AddCmd::Sphere(a) => {
            p.check_new_object_name(&a.name)?;
            let (center, radius) = match (&a.from, a.center, a.radius) {
                (Some(from), _, _) => {
                    let s = skeleton(p, from)?;
                    let pts = s.points_3d();
                    if pts.len() < 2 {
                        return Err(ModelError::skeleton(
                            from,
                            "a sphere needs two points: the centre and a point on the sphere",
                        ));
                    }
                    (pts[0].to_array(), pts[0].distance(pts[1]))
                }
                (None, Some(c), Some(r)) => (c, r),
                _ => {
                    return Err(ModelError::bad_arg(
                        "--center",
                        "give --from SKELETON, or --center and --radius",
                    ))
                }
            };
            if !(radius.is_finite() && radius > 0.0) {
                return Err(ModelError::bad_arg(
                    "--radius",
                    format!("the radius must be positive (got {radius})"),
                ));
            }
            p.add_object(part(a.name, vec![Primitive::Sphere { center, radius }]))
        }
        AddCmd::Polygon(a) => {
            p.check_new_object_name(&a.name)?;
            let vertices: Vec<DVec3> = match &a.from {
                Some(from) => {
                    if let Some(n) = a.smoothness {
                        check_smoothness("--smoothness", n)?;
                    }
                    let pts = skeleton(p, from)?.curve_3d(a.smoothness)?;
                    dedup_points(&pts, true, 1e-12 * scale_of(&pts))
                }
                None => a.vertices.iter().map(|v| DVec3::from_array(*v)).collect(),
            };
            if vertices.len() < 3 {
                return Err(ModelError::bad_arg(
                    a.from.as_deref().unwrap_or("--vertices"),
                    format!(
                        "a polygon needs at least three distinct vertices (has {})",
                        vertices.len()
                    ),
                ));
            }
            let vertices = vertices.iter().map(|v| v.to_array()).collect();
            p.add_object(part(
                a.name,
                vec![Primitive::Polygon {
                    vertices,
                    normals: None,
                }],
            ))
        }
        AddCmd::Quadric(a) => {
            p.check_new_object_name(&a.name)?;
            let mut coeffs = [0.0; 10];
            coeffs.copy_from_slice(&a.coeffs);
            if coeffs.iter().all(|c| *c == 0.0) {
                return Err(ModelError::bad_arg(
                    "--coeffs",
                    "all ten coefficients are zero",
                ));
            }
            let mut clip = Vec::new();
            if let [a0, b0] = a.bounds[..] {
                let (lo, hi) = (
                    DVec3::from_array(a0).min(DVec3::from_array(b0)),
                    DVec3::from_array(a0).max(DVec3::from_array(b0)),
                );
                if lo.cmpeq(hi).any() {
                    return Err(ModelError::bad_arg(
                        "--box",
                        "the box is flat; MIN and MAX must differ in x, y and z",
                    ));
                }
                clip.push(Clip::Box {
                    min: lo.to_array(),
                    max: hi.to_array(),
                });
            }
            clip.extend(a.plane.iter().map(|(normal, offset)| Clip::Plane {
                normal: *normal,
                offset: *offset,
            }));
            p.add_object(part(a.name, vec![Primitive::Quadric { coeffs, clip }]))
        }
    }
}

pub fn revolve(p: &mut Project, a: RevolveArgs) -> Result<(), ModelError> {
    p.check_new_object_name(&a.name)?;
    if let Some(n) = a.smoothness {
        check_smoothness("--smoothness", n)?;
    }
    let mesh = sweep::revolve(
        skeleton(p, &a.profile)?,
        a.axis.index(),
        a.step,
        a.smoothness,
        a.smooth.then_some(a.crease),
    )?;
    p.add_object(part(a.name, mesh.to_primitives()))
}

pub fn extrude(p: &mut Project, a: ExtrudeArgs) -> Result<(), ModelError> {
    p.check_new_object_name(&a.name)?;
    if let Some(n) = a.smoothness {
        check_smoothness("--smoothness", n)?;
    }
    let s = skeleton(p, &a.outline)?;
    let by = match (a.by, a.depth) {
        (Some(v), _) => DVec3::from_array(v),
        (None, Some(d)) => {
            let mut v = DVec3::ZERO;
            v[s.plane.axes().2] = d;
            v
        }
        (None, None) => {
            return Err(ModelError::bad_arg(
                "--by",
                "give --by x,y,z or --depth LENGTH",
            ))
        }
    };
    let mesh = sweep::extrude(s, by, !a.no_caps, a.centred, a.smoothness)?;
    p.add_object(part(a.name, mesh.to_primitives()))
}

fn unit(arg: &str, v: Option<f64>, lo: f64, hi: f64) -> Result<Option<f64>, ModelError> {
    match v {
        Some(x) if !(x.is_finite() && x >= lo && x <= hi) => Err(ModelError::bad_arg(
            arg,
            format!("must be between {lo} and {hi} (got {x})"),
        )),
        _ => Ok(v),
    }
}

pub fn surface(p: &mut Project, a: SurfaceArgs, table: &ColourTable) -> Result<(), ModelError> {
    if let Some(c) = &a.color {
        check_color(c, table, "--color")?;
    }
    let kdr = unit("--kdr", a.kdr, 0.0, 1.0)?;
    let kdt = unit("--kdt", a.kdt, 0.0, 1.0)?;
    let ka = unit("--ka", a.ka, 0.0, f64::MAX)?;
    let phong = unit("--phong", a.phong, 0.0, f64::MAX)?;
    let refract = unit("--refract", a.refract, 1e-6, f64::MAX)?;
    let any = a.color.is_some()
        || [kdr, kdt, ka, phong, refract].iter().any(Option::is_some)
        || a.texture.is_some();
    if !any && !a.inherit {
        return Err(ModelError::bad_arg("surface", "nothing to set: give --color, --kdr, --kdt, --ka, --phong, --refract, --texture or --inherit"));
    }
    let obj = p.object_mut(&a.name)?;
    if a.inherit {
        obj.surface = None;
    }
    if !any {
        return Ok(());
    }
    let s = obj.surface.get_or_insert_with(Default::default);
    s.color = a.color.or(s.color.take());
    s.kdr = kdr.or(s.kdr);
    s.kdt = kdt.or(s.kdt);
    s.ka = ka.or(s.ka);
    s.phong = phong.or(s.phong);
    s.refract = refract.or(s.refract);
    if let Some(t) = a.texture {
        s.texture = t.0;
    }
    Ok(())
}

pub fn transform(
    p: &mut Project,
    name: &str,
    t: Transform,
    about: Option<[f64; 3]>,
) -> Result<(), ModelError> {
    p.transform_object(name, t, about)
}

fn check_view(
    arg: &str,
    from: [f64; 3],
    at: [f64; 3],
    up: [f64; 3],
    angle: f64,
) -> Result<(), ModelError> {
    let dir = DVec3::from_array(at) - DVec3::from_array(from);
    if dir.length() == 0.0 {
        return Err(ModelError::bad_arg(
            arg,
            "the position and the point looked at are the same",
        ));
    }
    if dir.cross(DVec3::from_array(up)).length()
        <= 1e-12 * dir.length() * DVec3::from_array(up).length()
    {
        return Err(ModelError::bad_arg(
            "--up",
            "the up vector is zero or along the viewing direction",
        ));
    }
    if !(angle > 0.0 && angle < 90.0) {
        return Err(ModelError::bad_arg(
            "--angle",
            format!("the half angle must be between 0 and 90 degrees (got {angle})"),
        ));
    }
    Ok(())
}

pub fn camera(p: &mut Project, a: CameraArgs) -> Result<(), ModelError> {
    let c = p.settings.camera.get_or_insert_with(Default::default);
    c.position = a.position.unwrap_or(c.position);
    c.at = a.at.unwrap_or(c.at);
    c.up = a.up.unwrap_or(c.up);
    c.angle = a.angle.unwrap_or(c.angle);
    check_view("--position", c.position, c.at, c.up, c.angle)
}

pub fn view(p: &mut Project, a: ViewArgs) -> Result<(), ModelError> {
    if a.camera {
        p.settings.view = None;
        return Ok(());
    }
    let cam = p.settings.camera.clone().unwrap_or_default();
    let v = p.settings.view.get_or_insert(View {
        from: cam.position,
        at: cam.at,
        up: cam.up,
        angle: cam.angle,
    });
    v.from = a.from.unwrap_or(v.from);
    v.at = a.at.unwrap_or(v.at);
    v.up = a.up.unwrap_or(v.up);
    v.angle = a.angle.unwrap_or(v.angle);
    check_view("--from", v.from, v.at, v.up, v.angle)
}

fn light_mut<'a>(p: &'a mut Project, name: &str) -> Result<&'a mut Light, ModelError> {
    let names: Vec<String> = p.settings.lights.iter().map(|l| l.name.clone()).collect();
    p.settings
        .lights
        .iter_mut()
        .find(|l| l.name == name)
        .ok_or_else(|| ModelError::not_found("light", name, names.iter().map(String::as_str)))
}

pub fn light(p: &mut Project, cmd: LightCmd, table: &ColourTable) -> Result<(), ModelError> {
    match cmd {
        LightCmd::Add(a) => {
            check_name(&a.name)?;
            if p.settings.lights.iter().any(|l| l.name == a.name) {
                return Err(ModelError::Duplicate {
                    kind: "light",
                    name: a.name,
                });
            }
            check_color(&a.color, table, "--color")?;
            if let Some(r) = a.radius {
                unit("--radius", Some(r), 0.0, f64::MAX)?;
            }
            p.settings.lights.push(Light {
                name: a.name,
                position: a.position,
                color: a.color,
                radius: a.radius,
            });
        }
        LightCmd::Move(a) => light_mut(p, &a.name)?.position = a.position,
        LightCmd::Color(a) => {
            check_color(&a.color, table, "COLOR")?;
            light_mut(p, &a.name)?.color = a.color;
        }
        LightCmd::Delete(a) => {
            light_mut(p, &a.name)?;
            p.settings.lights.retain(|l| l.name != a.name);
        }
    }
    Ok(())
}
