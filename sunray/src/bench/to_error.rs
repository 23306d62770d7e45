//! `sunray bench to-error`: how fast each way of sampling reaches an error. On the accuracy
//! benchmark's scenes ([`super::accuracy::cases`]) against a reference from disjoint
//! stratified streams: (a) stratified jitter at N samples per pixel (what `--samples N`
//! renders), (b) Owen-scrambled Sobol at N (the same sequence the adaptive sampler draws
//! from, taken uniformly) and (c) rendering to an error (`--target-error E`, its default
//! first samples, at most 4,096). For each: the time to reach RMSE 0.01, 0.005 and 0.002
//! (log-log interpolation between the measured points) and the RMSE at equal time.

use super::accuracy::{cases, errors, render_with, scene, AccuracyError};
use crate::accel::{Accel, AccelOptions};
use crate::camera::Camera;
use crate::geometry::Vec3;
use crate::render::adaptive::{trace_pixel_to_error, Adaptive};
use crate::render::{trace_pixel, trace_pixel_sobol};
use crate::scene::Scene;
use crate::shading::Tracer;
use std::time::Instant;

/// Reference streams start here (disjoint from every measured stream).
const REFERENCE_STREAMS: u32 = 1 << 24;

/// The errors the report asks the time to.
pub const RMSE_TARGETS: [f64; 3] = [0.01, 0.005, 0.002];

/// A way of sampling, at one setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// Stratified jitter, N samples per pixel.
    Stratified(u32),
    /// Owen-scrambled Sobol, N samples per pixel.
    Sobol(u32),
    /// To a target error, the default first samples, at most 4,096.
    Adaptive(f64),
}

impl Method {
    /// The column name of the method.
    pub fn name(&self) -> &'static str {
        match self {
            Method::Stratified(_) => "(a) stratified",
            Method::Sobol(_) => "(b) Sobol",
            Method::Adaptive(_) => "(c) adaptive",
        }
    }

    /// Its setting: samples per pixel, or the target error.
    pub fn setting(&self) -> f64 {
        match *self {
            Method::Stratified(n) | Method::Sobol(n) => f64::from(n),
            Method::Adaptive(e) => e,
        }
    }

    /// Pixel (x, y) as the method renders it.
    fn pixel(&self, tracer: &mut Tracer, camera: &Camera, xy: (u32, u32)) -> Vec3 {
        match *self {
            Method::Stratified(n) => trace_pixel(tracer, camera, xy, 0, n),
            Method::Sobol(n) => trace_pixel_sobol(tracer, camera, xy, 0, n),
            Method::Adaptive(e) => {
                let a = Adaptive::new(e, None, Some(4096));
                trace_pixel_to_error(tracer, camera, xy, 0, &a).mean()
            }
        }
    }
}

/// The time at which a curve of (seconds, RMSE) points, in the order measured, first reaches
/// `rmse`: interpolated on log-log axes between the points around it; `None` if never.
pub fn time_to(points: &[(f64, f64)], rmse: f64) -> Option<f64> {
    let first = points.iter().position(|p| p.1 <= rmse)?;
    if first == 0 {
        return Some(points[0].0);
    }
    let ((t0, e0), (t1, e1)) = (points[first - 1], points[first]);
    let f = (rmse.ln() - e0.ln()) / (e1.ln() - e0.ln());
    Some((t0.ln() + f * (t1.ln() - t0.ln())).exp())
}

/// The RMSE a curve of (seconds, RMSE) points has at `seconds` (log-log interpolation
/// between the points around it, on the curve sorted by time); `None` outside it.
pub fn rmse_at(points: &[(f64, f64)], seconds: f64) -> Option<f64> {
    let mut p = points.to_vec();
    p.sort_by(|a, b| a.0.total_cmp(&b.0));
    let i = p
        .windows(2)
        .position(|w| w[0].0 <= seconds && seconds <= w[1].0)?;
    let ((t0, e0), (t1, e1)) = (p[i], p[i + 1]);
    if t1 <= t0 {
        return Some(e0.min(e1));
    }
    let f = (seconds.ln() - t0.ln()) / (t1.ln() - t0.ln());
    Some((e0.ln() + f * (e1.ln() - e0.ln())).exp())
}

/// Best-of-`runs` time (stopping after half a second spent) and the image of `method`.
fn measure(scene: &Scene, accel: &Accel, threads: usize, method: Method) -> (f64, Vec<Vec3>) {
    let (mut best, mut img, mut spent) = (f64::MAX, Vec::new(), 0.0);
    for _ in 0..3 {
        let t = Instant::now();
        img = render_with(scene, accel, threads, &|tr, cam, xy| {
            method.pixel(tr, cam, xy)
        });
        let s = t.elapsed().as_secs_f64();
        best = best.min(s);
        spent += s;
        if spent > 0.5 {
            break;
        }
    }
    (best, img)
}

/// Runs the comparison at `size x size` against `reference_samples`; fixed counts 4 ..
/// `max_samples`, targets `errors`. Returns the Markdown report.
pub fn run(
    size: u32,
    max_samples: u32,
    reference_samples: u32,
    targets: &[f64],
    threads: usize,
) -> Result<String, AccuracyError> {
    let mut points_text = String::from(
        "\n| scene | method | setting | seconds | RMSE | RMSE / E |\n|---|---|---:|---:|---:|---:|\n",
    );
    let mut summary = format!(
        "{size}x{size} pixels, {threads} thread(s), seconds = best of up to 3 runs; reference \
         {reference_samples} stratified samples per pixel from streams disjoint from every \
         measured one; RMSE over every channel of every pixel, linear radiance (1.0 = white).\n\n\
         Time to reach an RMSE (interpolated on log-log axes; - = not reached):\n\n\
         | scene | method | RMSE 0.01 | 0.005 | 0.002 | (c) vs (a) at 0.01 / 0.005 / 0.002 |\n\
         |---|---|---:|---:|---:|---|\n"
    );
    let mut equal_time = String::from(
        "\nRMSE at equal time (the time (c) took for each E; - = outside the measured range):\n\n\
         | scene | E | seconds | (a) stratified | (b) Sobol | (c) adaptive |\n|---|---:|---:|---:|---:|---:|\n",
    );
    for (name, _, body) in cases() {
        let mut scene = scene(name, body, size)?;
        let accel = Accel::build(&mut scene.prims, &AccelOptions::default());
        let reference = render_with(&scene, &accel, threads, &|tr, cam, xy| {
            trace_pixel(tr, cam, xy, REFERENCE_STREAMS, reference_samples)
        });
        let counts: Vec<u32> = (2..=16)
            .map(|k| 1u32 << k)
            .filter(|&n| n <= max_samples)
            .collect();
        let mut curves: Vec<(Method, Vec<(f64, f64)>)> = Vec::new();
        let sweeps: [Vec<Method>; 3] = [
            counts.iter().map(|&n| Method::Stratified(n)).collect(),
            counts.iter().map(|&n| Method::Sobol(n)).collect(),
            targets.iter().map(|&e| Method::Adaptive(e)).collect(),
        ];
        for sweep in sweeps {
            let Some(&first) = sweep.first() else {
                continue;
            };
            let mut curve = Vec::new();
            for method in sweep {
                let s = method.setting();
                let (seconds, img) = measure(&scene, &accel, threads, method);
                let rmse = errors(&img, &reference).0;
                let ratio = match method {
                    Method::Adaptive(e) => format!("{:.2}", rmse / e),
                    _ => String::new(),
                };
                points_text += &format!(
                    "| {name} | {} | {s} | {seconds:.3} | {rmse:.5} | {ratio} |\n",
                    method.name()
                );
                curve.push((seconds.max(1e-6), rmse));
            }
            curves.push((first, curve));
        }
        let cell = |t: Option<f64>| t.map_or("-".to_string(), |t| format!("{t:.3} s"));
        for (method, curve) in &curves {
            let times: Vec<Option<f64>> = RMSE_TARGETS.iter().map(|&r| time_to(curve, r)).collect();
            let speedup = match method {
                Method::Adaptive(_) => RMSE_TARGETS
                    .iter()
                    .zip(&times)
                    .map(|(&r, t)| match (time_to(&curves[0].1, r), t) {
                        (Some(a), Some(c)) => format!("{:.1}x", a / c),
                        _ => "-".into(),
                    })
                    .collect::<Vec<_>>()
                    .join(" / "),
                _ => String::new(),
            };
            summary += &format!(
                "| {name} | {} | {} | {} | {} | {speedup} |\n",
                method.name(),
                cell(times[0]),
                cell(times[1]),
                cell(times[2])
            );
        }
        let rmse =
            |c: &[(f64, f64)], t: f64| rmse_at(c, t).map_or("-".into(), |e| format!("{e:.5}"));
        for (&e, &(t, own)) in targets.iter().zip(&curves[2].1) {
            equal_time += &format!(
                "| {name} | {e} | {t:.3} | {} | {} | {own:.5} |\n",
                rmse(&curves[0].1, t),
                rmse(&curves[1].1, t)
            );
        }
    }
    Ok(format!(
        "{summary}{equal_time}\nEvery point measured:\n{points_text}"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_and_errors_are_interpolated_on_log_log_axes() {
        let curve = [(1.0, 0.1), (4.0, 0.05), (16.0, 0.025)];
        assert_eq!(time_to(&curve, 0.2), Some(1.0));
        assert!((time_to(&curve, 0.05).unwrap() - 4.0).abs() < 1e-12);
        assert!((time_to(&curve, 0.0353553).unwrap() - 8.0).abs() < 1e-3);
        assert_eq!(time_to(&curve, 0.01), None);
        assert!((rmse_at(&curve, 8.0).unwrap() - 0.0353553).abs() < 1e-6);
        assert_eq!(rmse_at(&curve, 32.0), None);
    }

    /// At a tiny size every method's error falls as it is given more, and the adaptive one
    /// lands under twice its target.
    #[test]
    fn every_method_converges_on_a_tiny_penumbra() {
        let (_, _, body) = cases()[1];
        let mut s = scene("penumbra", body, 10).unwrap();
        let accel = Accel::build(&mut s.prims, &AccelOptions::default());
        let reference = render_with(&s, &accel, 2, &|tr, cam, xy| {
            trace_pixel(tr, cam, xy, REFERENCE_STREAMS, 1024)
        });
        let rmse = |m: Method| {
            let img = render_with(&s, &accel, 2, &|tr, cam, xy| m.pixel(tr, cam, xy));
            errors(&img, &reference).0
        };
        for (low, high) in [
            (Method::Stratified(4), Method::Stratified(64)),
            (Method::Sobol(4), Method::Sobol(64)),
            (Method::Adaptive(0.05), Method::Adaptive(0.01)),
        ] {
            let (l, h) = (rmse(low), rmse(high));
            assert!(h < 0.7 * l, "{low:?} {l} vs {high:?} {h}");
        }
        assert!(rmse(Method::Adaptive(0.02)) < 2.0 * 0.02);
    }
}
