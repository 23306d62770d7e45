//! `sunray bench accuracy`: speed against error for the stochastic features. Four small
//! scenes, each using one feature (antialiased edges, an area light's penumbra, glossy
//! reflection, depth of field), are rendered at 1, 2, 4, ... samples per pixel and compared
//! with a converged reference rendered from sample streams disjoint from the measured ones
//! (so the reference's own noise is independent of the error it measures).
//!
//! Sampling (see [`crate::sampler`]): the pixel offset is jittered in cell s of an a x b grid
//! of the pixel (a b = samples), and every other 2-D draw (light disc, gloss cone, lens) is
//! jittered in a cell chosen by a per-pixel random permutation of the sample indices. See
//! docs/accuracy.md for the measured slopes.

use super::plot::{loglog, Labels, PlotError, Series};
use crate::accel::{Accel, AccelOptions, Scratch};
use crate::camera::Camera;
use crate::geometry::Vec3;
use crate::render::{trace_pixel, RenderOptions};
use crate::scene::Scene;
use crate::shading::Tracer;
use crate::stats::Counters;
use std::path::Path;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;
use yari::model::World;

/// Sample streams of the reference start here, far above any measured sample index.
const REFERENCE_STREAMS: u32 = 1 << 24;

/// The benchmark scenes: (name, plot colour, YARI text without resolution).
pub fn cases() -> Vec<(&'static str, [u8; 3], &'static str)> {
    vec![
        ("edges", [200, 30, 30], EDGES),
        ("penumbra", [30, 120, 200], PENUMBRA),
        ("gloss", [30, 160, 60], GLOSS),
        ("depth_of_field", [150, 60, 180], DOF),
    ]
}

const EDGES: &str = "background(color = 0,0,0); ambient(color = 0.3,0.3,0.3);
light(position = 5,8,10 ; color = 1,1,1);
camera(position = 0,0,8 ; at = 0,0,0 ; up = 0,1,0 ; angle = 20);
begin
  begin attribute(color = 1,1,1); sphere(center = -1,0.4,0 ; radius = 1); end
  begin attribute(color = 1,0.8,0.2); polygon(vertices = 3; 0.2,-2,0 2.3,-1.2,0.5 1.0,1.9,-0.3); end
  begin attribute(color = 0.2,0.9,1); polygon(vertices = 4; -2.5,-2.2,-1 -0.5,-2.0,-1 -0.4,-1.1,-1 -2.4,-1.3,-1); end
end";

const PENUMBRA: &str = "background(color = 0,0,0); ambient(color = 0.05,0.05,0.05);
light(position = 3,6,2 ; color = 1,1,1 ; radius = 1.2);
camera(position = 0,5,5 ; at = 0,0,0 ; up = 0,1,0 ; angle = 22);
begin
  attribute(color = 0.9,0.9,0.9);
  polygon(vertices = 4; -4,0,-4 -4,0,4 4,0,4 4,0,-4);
  begin attribute(color = 0.8,0.3,0.2); sphere(center = -0.3,1.2,0 ; radius = 0.7); end
end";

const GLOSS: &str = "background(color = 0.1,0.1,0.1); ambient(color = 0.2,0.2,0.2);
light(position = 4,8,6 ; color = 1,1,1);
camera(position = 0,2,6 ; at = 0,0.7,0 ; up = 0,1,0 ; angle = 20);
begin
  begin attribute(color = 0.9,0.9,0.9 ; texture = 5 0.1,0.1,0.1 0.5,0.5,0.5);
    polygon(vertices = 4; -6,0,-6 -6,0,6 6,0,6 6,0,-6); end
  begin attribute(color = 0.9,0.8,0.6 ; kdr = 0.2 ; gloss = 6 ; phong = 40);
    sphere(center = 0,1,0 ; radius = 1); end
end";

const DOF: &str = "background(color = 0.1,0.1,0.2); ambient(color = 0.2,0.2,0.2);
light(position = 4,8,8 ; color = 1,1,1);
camera(position = 0,1,8 ; at = 0,0.5,0 ; up = 0,1,0 ; angle = 18 ; aperture = 0.25 ; focus = 8);
begin
  begin attribute(color = 0.9,0.9,0.9 ; texture = 5 0.2,0.2,0.2 0.5,0.5,0.5);
    polygon(vertices = 4; -6,0,-8 -6,0,6 6,0,6 6,0,-8); end
  begin attribute(color = 1,0.3,0.2); sphere(center = -1.5,0.7,3 ; radius = 0.7); end
  begin attribute(color = 0.2,0.9,0.3); sphere(center = 0,0.7,0 ; radius = 0.7); end
  begin attribute(color = 0.3,0.4,1); sphere(center = 1.8,0.7,-4 ; radius = 0.7); end
end";

/// Why the accuracy benchmark stopped.
#[derive(Debug, thiserror::Error)]
pub enum AccuracyError {
    /// A built-in scene did not compile (its name and the compiler's message).
    #[error("benchmark scene {0} does not compile: {1}")]
    Scene(&'static str, String),
    /// The plot could not be drawn or written.
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// One measured point.
#[derive(Clone, Debug)]
pub struct Row {
    /// The stochastic feature measured (edges, penumbra, gloss, depth of field).
    pub case: &'static str,
    /// Samples per pixel.
    pub samples: u32,
    /// Wall-clock render time.
    pub seconds: f64,
    /// Root-mean-square error against the high-sample reference (linear radiance).
    pub rmse: f64,
    /// Largest error of one pixel channel against the reference.
    pub max_error: f64,
}

/// The compiled scene `text` at `size x size`.
pub fn scene(name: &'static str, text: &str, size: u32) -> Result<Scene, AccuracyError> {
    Ok(Scene::new(world(name, text, size)?))
}

/// The YARI source of the benchmark scene `text` at `size x size`: what [`world`] compiles.
pub fn scene_source(text: &str, size: u32) -> String {
    format!("resolution({size}, {size});\n{text}\n")
}

/// Every benchmark scene at `size x size` as a file to write: (`NAME.yari`, its YARI source).
/// `sunray bench scenes` writes them, so a person can render what the benchmark measures, and
/// deploy/pgo-build.sh trains on them with plain renders (the same counts every time, where
/// the benchmark repeats its runs by the clock).
pub fn scene_files(size: u32) -> Vec<(String, String)> {
    cases()
        .into_iter()
        .map(|(name, _, text)| (format!("{name}.yari"), scene_source(text, size)))
        .collect()
}

/// The world of [`scene`], before it becomes primitives (what `sunray convert` writes).
pub fn world(name: &'static str, text: &str, size: u32) -> Result<World, AccuracyError> {
    let loaded = yari::load::load_str(
        name,
        scene_source(text, size),
        yari::load::InputKind::Yari,
        &yari::colour::ColourTable::builtin(),
    )
    .map_err(|e| AccuracyError::Scene(name, e.to_string()))?;
    Ok(loaded.world)
}

/// Renders `samples` per pixel using sample streams `first_stream..` on `threads` threads;
/// the image in f64, row-major.
pub fn render_streams(
    scene: &Scene,
    accel: &Accel,
    samples: u32,
    first_stream: u32,
    threads: usize,
) -> Vec<Vec3> {
    render_with(scene, accel, threads, &|tracer, camera, xy| {
        trace_pixel(tracer, camera, xy, first_stream, samples.max(1))
    })
}

/// How a pixel is rendered: its colour from a tracer, the camera and its coordinates.
pub type PixelFn<'a> = dyn Fn(&mut Tracer, &Camera, (u32, u32)) -> Vec3 + Sync + 'a;

/// `scene` rendered on `threads` threads with `pixel` for each pixel; row-major.
pub fn render_with(scene: &Scene, accel: &Accel, threads: usize, pixel: &PixelFn) -> Vec<Vec3> {
    let opts = RenderOptions::for_scene(scene);
    let (w, h) = (opts.width, opts.height);
    let camera = Camera::new(&scene.world.camera, w, h);
    let next = AtomicU32::new(0);
    let mut rows: Vec<(u32, Vec<Vec3>)> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads.max(1))
            .map(|_| {
                s.spawn(|| {
                    let mut scratch = Scratch::new(scene.prims.len(), true);
                    let mut counters = Counters::default();
                    let mut done = Vec::new();
                    loop {
                        let y = next.fetch_add(1, Ordering::Relaxed);
                        if y >= h {
                            break;
                        }
                        let mut tracer = Tracer {
                            scene,
                            accel,
                            opts: opts.trace,
                            scratch: &mut scratch,
                            counters: &mut counters,
                        };
                        let row = (0..w).map(|x| pixel(&mut tracer, &camera, (x, y)));
                        done.push((y, row.collect()));
                    }
                    done
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_default())
            .collect()
    });
    rows.sort_by_key(|r| r.0);
    rows.into_iter().flat_map(|r| r.1).collect()
}

/// RMSE over all channels of all pixels, and the largest channel error.
pub fn errors(image: &[Vec3], reference: &[Vec3]) -> (f64, f64) {
    let mut sum = 0.0;
    let mut max: f64 = 0.0;
    for (a, b) in image.iter().zip(reference) {
        let d = *a - *b;
        sum += d.length_squared();
        max = max.max(d.abs().max_element());
    }
    ((sum / (3 * image.len().max(1)) as f64).sqrt(), max)
}

/// Least-squares slope of log(y) against log(x).
pub fn loglog_slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
    for &(x, y) in points {
        let (lx, ly) = (x.ln(), y.ln());
        sx += lx;
        sy += ly;
        sxx += lx * lx;
        sxy += lx * ly;
    }
    (n * sxy - sx * sy) / (n * sxx - sx * sx)
}

/// Runs the benchmark: every case at 1, 2, 4, ... `max_samples` against a
/// `reference_samples` reference at `size x size`; writes the plot to `plot` if given and
/// returns the rows and a Markdown table.
pub fn run(
    size: u32,
    max_samples: u32,
    reference_samples: u32,
    threads: usize,
    plot: Option<&Path>,
) -> Result<(Vec<Row>, String), AccuracyError> {
    let mut rows = Vec::new();
    let mut series = Vec::new();
    let mut text = format!(
        "{size}x{size} pixels, {threads} thread(s), seconds = best of up to 5 runs, reference {reference_samples} samples/pixel \
         from disjoint sample streams; error in linear radiance (1.0 = white).\n\n\
         | scene | samples | seconds | RMSE | max error |\n|---|---:|---:|---:|---:|\n"
    );
    let mut slopes = String::from("\n| scene | RMSE slope vs samples | vs seconds | 1/sqrt bound (-0.5) |\n|---|---:|---:|---|\n");
    for (name, colour, body) in cases() {
        let mut scene = scene(name, body, size)?;
        let accel = Accel::build(&mut scene.prims, &AccelOptions::default());
        let t = Instant::now();
        let reference = render_streams(
            &scene,
            &accel,
            reference_samples,
            REFERENCE_STREAMS,
            threads,
        );
        let ref_s = t.elapsed().as_secs_f64();
        let mut points = Vec::new();
        let mut by_time = Vec::new();
        let mut n = 1;
        while n <= max_samples {
            // Best of up to 5 runs (at least one, stopping after 0.5 s) against other load.
            let (mut seconds, mut img, mut spent) = (f64::MAX, Vec::new(), 0.0);
            for _ in 0..5 {
                let t = Instant::now();
                img = render_streams(&scene, &accel, n, 0, threads);
                let s = t.elapsed().as_secs_f64();
                seconds = seconds.min(s);
                spent += s;
                if spent > 0.5 {
                    break;
                }
            }
            let (rmse, max_error) = errors(&img, &reference);
            text += &format!("| {name} | {n} | {seconds:.3} | {rmse:.5} | {max_error:.4} |\n");
            points.push((n as f64, rmse));
            by_time.push((seconds.max(1e-6), rmse));
            rows.push(Row {
                case: name,
                samples: n,
                seconds,
                rmse,
                max_error,
            });
            n *= 2;
        }
        let slope = loglog_slope(&points);
        let slope_t = loglog_slope(&by_time);
        slopes += &format!(
            "| {name} | {slope:.3} | {slope_t:.3} | {} |\n",
            if slope <= -0.5 + 0.03 {
                "met"
            } else {
                "NOT met"
            }
        );
        text += &format!("| {name} (reference) | {reference_samples} | {ref_s:.3} | 0 | 0 |\n");
        series.push(Series {
            name: name.replace('_', " "),
            colour,
            points: by_time,
        });
    }
    text += &slopes;
    if let Some(path) = plot {
        let title = format!(
            "RMS error against render time, {size}×{size} pixels, 1 to {max_samples} samples/pixel"
        );
        let labels = Labels {
            title: &title,
            x: "render time (s, wall clock)",
            y: "RMS error (linear radiance)",
        };
        loglog(&series, &labels, path)?;
    }
    Ok((rows, text))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_of_a_power_law() {
        let pts: Vec<(f64, f64)> = (0..6)
            .map(|k| (2f64.powi(k), 3.0 * 2f64.powi(k).powf(-0.5)))
            .collect();
        assert!((loglog_slope(&pts) + 0.5).abs() < 1e-12);
    }

    /// At a tiny size, the error of the penumbra scene falls as samples grow, and the
    /// measured error of the reference against itself is zero.
    #[test]
    fn error_falls_with_samples() {
        let mut s = scene("penumbra", PENUMBRA, 12).unwrap();
        let accel = Accel::build(&mut s.prims, &AccelOptions::default());
        let reference = render_streams(&s, &accel, 256, REFERENCE_STREAMS, 2);
        assert_eq!(errors(&reference, &reference), (0.0, 0.0));
        let e1 = errors(&render_streams(&s, &accel, 1, 0, 2), &reference).0;
        let e16 = errors(&render_streams(&s, &accel, 16, 0, 2), &reference).0;
        assert!(e16 < 0.6 * e1, "{e16} vs {e1}");
    }
}
