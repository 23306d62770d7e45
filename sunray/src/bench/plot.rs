//! A log-log line plot drawn with the `image` crate alone (no fonts): axes with a tick at
//! every power of ten, one coloured polyline with square markers per series, and dashed
//! guide lines of slope -1/2 (error proportional to 1/sqrt(time)). The legend lives in the
//! text that goes with the picture (docs/accuracy.md names each colour).

use image::{Rgb, RgbImage};
use std::path::Path;

/// One series: its colour and (x, y) points, both positive.
pub struct Series {
    pub colour: [u8; 3],
    pub points: Vec<(f64, f64)>,
}

const W: u32 = 720;
const H: u32 = 480;
const MARGIN: f64 = 40.0;

/// Draws the series on log-log axes into a PNG at `path` (written to a temporary name, then
/// renamed).
pub fn loglog(series: &[Series], path: &Path) -> Result<(), image::ImageError> {
    let mut img = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    let pts = series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|p| p.0 > 0.0 && p.1 > 0.0);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts {
        x0 = x0.min(x.log10());
        x1 = x1.max(x.log10());
        y0 = y0.min(y.log10());
        y1 = y1.max(y.log10());
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let (x0, x1) = (x0.floor(), x1.ceil().max(x0.floor() + 1.0));
    let (y0, y1) = (y0.floor(), y1.ceil().max(y0.floor() + 1.0));
    let to_px = |x: f64, y: f64| -> (f64, f64) {
        let px = MARGIN + (x.log10() - x0) / (x1 - x0) * (W as f64 - 2.0 * MARGIN);
        let py = H as f64 - MARGIN - (y.log10() - y0) / (y1 - y0) * (H as f64 - 2.0 * MARGIN);
        (px, py)
    };
    let grey = Rgb([200, 200, 200]);
    let black = Rgb([0, 0, 0]);
    // Decade grid lines and ticks.
    for d in (x0 as i32)..=(x1 as i32) {
        let (px, _) = to_px(10f64.powi(d), 10f64.powi(y0 as i32));
        line(&mut img, (px, MARGIN), (px, H as f64 - MARGIN), grey, 1);
        line(
            &mut img,
            (px, H as f64 - MARGIN),
            (px, H as f64 - MARGIN + 8.0),
            black,
            1,
        );
    }
    for d in (y0 as i32)..=(y1 as i32) {
        let (_, py) = to_px(10f64.powi(x0 as i32), 10f64.powi(d));
        line(&mut img, (MARGIN, py), (W as f64 - MARGIN, py), grey, 1);
        line(&mut img, (MARGIN - 8.0, py), (MARGIN, py), black, 1);
    }
    // Axes.
    line(
        &mut img,
        (MARGIN, H as f64 - MARGIN),
        (W as f64 - MARGIN, H as f64 - MARGIN),
        black,
        1,
    );
    line(
        &mut img,
        (MARGIN, MARGIN),
        (MARGIN, H as f64 - MARGIN),
        black,
        1,
    );
    for s in series {
        let c = Rgb(s.colour);
        // The 1/sqrt guide through the series' first point, dashed, in a light tint.
        if let Some(&(fx, fy)) = s.points.first() {
            let tint = Rgb(s.colour.map(|v| ((v as u16 + 2 * 255) / 3) as u8));
            let last_x = s.points.last().map_or(fx, |p| p.0);
            let steps = 40;
            for k in 0..steps {
                if k % 2 == 1 {
                    continue;
                }
                let xa = fx * (last_x / fx).powf(k as f64 / steps as f64);
                let xb = fx * (last_x / fx).powf((k + 1) as f64 / steps as f64);
                let ya = fy * (xa / fx).powf(-0.5);
                let yb = fy * (xb / fx).powf(-0.5);
                line(&mut img, to_px(xa, ya), to_px(xb, yb), tint, 1);
            }
        }
        for w in s.points.windows(2) {
            line(&mut img, to_px(w[0].0, w[0].1), to_px(w[1].0, w[1].1), c, 2);
        }
        for &(x, y) in &s.points {
            let (px, py) = to_px(x, y);
            for dy in -3i32..=3 {
                for dx in -3i32..=3 {
                    put(&mut img, px as i32 + dx, py as i32 + dy, c);
                }
            }
        }
    }
    let tmp = path.with_extension("tmp.png");
    img.save(&tmp)?;
    std::fs::rename(&tmp, path).map_err(image::ImageError::IoError)
}

fn put(img: &mut RgbImage, x: i32, y: i32, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

/// A straight line `width` pixels thick.
fn line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), c: Rgb<u8>, width: i32) {
    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as i32).max(1);
    for k in 0..=n {
        let t = k as f64 / n as f64;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        for d in 0..width {
            put(img, x as i32 + d, y as i32, c);
            put(img, x as i32, y as i32 + d, c);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_series_in_their_colours() {
        let dir = std::env::temp_dir().join(format!("sunray-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.png");
        let s = Series {
            colour: [200, 0, 0],
            points: vec![(0.01, 1.0), (0.1, 0.3), (1.0, 0.1)],
        };
        loglog(&[s], &path).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!((img.width(), img.height()), (W, H));
        let red = img.pixels().filter(|p| p.0 == [200, 0, 0]).count();
        assert!(red > 100, "{red}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
