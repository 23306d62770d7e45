//! Previews like the editor's four views (thesis section 2.4.1): top, perspective, front and
//! side in one PNG, either as a wireframe or flat shaded with hidden surfaces removed by a
//! z-buffer. The project is compiled with the YARI compiler first, so the preview shows what
//! the renderer will get; skeletons, lights and the camera are drawn over it.
//!
//! Layout of the image (third-angle projection, as on a drawing board):
//!
//! ```text
//!   TOP    | PERSPECTIVE
//!   -------+------------
//!   FRONT  | SIDE
//! ```
//!
//! # Layout
//! - this file: options, composing the views, PNG output.
//! - `views`: the projections.
//! - `shapes`: the world as polygons and quadrics.
//! - `raster`: the z-buffer rasterizer (faces).
//! - `pen`: antialiased lines and marks (tiny-skia) drawn over the faces.
//! - `font`: the view labels in the embedded DejaVu Sans.

mod font;
pub mod pen;
pub mod raster;
pub mod shapes;
pub mod views;

use crate::error::ModelError;
use crate::project::Project;
use glam::DVec3;
use pen::Pen;
use raster::Canvas;
use shapes::{bounds_of, Drawables};
use views::View;

const BACKGROUND: [f32; 3] = [0.12, 0.12, 0.13];
const SKELETON: [f32; 3] = [1.0, 0.85, 0.1];
const CONTROL: [f32; 3] = [0.55, 0.45, 0.1];
const LIGHT: [f32; 3] = [1.0, 1.0, 1.0];
const CAMERA: [f32; 3] = [0.2, 0.9, 0.9];
const LABEL: [f32; 3] = [0.8, 0.8, 0.8];
const GAP: usize = 2;
/// Stroke widths in pixels: model edges and axes, skeletons and the camera's line of sight.
const THIN: f32 = 1.0;
const BOLD: f32 = 1.6;

/// How surfaces are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    /// Polygon edges (and contour slices of quadrics), everything visible.
    Wire,
    /// Flat-shaded faces, hidden surfaces removed.
    Flat,
}

/// How a preview is drawn.
#[derive(Clone, Debug)]
pub struct Options {
    /// Width and height of each of the four views, in pixels.
    pub size: usize,
    /// Wireframe or flat-shaded faces.
    pub style: Style,
}

/// What is drawn over the geometry: skeletons, lights and the camera.
#[derive(Default)]
pub struct Overlay {
    /// Polylines (closed or not) in the skeleton colour, and control polygons.
    pub curves: Vec<(Vec<DVec3>, bool)>,
    /// Bézier control polygons, drawn dimmer than the curves.
    pub controls: Vec<Vec<DVec3>>,
    /// Skeleton points of `points` skeletons, drawn as crosses.
    pub points: Vec<DVec3>,
    /// Light positions, drawn as white crosses.
    pub lights: Vec<DVec3>,
    /// The camera's location and the point it looks at, joined by its line of sight.
    pub camera: Option<(DVec3, DVec3)>,
}

impl Overlay {
    /// The skeletons, lights and camera of project `p`.
    pub fn of_project(p: &Project) -> Overlay {
        let mut o = Overlay::default();
        for s in &p.skeletons {
            let pts = s.points_3d();
            match s.kind {
                crate::skeleton::SkeletonKind::Points => o.points.extend(pts),
                crate::skeleton::SkeletonKind::Lines => o.curves.push((pts, s.closed)),
                crate::skeleton::SkeletonKind::Bezier => {
                    // An unfinished chain (wrong point count) shows its control polygon only.
                    if let Ok(c) = s.curve_3d(None) {
                        o.curves.push((c, s.closed));
                    }
                    o.points.extend(pts.iter().copied());
                    o.controls.push(pts);
                }
            }
        }
        o.lights = p
            .settings
            .lights
            .iter()
            .map(|l| DVec3::from_array(l.position))
            .collect();
        o.camera = p
            .settings
            .camera
            .as_ref()
            .map(|c| (DVec3::from_array(c.position), DVec3::from_array(c.at)));
        o
    }
}

/// Compiles the project, its relative mesh files found in `folder` (the project file's,
/// [`crate::mesh_files`]), and draws its four views.
pub fn render_project(
    project: &Project,
    folder: &std::path::Path,
    opts: &Options,
) -> Result<image::RgbImage, ModelError> {
    let table =
        yari::colour::ColourTable::for_run(None).map_err(|e| ModelError::Yari(e.to_string()))?;
    let scene = crate::export::to_scene(project);
    let world = match yari::compile::compile_in(&scene, &table, folder) {
        Ok(c) => c.world,
        Err(d) => {
            let msgs: Vec<String> = d.errors().map(|e| e.message.clone()).collect();
            return Err(ModelError::Yari(format!(
                "the scene does not compile: {}",
                msgs.join("; ")
            )));
        }
    };
    Ok(render_world(
        &world,
        &Overlay::of_project(project),
        project.settings.view.as_ref(),
        opts,
    ))
}

/// Draws the four views of a compiled world. `view` is the perspective viewpoint
/// (the project's view location); without it the world's camera is used.
pub fn render_world(
    world: &yari::model::World,
    overlay: &Overlay,
    view: Option<&crate::project::View>,
    opts: &Options,
) -> image::RgbImage {
    let size = opts.size.max(16);
    let drawables = Drawables::from_world(world);
    let overlay_pts = overlay
        .curves
        .iter()
        .flat_map(|(c, _)| c.iter().copied())
        .chain(overlay.points.iter().copied());
    let (lo, hi) = match (drawables.bounds(), bounds_of(overlay_pts)) {
        (Some((a, b)), Some((c, d))) => (a.min(c), b.max(d)),
        (Some(b), None) | (None, Some(b)) => b,
        (None, None) => (DVec3::splat(-1.0), DVec3::splat(1.0)),
    };
    let [front, top, side] = views::ortho_views(lo, hi, size);
    let (eye, at, up, angle) = match view {
        Some(v) => (
            DVec3::from_array(v.from),
            DVec3::from_array(v.at),
            DVec3::from_array(v.up),
            v.angle,
        ),
        None => (
            world.camera.position,
            world.camera.at,
            world.camera.up,
            world.camera.half_angle_deg,
        ),
    };
    let near = 1e-3 * (hi - lo).length().max(1e-6);
    let persp = views::perspective_view(eye, at, up, angle, size, near);
    let mut out = image::RgbImage::from_pixel(
        (2 * size + 3 * GAP) as u32,
        (2 * size + 3 * GAP) as u32,
        image::Rgb([70, 70, 74]),
    );
    let cells = [
        (Some(top), 0, 0),
        (persp, 1, 0),
        (Some(front), 0, 1),
        (Some(side), 1, 1),
    ];
    for (v, cx, cy) in cells {
        let pen = match &v {
            Some(v) => draw_view(v, &drawables, overlay, (lo, hi), opts.style, view.is_none()),
            None => Pen::new(size, size, BACKGROUND),
        };
        let Some(pen) = pen else { continue };
        let (ox, oy) = (GAP + cx * (size + GAP), GAP + cy * (size + GAP));
        for (i, c) in pen.rgb().enumerate() {
            let (x, y) = (i % size, i / size);
            out.put_pixel((ox + x) as u32, (oy + y) as u32, image::Rgb(c));
        }
    }
    out
}

fn draw_view(
    v: &View,
    d: &Drawables,
    overlay: &Overlay,
    bounds: (DVec3, DVec3),
    style: Style,
    camera_view: bool,
) -> Option<Pen> {
    let mut c = Pen::new(v.width, v.height, BACKGROUND)?;
    if matches!(v.projection, views::Projection::Ortho { .. }) {
        for (k, col) in [[0.45, 0.2, 0.2], [0.2, 0.45, 0.2], [0.2, 0.25, 0.5]]
            .into_iter()
            .enumerate()
        {
            let mut a = DVec3::ZERO;
            a[k] = 1e6;
            c.line(v.project(-a), v.project(a), col, THIN);
        }
    }
    match style {
        Style::Flat => draw_flat(v, d, &mut c),
        Style::Wire => draw_wire(v, d, bounds, &mut c),
    }
    let segment = |c: &mut Pen, a: DVec3, b: DVec3, col: [f32; 3], width: f32| {
        let pts = v.clip_near(&[a, b], false);
        if pts.len() == 2 {
            c.line(v.project(pts[0]), v.project(pts[1]), col, width);
        }
    };
    for ctrl in &overlay.controls {
        for w in ctrl.windows(2) {
            segment(&mut c, w[0], w[1], CONTROL, THIN);
        }
    }
    for (curve, closed) in &overlay.curves {
        for w in curve.windows(2) {
            segment(&mut c, w[0], w[1], SKELETON, BOLD);
        }
        if *closed && curve.len() > 2 {
            segment(&mut c, curve[curve.len() - 1], curve[0], SKELETON, BOLD);
        }
    }
    let visible = |p: DVec3| v.depth(p) > 0.0;
    for p in overlay.points.iter().filter(|p| visible(**p)) {
        c.cross(v.project(*p), 2, SKELETON);
    }
    for p in overlay.lights.iter().filter(|p| visible(**p)) {
        c.cross(v.project(*p), 4, LIGHT);
    }
    if let (Some((pos, at)), false) = (
        overlay.camera,
        camera_view && matches!(v.projection, views::Projection::Perspective { .. }),
    ) {
        segment(&mut c, pos, at, CAMERA, THIN);
        if visible(pos) {
            c.cross(v.project(pos), 4, CAMERA);
        }
    }
    let px = (v.width as f32 / 18.0).clamp(11.0, 20.0);
    font::draw_text(v.label, 5.0, 4.0, px, &mut |x, y, a| {
        c.blend(x, y, LABEL, a)
    });
    Some(c)
}

/// Flat shading: a light at the viewer, so a face's brightness is how squarely it faces us.
fn shade(color: [f32; 3], normal: DVec3, toward: DVec3) -> [f32; 3] {
    let k = 0.25 + 0.75 * normal.normalize_or_zero().dot(toward).abs() as f32;
    color.map(|c| c * k)
}

/// Faces into a z-buffer, then onto the view (over the axes, under the overlay).
fn draw_flat(v: &View, d: &Drawables, pen: &mut Pen) {
    let mut c = Canvas::new(v.width, v.height, BACKGROUND);
    faces(v, d, &mut c);
    pen.faces(&c);
}

fn faces(v: &View, d: &Drawables, c: &mut Canvas) {
    for (poly, color) in &d.polygons {
        let clipped = v.clip_near(poly, true);
        if clipped.len() < 3 {
            continue;
        }
        let centroid = clipped.iter().copied().sum::<DVec3>() / clipped.len() as f64;
        let col = shade(*color, newell(poly), v.toward_viewer(centroid));
        let screen: Vec<[f64; 3]> = clipped.iter().map(|p| v.project(*p)).collect();
        c.fill_polygon(&screen, col);
    }
    if d.quadrics.is_empty() {
        return;
    }
    let reach = 1e6;
    for y in 0..c.height {
        for x in 0..c.width {
            let (o, dir) = v.ray(x as f64, y as f64, reach);
            for q in &d.quadrics {
                if let Some((p, n)) = q.hit(o, dir) {
                    if v.depth(p) > 0.0 {
                        c.plot(
                            x as i64,
                            y as i64,
                            Some(v.key(p) as f32),
                            shade(q.color, n, -dir),
                        );
                    }
                }
            }
        }
    }
}

fn draw_wire(v: &View, d: &Drawables, bounds: (DVec3, DVec3), c: &mut Pen) {
    let edge = |c: &mut Pen, a: DVec3, b: DVec3, col: [f32; 3]| {
        let pts = v.clip_near(&[a, b], false);
        if pts.len() == 2 {
            c.line(v.project(pts[0]), v.project(pts[1]), col, THIN);
        }
    };
    for (poly, color) in &d.polygons {
        let col = visible_on_dark(*color);
        for i in 0..poly.len() {
            edge(c, poly[i], poly[(i + 1) % poly.len()], col);
        }
    }
    for q in &d.quadrics {
        let (lo, hi) = q.bounds.unwrap_or(bounds);
        let col = visible_on_dark(q.color);
        for (a, b) in q.slices(lo, hi, 6, 24) {
            edge(c, a, b, col);
        }
    }
}

/// Lifts dark colours so that lines show on the dark preview background.
fn visible_on_dark(c: [f32; 3]) -> [f32; 3] {
    let lum = 0.3 * c[0] + 0.59 * c[1] + 0.11 * c[2];
    if lum >= 0.35 {
        c
    } else {
        let t = (0.35 - lum) / 0.35;
        c.map(|v| v + (0.6 - v) * t)
    }
}

/// A polygon's normal by Newell's method (any outline, not normalized).
pub fn newell(poly: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        n += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    n
}

/// Writes an image as PNG atomically (a temporary file, then a rename).
pub fn write_png(img: &image::RgbImage, path: &std::path::Path) -> Result<(), ModelError> {
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .map_err(|e| ModelError::Image {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    crate::project::write_atomic(path, &bytes)
}

#[cfg(test)]
mod tests;
