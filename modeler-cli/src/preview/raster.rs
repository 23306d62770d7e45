//! A small z-buffer rasterizer for the faces: filled polygons (any outline, even-odd rule)
//! with a depth per pixel (lines and marks are drawn over them by [`super::pen`]). Pixel centres are at integer coordinates; `key` is a
//! depth value that is affine in screen space and larger when nearer (the view-space depth
//! negated for orthographic views, 1/depth for perspective).

/// An RGB image with a depth buffer.
pub struct Canvas {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Linear RGB per pixel, row by row from the top.
    pub color: Vec<[f32; 3]>,
    /// Depth key per pixel (larger = nearer; the background is the lowest).
    pub key: Vec<f32>,
}

/// A projected vertex: pixel x, pixel y, depth key.
pub type ScreenPoint = [f64; 3];

impl Canvas {
    /// A canvas filled with `background`, with nothing in the depth buffer.
    pub fn new(width: usize, height: usize, background: [f32; 3]) -> Canvas {
        Canvas {
            width,
            height,
            color: vec![background; width * height],
            key: vec![f32::NEG_INFINITY; width * height],
        }
    }

    /// Writes a pixel if it is nearer than what is there (`key` = None draws on top).
    pub fn plot(&mut self, x: i64, y: i64, key: Option<f32>, c: [f32; 3]) {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return;
        }
        let i = y as usize * self.width + x as usize;
        match key {
            Some(k) if k < self.key[i] => {}
            Some(k) => {
                self.key[i] = k;
                self.color[i] = c;
            }
            None => self.color[i] = c,
        }
    }

    /// Fills a polygon with depth test. An edge-on polygon (no area on screen) is skipped.
    pub fn fill_polygon(&mut self, pts: &[ScreenPoint], c: [f32; 3]) {
        if pts.len() < 3 || pts.iter().any(|p| !p.iter().all(|v| v.is_finite())) {
            return;
        }
        // Plane key(x, y) through the centroid, normal by Newell's method.
        let mut n = [0.0f64; 3];
        let mut centroid = [0.0f64; 3];
        for (i, a) in pts.iter().enumerate() {
            let b = pts[(i + 1) % pts.len()];
            n[0] += (a[1] - b[1]) * (a[2] + b[2]);
            n[1] += (a[2] - b[2]) * (a[0] + b[0]);
            n[2] += (a[0] - b[0]) * (a[1] + b[1]);
            for k in 0..3 {
                centroid[k] += a[k] / pts.len() as f64;
            }
        }
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if n[2].abs() <= 1e-9 * len || len == 0.0 {
            return;
        }
        let (kmin, kmax) = pts
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p[2]), hi.max(p[2]))
            });
        let key_at = |x: f64, y: f64| {
            let k = centroid[2] - (n[0] * (x - centroid[0]) + n[1] * (y - centroid[1])) / n[2];
            k.clamp(kmin, kmax) as f32
        };
        let ymin = pts
            .iter()
            .map(|p| p[1])
            .fold(f64::INFINITY, f64::min)
            .ceil()
            .max(0.0) as i64;
        let ymax = pts
            .iter()
            .map(|p| p[1])
            .fold(f64::NEG_INFINITY, f64::max)
            .floor()
            .min(self.height as f64 - 1.0) as i64;
        let mut xs = Vec::new();
        for y in ymin..=ymax {
            let yf = y as f64;
            xs.clear();
            for (i, a) in pts.iter().enumerate() {
                let b = pts[(i + 1) % pts.len()];
                let (lo, hi) = if a[1] < b[1] { (a, &b) } else { (&b, a) };
                if yf >= lo[1] && yf < hi[1] {
                    xs.push(lo[0] + (yf - lo[1]) * (hi[0] - lo[0]) / (hi[1] - lo[1]));
                }
            }
            xs.sort_by(f64::total_cmp);
            for pair in xs.chunks_exact(2) {
                let x0 = pair[0].ceil().max(0.0) as i64;
                let x1 = (pair[1].ceil() - 1.0).min(self.width as f64 - 1.0) as i64;
                for x in x0..=x1 {
                    self.plot(x, y, Some(key_at(x as f64, yf)), c);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RED: [f32; 3] = [1.0, 0.0, 0.0];
    const BLUE: [f32; 3] = [0.0, 0.0, 1.0];

    fn count(c: &Canvas, col: [f32; 3]) -> usize {
        c.color.iter().filter(|p| **p == col).count()
    }

    #[test]
    fn a_square_fills_exactly_its_pixel_centres() {
        let mut c = Canvas::new(10, 10, [0.0; 3]);
        c.fill_polygon(
            &[
                [1.5, 1.5, 0.0],
                [5.5, 1.5, 0.0],
                [5.5, 4.5, 0.0],
                [1.5, 4.5, 0.0],
            ],
            RED,
        );
        assert_eq!(count(&c, RED), 4 * 3);
    }

    #[test]
    fn a_concave_outline_leaves_its_notch_empty() {
        // A U shape: 9x9 minus a 3-wide notch of depth 6 at the top.
        let mut c = Canvas::new(12, 12, [0.0; 3]);
        let u = [
            [0.5, 0.5, 0.0],
            [9.5, 0.5, 0.0],
            [9.5, 9.5, 0.0],
            [6.5, 9.5, 0.0],
            [6.5, 3.5, 0.0],
            [3.5, 3.5, 0.0],
            [3.5, 9.5, 0.0],
            [0.5, 9.5, 0.0],
        ];
        c.fill_polygon(&u, RED);
        assert_eq!(count(&c, RED), 81 - 18);
        assert_eq!(c.color[5 * 12 + 5], [0.0; 3]);
    }

    #[test]
    fn the_nearer_polygon_wins_whatever_the_order() {
        for order in [0, 1] {
            let mut c = Canvas::new(8, 8, [0.0; 3]);
            let near = [
                [0.0, 0.0, 2.0],
                [7.9, 0.0, 2.0],
                [7.9, 7.9, 2.0],
                [0.0, 7.9, 2.0],
            ];
            let far = [
                [0.0, 0.0, 1.0],
                [7.9, 0.0, 1.0],
                [7.9, 7.9, 1.0],
                [0.0, 7.9, 1.0],
            ];
            if order == 0 {
                c.fill_polygon(&near, RED);
                c.fill_polygon(&far, BLUE);
            } else {
                c.fill_polygon(&far, BLUE);
                c.fill_polygon(&near, RED);
            }
            assert_eq!(count(&c, BLUE), 0);
            assert_eq!(count(&c, RED), 64);
        }
    }

    #[test]
    fn interpenetrating_planes_split_along_their_intersection() {
        let mut c = Canvas::new(10, 1, [0.0; 3]);
        // key rises left to right for red, falls for blue; they cross at x = 4.5.
        c.fill_polygon(
            &[
                [-0.5, -0.5, 0.0],
                [9.5, -0.5, 10.0],
                [9.5, 0.5, 10.0],
                [-0.5, 0.5, 0.0],
            ],
            RED,
        );
        c.fill_polygon(
            &[
                [-0.5, -0.5, 10.0],
                [9.5, -0.5, 0.0],
                [9.5, 0.5, 0.0],
                [-0.5, 0.5, 10.0],
            ],
            BLUE,
        );
        assert_eq!(c.color[..5], [BLUE; 5]);
        assert_eq!(c.color[5..], [RED; 5]);
    }
}
