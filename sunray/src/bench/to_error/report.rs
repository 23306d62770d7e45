//! The to-error benchmark's Markdown: the time each method takes to each RMSE, the RMSE of
//! each at (c)'s times, and every measured point with (c)'s error against its target.

use super::{rmse_at, time_to, Method, Point, RMSE_TARGETS};

/// What was measured on one scene.
pub struct SceneResult {
    /// The scene's name.
    pub name: &'static str,
    /// Samples per pixel of its reference.
    pub reference_samples: u32,
    /// The reference's own RMSE over the pixels that carry error.
    pub reference_rmse: f64,
    /// The curves of the methods measured, (a), (b), (c) and maybe (d), in that order.
    pub curves: Vec<Vec<Point>>,
    /// Why a method is missing, when one is.
    pub note: Option<String>,
}

/// (seconds, RMSE) of a curve.
fn xy(curve: &[Point]) -> Vec<(f64, f64)> {
    curve.iter().map(|p| (p.seconds, p.rmse)).collect()
}

/// The report of `scenes`, measured at `size` x `size` on `threads` threads against
/// `reference_samples`.
pub fn markdown(
    (size, threads, reference_samples): (u32, usize, u32),
    scenes: &[SceneResult],
    note: Option<&str>,
) -> String {
    let (most, within) = (super::MOST_RUNS, super::RUNS_WITHIN_S);
    let mut out = format!(
        "{size}x{size} pixels, {threads} thread(s), seconds = the best of up to {most} runs, \
         run again while they took at most {within} s in all (POV-Ray: its trace time, the \
         same); reference {reference_samples} stratified samples per \
         pixel (the gears: at most 4096) in two halves from streams disjoint from every \
         measured one; RMSE over every \
         channel of every pixel, linear radiance (1.0 = white). (d) is measured against \
         POV-Ray's own converged image (+A0.0 +AM2 +R6), on the scenes where antialiasing is \
         the whole of the error.\n"
    );
    if let Some(n) = note {
        out += &format!("\n{n}\n");
    }
    out += &times_table(scenes);
    out += &equal_time_table(scenes);
    out += &points_table(scenes);
    out
}

/// Time to each RMSE target, and (a)'s time over each method's.
fn times_table(scenes: &[SceneResult]) -> String {
    let mut out = String::from(
        "\nTime to reach an RMSE (interpolated on log-log axes; - = not reached):\n\n\
         | scene | method | RMSE 0.01 | 0.005 | 0.002 | (a)'s time / this at 0.01 / 0.005 / 0.002 |\n\
         |---|---|---:|---:|---:|---|\n",
    );
    let cell = |t: Option<f64>| t.map_or("-".to_string(), |t| format!("{t:.3} s"));
    for s in scenes {
        let Some(stratified) = s.curves.first() else {
            continue;
        };
        let base = xy(stratified);
        for curve in &s.curves {
            let Some(first) = curve.first() else {
                continue;
            };
            let c = xy(curve);
            let times: Vec<Option<f64>> = RMSE_TARGETS.iter().map(|&r| time_to(&c, r)).collect();
            let speedup = if matches!(first.method, Method::Stratified(_)) {
                String::new()
            } else {
                RMSE_TARGETS
                    .iter()
                    .zip(&times)
                    .map(|(&r, t)| match (time_to(&base, r), t) {
                        (Some(a), Some(c)) => format!("{:.1}x", a / c),
                        _ => "-".into(),
                    })
                    .collect::<Vec<_>>()
                    .join(" / ")
            };
            out += &format!(
                "| {} | {} | {} | {} | {} | {speedup} |\n",
                s.name,
                first.method.name(),
                cell(times[0]),
                cell(times[1]),
                cell(times[2])
            );
        }
        if let Some(n) = &s.note {
            out += &format!("| {} | {n} | | | | |\n", s.name);
        }
    }
    out
}

/// Every method's RMSE at the times (c) took.
fn equal_time_table(scenes: &[SceneResult]) -> String {
    let mut out = String::from(
        "\nRMSE at equal time (the time (c) took for each E; - = outside the measured range):\n\n\
         | scene | E | seconds | (a) stratified | (b) Sobol | (c) adaptive | (d) POV-Ray +A |\n\
         |---|---:|---:|---:|---:|---:|---:|\n",
    );
    let at = |c: Option<&Vec<Point>>, t: f64| {
        c.and_then(|c| rmse_at(&xy(c), t))
            .map_or("-".into(), |e| format!("{e:.5}"))
    };
    for s in scenes {
        let Some(adaptive) = s.curves.get(2) else {
            continue;
        };
        for p in adaptive {
            out += &format!(
                "| {} | {} | {:.3} | {} | {} | {:.5} | {} |\n",
                s.name,
                p.method.setting(),
                p.seconds,
                at(s.curves.first(), p.seconds),
                at(s.curves.get(1), p.seconds),
                p.rmse,
                at(s.curves.get(3), p.seconds)
            );
        }
    }
    out
}

/// Every point, with (c)'s error against E over the whole image and over the pixels that
/// carry error.
fn points_table(scenes: &[SceneResult]) -> String {
    let mut out = String::from(
        "\nEvery point measured. For (c): RMSE / E over the whole image; over the pixels \
         that carry error (those whose two reference halves differ); and over the pixels its \
         estimate stopped (more samples than their first, fewer than the most), both less \
         the reference's own error there (the reference's samples and its error over the \
         varying pixels beside the scene's name). And the RMSE the render estimated for \
         itself (the stats JSON's `error.rms`, the root mean square of its pixels' estimated \
         errors) with the whole image's RMSE, less the reference's own, over it: flat pixels \
         are exact and their estimate says so, so this is the estimate's honesty over the \
         whole image where RMSE / E is not:\n\n\
         | scene | method | setting | seconds | RMSE | RMSE / E | varying pixels: RMSE / E | pixels stopped by E: RMSE / E (how many) | estimated RMSE (error.rms) | RMSE / estimated |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for s in scenes {
        let name = format!(
            "{} (ref. {} samples, {:.5})",
            s.name, s.reference_samples, s.reference_rmse
        );
        for p in s.curves.iter().flatten() {
            let (whole, varying, stopped) = match (p.method, p.varying_rmse, p.stopped) {
                (Method::Adaptive(e), Some(v), Some((s, n))) => (
                    format!("{:.2}", p.rmse / e),
                    format!("{:.2}", v / e),
                    format!("{:.2} ({n})", s / e),
                ),
                _ => (String::new(), String::new(), String::new()),
            };
            let (estimated, honesty) = match p.estimated {
                Some((est, rmse)) if est > 0.0 => {
                    (format!("{est:.5}"), format!("{:.2}", rmse / est))
                }
                Some((est, _)) => (format!("{est:.5}"), String::new()),
                None => (String::new(), String::new()),
            };
            out += &format!(
                "| {name} | {} | {} | {:.3} | {:.5} | {whole} | {varying} | {stopped} | {estimated} | {honesty} |\n",
                p.method.name(),
                p.method.setting_text(),
                p.seconds,
                p.rmse
            );
        }
    }
    out
}
