//! `sunray bench to-error`: how fast each way of sampling reaches an error. On the accuracy
//! benchmark's scenes ([`super::accuracy::cases`]) and Haines's glass gears (SPD `gears 1`),
//! against a reference from disjoint stratified streams: (a) stratified jitter at N samples
//! per pixel (what `--samples N` renders), (b) Owen-scrambled Sobol at N (`--sampler sobol`,
//! the sequence the adaptive sampler draws from), (c) rendering to an error
//! (`--target-error E`, its default first samples, at most 4,096) and, where `povray` runs
//! and antialiasing is the whole of the error (edges, gears), (d) POV-Ray 3.7's adaptive
//! antialiasing ([`super::pov_aa`]). For each: the time to reach RMSE 0.01, 0.005 and 0.002
//! (log-log interpolation between the measured points), the RMSE at equal time, and a plot
//! of RMSE against time per scene (`to_error-SCENE.png`).
//!
//! Whether the estimate is honest: the reference is two halves from disjoint streams, so a
//! pixel whose halves differ is one that carries error (a flat pixel's samples all agree, and
//! its estimate is exact whatever the count). (c)'s RMSE over those pixels, less the
//! reference's own error there (a quarter of the halves' squared difference), is what E
//! promises of each pixel, and is reported beside the whole image's RMSE.
//!
//! [`reference`] makes that reference and measures against it; [`report`] writes the tables.

use super::accuracy::{cases as accuracy_cases, errors, world, AccuracyError};
use super::plot::{loglog, Labels, Series};
use super::pov_aa;
use crate::accel::{Accel, AccelOptions};
use crate::geometry::Vec3;
use crate::render::adaptive::{error_stats, raised_samples, Adaptive};
use crate::render::{render_image_summarized, Progress, RenderOptions};
use crate::sampler::Sampler;
use crate::scene::Scene;
use std::path::Path;
use std::time::Instant;

mod reference;
mod report;
pub use reference::Reference;

/// Reference streams start here (disjoint from every measured stream).
const REFERENCE_STREAMS: u32 = 1 << 24;

/// The errors the report asks the time to.
pub const RMSE_TARGETS: [f64; 3] = [0.01, 0.005, 0.002];

/// The SPD scene with glass: Haines's gears at size 1 (transparent, refracting gears).
const GEARS_SIZE: u32 = 1;
/// The most reference samples the gears take (its error is antialiasing alone, which
/// converges faster than the stochastic features', and each of its samples costs more).
const GEARS_REFERENCE: u32 = 4096;

/// A way of sampling, at one setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// Stratified jitter, N samples per pixel.
    Stratified(u32),
    /// Owen-scrambled Sobol, N samples per pixel.
    Sobol(u32),
    /// To a target error, the default first samples, at most 4,096.
    Adaptive(f64),
    /// POV-Ray's adaptive antialiasing at a threshold and depth (`+A<t> +R<depth>`).
    Pov(f64, u32),
}

impl Method {
    /// The column name of the method.
    pub fn name(&self) -> &'static str {
        match self {
            Method::Stratified(_) => "(a) stratified",
            Method::Sobol(_) => "(b) Sobol",
            Method::Adaptive(_) => "(c) adaptive",
            Method::Pov(..) => "(d) POV-Ray +A",
        }
    }

    /// Its setting: samples per pixel, the target error or POV-Ray's threshold.
    pub fn setting(&self) -> f64 {
        match *self {
            Method::Stratified(n) | Method::Sobol(n) => f64::from(n),
            Method::Adaptive(e) | Method::Pov(e, _) => e,
        }
    }

    /// Its setting as the report prints it (POV-Ray's with its depth: `0.01 +R4`).
    pub fn setting_text(&self) -> String {
        match *self {
            Method::Pov(t, depth) => format!("{t} +R{depth}"),
            _ => self.setting().to_string(),
        }
    }

    /// What `sunray render` is given for the method on `scene` (`None` for POV-Ray's).
    fn options(&self, scene: &Scene) -> Option<RenderOptions> {
        let scene_own = RenderOptions::for_scene(scene);
        let fixed = |samples, sampler| RenderOptions {
            samples,
            sampler,
            ..scene_own
        };
        match *self {
            Method::Stratified(n) => Some(fixed(n, Sampler::Stratified)),
            Method::Sobol(n) => Some(fixed(n, Sampler::Sobol)),
            Method::Adaptive(e) => Some(RenderOptions {
                adaptive: Some(adaptive_of(e)),
                ..scene_own
            }),
            Method::Pov(..) => None,
        }
    }
}

/// What (c) at target `e` asks: the default first samples, at most 4,096.
fn adaptive_of(e: f64) -> Adaptive {
    Adaptive::new(e, None, Some(4096))
}

/// One scene of the benchmark.
struct Case {
    name: &'static str,
    scene: Scene,
    /// The scene in POV-Ray SDL, where (d) is measured (antialiasing is the whole of its
    /// error).
    pov: Option<String>,
}

impl Case {
    /// Scene `name` from YARI `body` at `size` x `size`, with its POV-Ray SDL if `pov`.
    fn new(name: &'static str, body: &str, size: u32, pov: bool) -> Result<Case, AccuracyError> {
        let world = world(name, body, size)?;
        Ok(Case {
            name,
            pov: pov.then(|| yari::pov::write_pov(&world)),
            scene: Scene::new(world),
        })
    }
}

/// The accuracy benchmark's scenes and the SPD gears, at `size` x `size`.
fn cases(size: u32) -> Result<Vec<Case>, AccuracyError> {
    let mut out = Vec::new();
    for (name, _, body) in accuracy_cases() {
        out.push(Case::new(name, body, size, name == "edges")?);
    }
    let nff = yari::spd::generate(yari::spd::Database::Gears, GEARS_SIZE)
        .map_err(|e| AccuracyError::Scene("gears", e.to_string()))?;
    let text = yari::writer::write_scene(&yari::nff::to_yari(&nff));
    // The benchmark's size replaces Haines's 512 x 512.
    let body: String = text
        .lines()
        .filter(|l| !l.starts_with("resolution("))
        .map(|l| format!("{l}\n"))
        .collect();
    out.push(Case::new("gears", &body, size, true)?);
    Ok(out)
}

/// One measured point of a method.
#[derive(Clone, Copy, Debug)]
pub struct Point {
    /// The method and its setting.
    pub method: Method,
    /// Its time, the best of up to [`MOST_RUNS`] runs (POV-Ray's trace time).
    pub seconds: f64,
    /// RMSE over the whole image.
    pub rmse: f64,
    /// (c) only: RMSE over the pixels that carry error, less the reference's own.
    pub varying_rmse: Option<f64>,
    /// (c) only: RMSE over the pixels the target stopped (more than their first samples,
    /// fewer than the most), less the reference's own, and how many pixels those are.
    pub stopped: Option<(f64, usize)>,
    /// (c) only: the RMSE the render estimated for itself (the stats JSON's `error.rms`: the
    /// root mean square of its pixels' estimated errors) and the RMSE over the whole image
    /// less the reference's own error, to set against it.
    pub estimated: Option<(f64, f64)>,
}

/// What one method measured: its best time, its image and the samples each pixel took.
struct Measured {
    seconds: f64,
    image: Vec<Vec3>,
    samples: Vec<u32>,
    estimated_rms: Option<f64>,
}

/// A render runs again while its runs took at most this long in all: a 10 ms one (the
/// penumbra's (c) at RMSE 0.01) is the best of 15, a 0.2 s one of 3, a 1 s one of 1.
const RUNS_WITHIN_S: f64 = 0.5;
/// The most runs of one measured render.
const MOST_RUNS: usize = 15;

/// The best time of up to [`MOST_RUNS`] runs of `run` (which gives its seconds and what it
/// made), running again while they took at most [`RUNS_WITHIN_S`] in all, and what the last
/// run made.
fn best_of_runs<T, E>(mut run: impl FnMut() -> Result<(f64, T), E>) -> Result<(f64, T), E> {
    let (mut best, mut last) = run()?;
    let mut spent = best;
    for _ in 1..MOST_RUNS {
        if spent > RUNS_WITHIN_S {
            break;
        }
        let (s, made) = run()?;
        (best, spent, last) = (best.min(s), spent + s, made);
    }
    Ok((best, last))
}

/// Best time of up to [`MOST_RUNS`] runs within [`RUNS_WITHIN_S`], the image `opts` give, the
/// samples each pixel took and (rendering to an error) its own estimate of its RMSE, rendered as `sunray render` renders it (line by line, the
/// background outside the scene's footprint not traced).
fn measure(scene: &Scene, accel: &Accel, threads: usize, opts: &RenderOptions) -> Measured {
    let render = || {
        let t = Instant::now();
        let rendered = render_image_summarized(scene, accel, opts, threads, true, Progress::Hidden);
        (t.elapsed().as_secs_f64(), rendered)
    };
    let Ok::<_, std::convert::Infallible>((best, (film, _, summaries))) =
        best_of_runs(|| Ok(render()));
    let estimated_rms = opts.adaptive.map(|a| error_stats(&summaries, &a).rms);
    let samples = if opts.adaptive.is_some() {
        summaries.iter().map(|p| p.samples).collect()
    } else {
        vec![opts.samples; film.pixels.len()]
    };
    Measured {
        seconds: best,
        image: film
            .pixels
            .iter()
            .map(|p| Vec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
            .collect(),
        samples,
        estimated_rms,
    }
}

/// The curves of (a), (b) and (c) on `case`: fixed counts `counts`, targets `targets`.
fn sunray_curves(
    case: &Case,
    accel: &Accel,
    reference: &Reference,
    (counts, targets): (&[u32], &[f64]),
    threads: usize,
) -> Vec<Vec<Point>> {
    let sweeps: [Vec<Method>; 3] = [
        counts.iter().map(|&n| Method::Stratified(n)).collect(),
        counts.iter().map(|&n| Method::Sobol(n)).collect(),
        targets.iter().map(|&e| Method::Adaptive(e)).collect(),
    ];
    sweeps
        .into_iter()
        .map(|sweep| {
            sweep
                .into_iter()
                .filter_map(|method| {
                    let m = measure(&case.scene, accel, threads, &method.options(&case.scene)?);
                    let adaptive = matches!(method, Method::Adaptive(_));
                    Some(Point {
                        method,
                        seconds: m.seconds.max(1e-6),
                        rmse: errors(&m.image, &reference.image).0,
                        varying_rmse: adaptive.then(|| reference.varying_rmse(&m.image)),
                        stopped: match method {
                            Method::Adaptive(e) => {
                                let mask = stopped_by_target(&m.samples, &adaptive_of(e));
                                let n = mask.iter().filter(|&&m| m).count();
                                Some((reference.rmse_over(&m.image, &mask), n))
                            }
                            _ => None,
                        },
                        estimated: m.estimated_rms.map(|est| {
                            let all = vec![true; m.image.len()];
                            (est, reference.rmse_over(&m.image, &all))
                        }),
                    })
                })
                .collect()
        })
        .collect()
}

/// The pixels whose count `a`'s estimate decided, of those that took `samples`: more than
/// a raised pixel's fewest ([`raised_samples`]), fewer than the most. Their RMSE against E
/// says whether the estimate is honest, apart from the pixels that need no more than their
/// first samples or than a raised pixel's fewest, and those the cap stops.
fn stopped_by_target(samples: &[u32], a: &Adaptive) -> Vec<bool> {
    let least = raised_samples(a);
    samples
        .iter()
        .map(|&n| n > least && n < a.max_samples)
        .collect()
}

/// The curve of (d) on a scene (its SDL `pov`): POV-Ray at each of [`pov_aa::THRESHOLDS`] and
/// [`pov_aa::DEPTHS`] against its own converged image, the fastest way to each error kept
/// (POV-Ray on its best terms: the points no faster setting beats); a note instead when it
/// cannot be measured.
fn pov_curve(pov: &str, size: u32, threads: usize) -> Result<Vec<Point>, String> {
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let run = |t: f64, depth: u32| {
        pov_aa::render(pov, size, (t, depth), threads, dir.path()).map_err(|e| e.to_string())
    };
    let reference = run(0.0, pov_aa::REFERENCE_DEPTH)?;
    let mut all = Vec::new();
    for &depth in &pov_aa::DEPTHS {
        for &t in &pov_aa::THRESHOLDS {
            // Timed as ours are (the image is the same each time).
            let (seconds, mut best) = best_of_runs(|| run(t, depth).map(|r| (r.seconds, r)))?;
            best.seconds = seconds;
            all.push(Point {
                method: Method::Pov(t, depth),
                seconds: best.seconds.max(1e-6),
                rmse: errors(&best.image, &reference.image).0,
                varying_rmse: None,
                stopped: None,
                estimated: None,
            });
        }
    }
    Ok(lower_envelope(all))
}

/// The points of `all` that no faster point matches in error, fastest first.
pub fn lower_envelope(mut all: Vec<Point>) -> Vec<Point> {
    all.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
    let mut best = f64::INFINITY;
    all.retain(|p| {
        let keep = p.rmse < best;
        best = best.min(p.rmse);
        keep
    });
    all
}

/// Runs the comparison at `size x size` against `reference_samples`; fixed counts 4 ..
/// `max_samples`, targets `targets`; plots into `plots` when given. Returns the Markdown
/// report.
pub fn run(
    size: u32,
    max_samples: u32,
    reference_samples: u32,
    targets: &[f64],
    threads: usize,
    plots: Option<&Path>,
) -> Result<String, AccuracyError> {
    let counts: Vec<u32> = (2..=16)
        .map(|k| 1u32 << k)
        .filter(|&n| n <= max_samples)
        .collect();
    let pov = pov_aa::available();
    let mut scenes = Vec::new();
    for mut case in cases(size)? {
        let accel = Accel::build(&mut case.scene.prims, &AccelOptions::default());
        let samples = match case.name {
            "gears" => reference_samples.min(GEARS_REFERENCE),
            _ => reference_samples,
        };
        let reference = Reference::render(&case.scene, &accel, threads, samples);
        let mut curves = sunray_curves(&case, &accel, &reference, (&counts, targets), threads);
        let mut note = None;
        if let (Some(sdl), true) = (&case.pov, pov) {
            match pov_curve(sdl, size, threads) {
                Ok(c) => curves.push(c),
                Err(e) => note = Some(format!("(d) not measured: {e}")),
            }
        }
        if let Some(dir) = plots {
            plot(case.name, &curves, dir)?;
        }
        scenes.push(report::SceneResult {
            name: case.name,
            reference_samples: samples,
            reference_rmse: reference.own_rmse,
            curves,
            note,
        });
    }
    let pov_note = (!pov).then_some("`povray` does not run here: no (d).");
    Ok(report::markdown(
        (size, threads, reference_samples),
        &scenes,
        pov_note,
    ))
}

/// RMSE against time of every method on scene `name`, into `dir/to_error-NAME.png`.
fn plot(name: &str, curves: &[Vec<Point>], dir: &Path) -> Result<(), AccuracyError> {
    const COLOURS: [[u8; 3]; 4] = [[200, 30, 30], [30, 90, 200], [30, 150, 60], [150, 60, 180]];
    let series: Vec<Series> = curves
        .iter()
        .zip(COLOURS)
        .filter_map(|(c, colour)| {
            Some(Series {
                name: c.first()?.method.name().to_string(),
                colour,
                points: c.iter().map(|p| (p.seconds, p.rmse)).collect(),
            })
        })
        .collect();
    let title = format!("{name}: RMSE against time (dashed: slope -1/2)");
    let labels = Labels {
        title: &title,
        x: "seconds",
        y: "RMSE (linear radiance)",
    };
    loglog(&series, &labels, &dir.join(format!("to_error-{name}.png")))?;
    Ok(())
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

#[cfg(test)]
mod tests;
