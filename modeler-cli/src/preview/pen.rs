//! Antialiased lines and marks over a view, drawn with `tiny-skia`. Coordinates are the
//! rasterizer's (pixel centres at integers, see [`super::raster`]); segments are clipped
//! in f64 before they reach tiny-skia, so points far outside (or not finite) cost nothing.

use super::raster::{Canvas, ScreenPoint};
use tiny_skia::{LineCap, Paint, PathBuilder, Pixmap, PremultipliedColorU8, Stroke, Transform};

/// How far outside the view a clipped segment may end, in pixels (past a round cap).
const CLIP_MARGIN: f64 = 4.0;

/// An RGB picture of one view that lines, marks and text are drawn on.
pub struct Pen {
    pixmap: Pixmap,
}

fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

fn paint(c: [f32; 3]) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color_rgba8(to_u8(c[0]), to_u8(c[1]), to_u8(c[2]), 255);
    p.anti_alias = true;
    p
}

impl Pen {
    /// A `width x height` picture filled with `background`; None if tiny-skia cannot hold
    /// that size (zero, or more than it can address).
    pub fn new(width: usize, height: usize, background: [f32; 3]) -> Option<Pen> {
        let mut pixmap = Pixmap::new(u32::try_from(width).ok()?, u32::try_from(height).ok()?)?;
        pixmap.fill(tiny_skia::Color::from_rgba8(
            to_u8(background[0]),
            to_u8(background[1]),
            to_u8(background[2]),
            255,
        ));
        Some(Pen { pixmap })
    }

    /// Width and height in pixels.
    pub fn size(&self) -> (usize, usize) {
        (self.pixmap.width() as usize, self.pixmap.height() as usize)
    }

    /// A straight line `width` pixels wide from `a` to `b` (only x and y are used).
    pub fn line(&mut self, a: ScreenPoint, b: ScreenPoint, c: [f32; 3], width: f32) {
        let (w, h) = self.size();
        let Some((a, b)) = clip_to_rect(a, b, w as f64, h as f64, CLIP_MARGIN) else {
            return;
        };
        let mut pb = PathBuilder::new();
        pb.move_to(a[0] as f32 + 0.5, a[1] as f32 + 0.5);
        pb.line_to(b[0] as f32 + 0.5, b[1] as f32 + 0.5);
        let Some(path) = pb.finish() else { return };
        let stroke = Stroke {
            width,
            line_cap: LineCap::Round,
            ..Stroke::default()
        };
        self.pixmap
            .stroke_path(&path, &paint(c), &stroke, Transform::identity(), None);
    }

    /// A cross of arm `r` pixels on the pixel nearest to `p`, one pixel wide and crisp.
    pub fn cross(&mut self, p: ScreenPoint, r: i64, c: [f32; 3]) {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return;
        }
        let (x, y, r) = (p[0].round(), p[1].round(), r as f64);
        // Butt-capped strokes from pixel edge to pixel edge fill whole pixels only.
        for (a, b) in [
            ([x - r - 0.5, y], [x + r + 0.5, y]),
            ([x, y - r - 0.5], [x, y + r + 0.5]),
        ] {
            let mut pb = PathBuilder::new();
            pb.move_to(a[0] as f32 + 0.5, a[1] as f32 + 0.5);
            pb.line_to(b[0] as f32 + 0.5, b[1] as f32 + 0.5);
            if let Some(path) = pb.finish() {
                self.pixmap.stroke_path(
                    &path,
                    &paint(c),
                    &Stroke::default(),
                    Transform::identity(),
                    None,
                );
            }
        }
    }

    /// Copies the pixels a z-buffered canvas of the same size has drawn (those with a depth).
    pub fn faces(&mut self, canvas: &Canvas) {
        let pixels = self.pixmap.pixels_mut();
        for ((px, key), col) in pixels.iter_mut().zip(&canvas.key).zip(&canvas.color) {
            if *key > f32::NEG_INFINITY {
                *px = opaque(col.map(to_u8));
            }
        }
    }

    /// Blends colour `c` over pixel (x, y) with coverage `a` in 0..=1 (for text).
    pub fn blend(&mut self, x: i64, y: i64, c: [f32; 3], a: f32) {
        let (w, h) = self.size();
        if x < 0 || y < 0 || x as usize >= w || y as usize >= h {
            return;
        }
        let a = a.clamp(0.0, 1.0);
        let i = y as usize * w + x as usize;
        let old = self.pixmap.pixels()[i];
        let mix = |o: u8, n: f32| ((o as f32) * (1.0 - a) + to_u8(n) as f32 * a).round() as u8;
        self.pixmap.pixels_mut()[i] = opaque([
            mix(old.red(), c[0]),
            mix(old.green(), c[1]),
            mix(old.blue(), c[2]),
        ]);
    }

    /// The picture as RGB rows, top to bottom.
    pub fn rgb(&self) -> impl Iterator<Item = [u8; 3]> + '_ {
        self.pixmap
            .pixels()
            .iter()
            .map(|p| [p.red(), p.green(), p.blue()])
    }
}

fn opaque(c: [u8; 3]) -> PremultipliedColorU8 {
    // An opaque colour is its own premultiplied form, so this always succeeds.
    PremultipliedColorU8::from_rgba(c[0], c[1], c[2], 255)
        .unwrap_or(PremultipliedColorU8::TRANSPARENT)
}

/// Liang-Barsky clipping of a segment to the pixel centres [-margin, w-1+margin] x
/// [-margin, h-1+margin]; None if nothing is left or a coordinate is not finite.
pub fn clip_to_rect(
    a: ScreenPoint,
    b: ScreenPoint,
    w: f64,
    h: f64,
    margin: f64,
) -> Option<(ScreenPoint, ScreenPoint)> {
    if !a.iter().chain(b.iter()).all(|v| v.is_finite()) {
        return None;
    }
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-d[0], a[0] + margin),
        (d[0], w - 1.0 + margin - a[0]),
        (-d[1], a[1] + margin),
        (d[1], h - 1.0 + margin - a[1]),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: f64| [a[0] + d[0] * t, a[1] + d[1] * t, a[2] + d[2] * t];
    Some((at(t0), at(t1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    const RED: [f32; 3] = [1.0, 0.0, 0.0];

    fn reds(p: &Pen) -> Vec<usize> {
        p.rgb()
            .enumerate()
            .filter(|(_, c)| c[0] > 0)
            .map(|(i, _)| i)
            .collect()
    }

    #[test]
    fn lines_far_outside_are_clipped_cheaply() {
        let mut p = Pen::new(10, 10, [0.0; 3]).unwrap();
        p.line([-1e12, 5.0, 0.0], [1e12, 5.0, 0.0], RED, 1.0);
        // A one-pixel line along the row of pixel centres y = 5 covers that row exactly.
        let lit = reds(&p);
        assert_eq!(lit, (50..60).collect::<Vec<_>>());
        assert!(p.rgb().skip(50).take(10).all(|c| c == [255, 0, 0]));
        let mut q = Pen::new(10, 10, [0.0; 3]).unwrap();
        q.line([f64::NAN, 0.0, 0.0], [1.0, 1.0, 0.0], RED, 1.0);
        q.line([-5.0, -5.0, 0.0], [-1.0, 20.0, 0.0], RED, 1.0);
        assert!(reds(&q).is_empty());
    }

    #[test]
    fn a_slanted_line_is_antialiased() {
        let mut p = Pen::new(20, 20, [0.0; 3]).unwrap();
        p.line([0.0, 0.0, 0.0], [19.0, 7.0, 0.0], RED, 1.0);
        let partial = p.rgb().filter(|c| c[0] > 0 && c[0] < 250).count();
        assert!(partial > 10, "{partial}");
    }

    #[test]
    fn a_cross_is_crisp_and_centred_on_its_pixel() {
        let mut p = Pen::new(9, 9, [0.0; 3]).unwrap();
        p.cross([4.2, 3.8, 0.0], 2, RED);
        let lit = reds(&p);
        let expect: Vec<usize> = vec![
            2 * 9 + 4,
            3 * 9 + 4,
            4 * 9 + 2,
            4 * 9 + 3,
            4 * 9 + 4,
            4 * 9 + 5,
            4 * 9 + 6,
            5 * 9 + 4,
            6 * 9 + 4,
        ];
        assert_eq!(lit, expect);
        assert!(p.rgb().filter(|c| c[0] > 0).all(|c| c == [255, 0, 0]));
    }

    #[test]
    fn faces_take_only_the_pixels_with_a_depth() {
        let mut c = Canvas::new(4, 1, [0.5; 3]);
        c.plot(1, 0, Some(1.0), RED);
        let mut p = Pen::new(4, 1, [0.0; 3]).unwrap();
        p.faces(&c);
        let px: Vec<[u8; 3]> = p.rgb().collect();
        assert_eq!(px, vec![[0, 0, 0], [255, 0, 0], [0, 0, 0], [0, 0, 0]]);
    }
}
