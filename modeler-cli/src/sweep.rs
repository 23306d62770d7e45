//! The two sweeping grouping operations of thesis section 2.4.2: a surface of revolution
//! (a profile swept about a principal axis in steps of some degrees) and an extrusion (an
//! outline pulled along a vector, with caps). Both build a closed, outward-facing [`Mesh`].
//!
//! Revolve: the profile lies in a plane that contains the axis, on one side of it. Profile
//! points on the axis become single vertices (the faces next to them are triangles); an end
//! of the profile off the axis is closed by a flat cap, so the solid is always closed. A
//! closed profile sweeps a ring (torus-like) with no caps. With a crease angle
//! ([`revolve_smooth`], `revolve --smooth`) the side faces carry vertex normals
//! ([`smooth`]).
//!
//! Extrude: the outline is taken as closed; the side faces join each outline edge to its
//! copy moved by the vector, and the caps (bottom: the outline, top: the moved outline)
//! close the ends unless caps are turned off.

use crate::error::ModelError;
use crate::mesh::{dedup_points, scale_of, Mesh};
use crate::skeleton::Skeleton;
use glam::DVec3;

/// The most segments around the axis (a step of 0.5 degrees).
pub const MAX_SEGMENTS: usize = 720;

/// Sweeps `profile` (a skeleton whose plane contains `axis`) about that axis through 360
/// degrees in steps of about `step_deg` (rounded so that the steps divide 360). With
/// `crease_deg` the side faces get vertex normals for smooth shading (see [`smooth`]): smooth
/// around the axis, and along the profile at every corner that turns by at most `crease_deg`
/// degrees.
pub fn revolve(
    profile: &Skeleton,
    axis: usize,
    step_deg: f64,
    smoothness: Option<u32>,
    crease_deg: Option<f64>,
) -> Result<Mesh, ModelError> {
    let name = &profile.name;
    check_crease(crease_deg)?;
    let (pa, pb, normal_axis) = profile.plane.axes();
    if axis == normal_axis {
        return Err(ModelError::skeleton(
            name,
            format!(
                "lies in plane {} which does not contain the {} axis; draw the profile in a plane through it",
                profile.plane.name(),
                axis_name(axis)
            ),
        ));
    }
    let segments = segments_of(step_deg)?;
    let radial_axis = if pa == axis { pb } else { pa };
    let (rh, side) = radius_height(profile, axis, radial_axis, smoothness)?;
    let mut a = DVec3::ZERO;
    a[axis] = 1.0;
    // The direction in which radius is measured at angle 0 is the side the profile is on.
    let mut e1 = DVec3::ZERO;
    e1[radial_axis] = side;
    let frame = smooth::Frame {
        axis: a,
        e1,
        e2: a.cross(e1),
    };
    let mut mesh = Mesh::default();
    let ring = rings(&mut mesh, &rh, &frame, segments);
    let point_normals = crease_deg.map(|c| smooth::profile_normals(&rh, profile.closed, c));
    let swept = Swept {
        rh: &rh,
        closed: profile.closed,
        ring: &ring,
        segments,
    };
    swept.side_faces(&mut mesh, &frame, point_normals.as_deref());
    let n = rh.len();
    if !profile.closed {
        if rh[0].0 > 0.0 {
            mesh.faces.push(ring[0].iter().rev().copied().collect());
        }
        if rh[n - 1].0 > 0.0 {
            mesh.faces.push(ring[n - 1].clone());
        }
    }
    if mesh.faces.is_empty() {
        return Err(ModelError::skeleton(name, "sweeps no surface"));
    }
    if point_normals.is_some() {
        // The caps are flat.
        mesh.normals.resize(mesh.faces.len(), None);
    }
    mesh.orient_outward();
    smooth::orient_normals(&mut mesh);
    Ok(mesh)
}

/// Refuses a crease angle outside 0 to 180 degrees.
fn check_crease(crease_deg: Option<f64>) -> Result<(), ModelError> {
    if let Some(c) = crease_deg {
        if !(0.0..=180.0).contains(&c) {
            return Err(ModelError::bad_arg(
                "--crease",
                format!("the crease angle must be 0 to 180 degrees (got {c})"),
            ));
        }
    }
    Ok(())
}

/// The number of steps around the axis for a step of about `step_deg` degrees (rounded so
/// that the steps divide 360): 3 to [`MAX_SEGMENTS`].
fn segments_of(step_deg: f64) -> Result<usize, ModelError> {
    if !(step_deg.is_finite() && step_deg > 0.0) {
        return Err(ModelError::bad_arg(
            "--step",
            format!("the step must be a positive number of degrees (got {step_deg})"),
        ));
    }
    let segments = (360.0 / step_deg).round();
    if !(3.0..=MAX_SEGMENTS as f64).contains(&segments) {
        return Err(ModelError::bad_arg(
            "--step",
            format!("{step_deg} degrees gives {segments} steps around the axis; use 3..={MAX_SEGMENTS} (step 0.5 to 120)"),
        ));
    }
    Ok(segments as usize)
}

/// The profile's distinct points as (radius, height): the radius along `radial_axis`, made
/// non-negative (exactly 0 on the axis), the height along `axis`; and the side of the axis
/// the profile is on (+1 or -1 along `radial_axis`). A profile must stay on one side, off
/// the axis somewhere, with two distinct points at least.
fn radius_height(
    profile: &Skeleton,
    axis: usize,
    radial_axis: usize,
    smoothness: Option<u32>,
) -> Result<(Vec<(f64, f64)>, f64), ModelError> {
    let name = &profile.name;
    let raw = profile.curve_3d(smoothness)?;
    let eps = 1e-9 * scale_of(&raw);
    let pts = dedup_points(&raw, profile.closed, eps);
    let mut rh: Vec<(f64, f64)> = pts.iter().map(|p| (p[radial_axis], p[axis])).collect();
    let negative = rh.iter().any(|&(r, _)| r < -eps);
    let positive = rh.iter().any(|&(r, _)| r > eps);
    if negative && positive {
        return Err(ModelError::skeleton(
            name,
            format!(
                "crosses the {} axis; keep the profile on one side",
                axis_name(axis)
            ),
        ));
    }
    if !positive && !negative {
        return Err(ModelError::skeleton(
            name,
            "lies on the axis; it sweeps no surface",
        ));
    }
    for p in &mut rh {
        p.0 = if p.0.abs() <= eps { 0.0 } else { p.0.abs() };
    }
    if rh.len() < 2 {
        return Err(ModelError::skeleton(
            name,
            "needs at least two distinct points",
        ));
    }
    Ok((rh, if negative { -1.0 } else { 1.0 }))
}

/// Angle of step `k` of `segments` around the axis, in radians.
fn step_angle(k: usize, segments: usize) -> f64 {
    (k as f64) * std::f64::consts::TAU / segments as f64
}

/// Adds the vertices of the swept profile to `mesh`: `ring[i][k]` is the vertex of profile
/// point i at step k, one shared vertex for a point on the axis.
fn rings(
    mesh: &mut Mesh,
    rh: &[(f64, f64)],
    frame: &smooth::Frame,
    segments: usize,
) -> Vec<Vec<usize>> {
    let mut ring: Vec<Vec<usize>> = Vec::with_capacity(rh.len());
    for &(r, h) in rh {
        if r == 0.0 {
            mesh.vertices.push(frame.axis * h);
            ring.push(vec![mesh.vertices.len() - 1; segments]);
        } else {
            let mut idx = Vec::with_capacity(segments);
            for k in 0..segments {
                let theta = step_angle(k, segments);
                // Exact zeros at multiples of 90 degrees keep the output clean.
                let (s, c) = theta.sin_cos();
                let (s, c) = (
                    if s.abs() < 1e-15 { 0.0 } else { s },
                    if c.abs() < 1e-15 { 0.0 } else { c },
                );
                mesh.vertices
                    .push(frame.axis * h + frame.e1 * (r * c) + frame.e2 * (r * s));
                idx.push(mesh.vertices.len() - 1);
            }
            ring.push(idx);
        }
    }
    ring
}

/// The swept profile, as [`rings`] laid out its vertices.
struct Swept<'a> {
    /// The profile's points as (radius, height).
    rh: &'a [(f64, f64)],
    /// Whether the last point joins the first.
    closed: bool,
    /// `ring[i][k]`: the vertex of profile point i at step k.
    ring: &'a [Vec<usize>],
    /// Steps around the axis.
    segments: usize,
}

impl Swept<'_> {
    /// Adds the side faces, one per profile edge and step (a triangle next to the axis, else
    /// a quadrilateral), with their corner normals from `point_normals` (the profile's normals,
    /// [`smooth::profile_normals`]) if given.
    fn side_faces(
        &self,
        mesh: &mut Mesh,
        frame: &smooth::Frame,
        point_normals: Option<&[smooth::PointNormals]>,
    ) {
        let (rh, ring, segments) = (self.rh, self.ring, self.segments);
        let n = rh.len();
        let edges = if self.closed { n } else { n - 1 };
        let angle = |k: usize| step_angle(k, segments);
        for i in 0..edges {
            let j = (i + 1) % n;
            let (ri, rj) = (rh[i].0, rh[j].0);
            if ri == 0.0 && rj == 0.0 {
                continue;
            }
            for k in 0..segments {
                let k1 = (k + 1) % segments;
                // Corners as (profile point, which of its normals, angle); a pole corner takes
                // the face's middle angle.
                let mid = (angle(k) + angle(k + 1)) / 2.0;
                let (face, corners) = if ri == 0.0 {
                    let c = vec![(i, 1, mid), (j, 0, angle(k1)), (j, 0, angle(k))];
                    (vec![ring[i][k], ring[j][k1], ring[j][k]], c)
                } else if rj == 0.0 {
                    let c = vec![(i, 1, angle(k)), (i, 1, angle(k1)), (j, 0, mid)];
                    (vec![ring[i][k], ring[i][k1], ring[j][k]], c)
                } else {
                    let c = vec![
                        (i, 1, angle(k)),
                        (i, 1, angle(k1)),
                        (j, 0, angle(k1)),
                        (j, 0, angle(k)),
                    ];
                    (vec![ring[i][k], ring[i][k1], ring[j][k1], ring[j][k]], c)
                };
                mesh.faces.push(face);
                if let Some(pn) = point_normals {
                    let normals: Option<Vec<DVec3>> = corners
                        .iter()
                        .map(|&(p, side, theta)| pn[p][side].map(|m| frame.normal(m, theta)))
                        .collect();
                    mesh.normals.push(normals);
                }
            }
        }
    }
}

/// Extrudes the closed outline of `outline` along `by`, with caps at both ends unless
/// `caps` is false. With `centred`, the solid reaches from -by/2 to +by/2 about the outline.
pub fn extrude(
    outline: &Skeleton,
    by: DVec3,
    caps: bool,
    centred: bool,
    smoothness: Option<u32>,
) -> Result<Mesh, ModelError> {
    let name = &outline.name;
    let raw = outline.curve_3d(smoothness)?;
    let eps = 1e-9 * scale_of(&raw);
    let mut base = dedup_points(&raw, true, eps);
    if base.len() < 3 {
        return Err(ModelError::skeleton(
            name,
            format!(
                "an outline needs at least three distinct points (has {})",
                base.len()
            ),
        ));
    }
    if !by.is_finite() || by.length() == 0.0 {
        return Err(ModelError::bad_arg(
            "--by",
            "the extrusion vector must be finite and not zero",
        ));
    }
    let (_, _, normal_axis) = outline.plane.axes();
    if by[normal_axis].abs() <= 1e-12 * by.length() {
        return Err(ModelError::bad_arg(
            "--by",
            format!(
                "{by} lies in the outline's plane {}; it must leave the plane",
                outline.plane.name()
            ),
        ));
    }
    if centred {
        for p in &mut base {
            *p -= by * 0.5;
        }
    }
    let n = base.len();
    let mut mesh = Mesh::default();
    mesh.vertices.extend(base.iter().copied());
    mesh.vertices.extend(base.iter().map(|p| *p + by));
    for i in 0..n {
        let j = (i + 1) % n;
        mesh.faces.push(vec![i, j, n + j, n + i]);
    }
    if caps {
        mesh.faces.push((0..n).rev().collect());
        mesh.faces.push((n..2 * n).collect());
    }
    mesh.orient_outward();
    Ok(mesh)
}

/// The name of axis 0, 1 or 2.
pub fn axis_name(axis: usize) -> &'static str {
    ["x", "y", "z"].get(axis).copied().unwrap_or("?")
}

pub mod smooth;
#[cfg(test)]
mod tests;
