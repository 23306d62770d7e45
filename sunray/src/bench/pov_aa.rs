//! POV-Ray 3.7's adaptive antialiasing, method (d) of `sunray bench to-error`: the scene as
//! `sunray convert` writes it ([`yari::pov::write_pov`]), rendered by `povray` with
//! `+A<threshold> +AM2 +R<depth>` (its adaptive supersampling: a pixel whose corners differ
//! by more than the threshold is subdivided, up to `depth` levels), thresholds and depths
//! swept, on as many threads as SunRay, to a 16-bit linear PNG. The time is POV-Ray's own trace time (its parse and start-up left out, as SunRay's
//! scene set-up is); the error is measured against POV-Ray's own converged image, the same
//! scene at `+A0.0 +AM2 +R6` (every pixel subdivided to the deepest level: about 1,000 samples
//! a pixel), because POV-Ray's shading is not SunRay's: each renderer is measured against its
//! own converged image. POV-Ray's area lights, blurred reflection and focal blur sample with
//! their own settings, not `+A`, so (d) is measured where antialiasing is the whole of the
//! error: on edges and the SPD glass scene.

use crate::geometry::Vec3;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The thresholds (d) is measured at, coarse to fine.
pub const THRESHOLDS: [f64; 6] = [0.3, 0.1, 0.03, 0.01, 0.003, 0.0];
/// The depths (d) is measured at (`+R`; POV-Ray's default is 3): deeper reaches lower
/// errors on edges, whose coverage a 2^R grid quantizes.
pub const DEPTHS: [u32; 3] = [3, 4, 5];
/// The depth of POV-Ray's converged image (threshold 0: every pixel that deep).
pub const REFERENCE_DEPTH: u32 = 6;

/// Why POV-Ray could not be measured.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PovError {
    /// The scene or image could not be written or read.
    #[error("{0}: {1}")]
    Io(PathBuf, std::io::Error),
    /// `povray` failed (its last lines of output).
    #[error("povray failed: {0}")]
    Failed(String),
    /// Its image could not be read, or has the wrong size.
    #[error("povray's image {0}: {1}")]
    Image(PathBuf, String),
}

/// Whether `povray` runs here.
pub fn available() -> bool {
    Command::new("povray")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// A POV-Ray render: its trace time and its image in linear radiance, row-major.
pub struct PovRender {
    /// POV-Ray's "Trace Time", in seconds.
    pub seconds: f64,
    /// Samples it took per pixel ("Smpls/Pxl"; 0 without antialiasing).
    pub samples_per_pixel: f64,
    /// The image.
    pub image: Vec<Vec3>,
}

/// The scene `pov` (POV-Ray SDL), `size` x `size`, rendered by POV-Ray with `+A<threshold>
/// +AM2 +R<depth>` on `threads` threads in `dir`.
pub fn render(
    pov: &str,
    size: u32,
    (threshold, depth): (f64, u32),
    threads: usize,
    dir: &Path,
) -> Result<PovRender, PovError> {
    let scene = dir.join("scene.pov");
    let out = dir.join("pov.png");
    std::fs::write(&scene, pov).map_err(|e| PovError::Io(scene.clone(), e))?;
    let run = Command::new("povray")
        .arg(format!("+I{}", scene.display()))
        .arg(format!("+O{}", out.display()))
        .args([format!("+W{size}"), format!("+H{size}")])
        .args(["+FN16", "File_Gamma=1.0", "-D", "+GS", "+GR", "-GD", "+AM2"])
        .args([format!("+A{threshold:.4}"), format!("+R{depth}")])
        .arg(format!("+WT{}", threads.max(1)))
        .output()
        .map_err(|e| PovError::Io("povray".into(), e))?;
    let log = String::from_utf8_lossy(&run.stderr).to_string();
    if !run.status.success() {
        // Its first complaint says what went wrong.
        let first = log
            .lines()
            .find(|l| !l.trim().is_empty() && !l.contains("povray.conf"));
        return Err(PovError::Failed(first.unwrap_or("no message").to_string()));
    }
    let seconds = trace_time(&log)
        .ok_or_else(|| PovError::Failed("no Trace Time in its statistics".into()))?;
    let samples_per_pixel = samples_per_pixel(&log).unwrap_or(0.0);
    let img = image::open(&out)
        .map_err(|e| PovError::Image(out.clone(), e.to_string()))?
        .to_rgb16();
    if img.dimensions() != (size, size) {
        return Err(PovError::Image(out, format!("{:?}", img.dimensions())));
    }
    let image = img
        .pixels()
        .map(|p| Vec3::new(p[0].into(), p[1].into(), p[2].into()) / 65535.0)
        .collect();
    Ok(PovRender {
        seconds,
        samples_per_pixel,
        image,
    })
}

/// POV-Ray's "Trace Time: 0 hours 0 minutes 4 seconds (4.746 seconds)", in seconds.
fn trace_time(log: &str) -> Option<f64> {
    let rest = after(log, "Trace Time:")?;
    let open = rest.rfind('(')?;
    rest[open + 1..].split_whitespace().next()?.parse().ok()
}

/// POV-Ray's "Smpls/Pxl: 1.06".
fn samples_per_pixel(log: &str) -> Option<f64> {
    after(log, "Smpls/Pxl:")?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// What follows `key` on the first line of POV-Ray's statistics that holds it.
fn after<'a>(log: &'a str, key: &str) -> Option<&'a str> {
    log.lines()
        .find_map(|l| l.split_once(key).map(|(_, rest)| rest))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trace_time_and_samples_are_read_from_povrays_statistics() {
        let log = "  Pixels:            17424   Samples:            18427   Smpls/Pxl: 1.06\n\
                   Trace Time:       0 hours  0 minutes  4 seconds (4.746 seconds)\n";
        assert_eq!(trace_time(log), Some(4.746));
        assert_eq!(samples_per_pixel(log), Some(1.06));
        assert_eq!(trace_time("Rays: 5\n"), None);
    }
}
