//! A log-log line plot drawn with `plotters` into a bitmap: a title, labelled axes with
//! tick values at the decades (and 2 and 5 between them where there is room), one coloured
//! line with round markers per series, dashed guide lines of slope -1/2 (error proportional
//! to 1/sqrt(time)) through each series' first point, and a legend naming every series.
//! Text is set in DejaVu Sans, embedded in the binary (assets/fonts/), so no system font is
//! needed.

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// One series: its legend name, its colour and (x, y) points, both positive.
pub struct Series {
    /// The name in the legend.
    pub name: String,
    /// RGB colour of the line and its markers.
    pub colour: [u8; 3],
    /// The points, in drawing order; points with x or y not positive are skipped.
    pub points: Vec<(f64, f64)>,
}

/// What the picture says: its title and the two axis labels.
pub struct Labels<'a> {
    /// The line above the plot.
    pub title: &'a str,
    /// Under the x axis.
    pub x: &'a str,
    /// Beside the y axis.
    pub y: &'a str,
}

/// Why a plot could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// The embedded font was not accepted by the font rasterizer.
    #[error("the embedded font (DejaVu Sans) cannot be read")]
    Font,
    /// Drawing failed inside `plotters`.
    #[error("drawing the plot: {0}")]
    Draw(String),
    /// Encoding or writing the PNG failed.
    #[error("writing the plot: {0}")]
    Save(#[from] image::ImageError),
}

const W: u32 = 900;
const H: u32 = 600;
/// The font family name the embedded font is registered under.
pub(crate) const FONT: &str = "dejavu-sans";
static FONT_BYTES: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// Registers the embedded font with plotters once per process.
pub(crate) fn register_font() -> Result<(), PlotError> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

pub(crate) fn draw_err<E: std::fmt::Debug>(e: E) -> PlotError {
    PlotError::Draw(format!("{e:?}"))
}

/// A tick value as a plain decimal with the digits it needs (0.001, 0.02, 1, 50); only
/// 1, 2 and 5 times a power of ten are labelled, so that a range of one decade, where
/// plotters puts a tick at every step, does not crowd its labels into each other.
fn tick(v: &f64) -> String {
    if !(v.is_finite() && *v > 0.0) {
        return String::new();
    }
    let mut e = v.log10().floor();
    let mut m = (v / 10f64.powf(e)).round();
    if m >= 10.0 {
        (e, m) = (e + 1.0, 1.0);
    }
    if ![1.0, 2.0, 5.0].contains(&m) {
        return String::new();
    }
    let decimals = (-e).max(0.0) as usize;
    format!("{:.*}", decimals, m * 10f64.powf(e))
}

/// The slope -1/2 guide through `points`' first point, out to its last x.
fn guide(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let (Some(&(fx, fy)), Some(&(lx, _))) = (points.first(), points.last()) else {
        return Vec::new();
    };
    vec![(fx, fy), (lx, fy * (lx / fx).powf(-0.5))]
}

/// Draws the series on log-log axes into a PNG at `path` (written to a temporary name, then
/// renamed, so a reader never sees half a picture).
pub fn loglog(series: &[Series], labels: &Labels, path: &Path) -> Result<(), PlotError> {
    register_font()?;
    let series: Vec<Series> = series
        .iter()
        .map(|s| Series {
            name: s.name.clone(),
            colour: s.colour,
            points: s
                .points
                .iter()
                .copied()
                .filter(|p| p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite())
                .collect(),
        })
        .collect();
    let mut buf = vec![255u8; (W * H * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (W, H)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        draw(&root, &series, labels)?;
        root.present().map_err(draw_err)?;
    }
    save_png(buf, (W, H), path)
}

/// Writes an RGB bitmap of `size` as a PNG at `path` (to a temporary name, then renamed, so a
/// reader never sees half a picture).
pub(crate) fn save_png(buf: Vec<u8>, (w, h): (u32, u32), path: &Path) -> Result<(), PlotError> {
    let img = image::RgbImage::from_raw(w, h, buf)
        .ok_or_else(|| PlotError::Draw("the bitmap has the wrong size".into()))?;
    let tmp = path.with_extension("tmp.png");
    img.save(&tmp)?;
    std::fs::rename(&tmp, path).map_err(|e| PlotError::Save(image::ImageError::IoError(e)))
}

fn draw(
    root: &DrawingArea<BitMapBackend, Shift>,
    series: &[Series],
    labels: &Labels,
) -> Result<(), PlotError> {
    // Whole decades around every point and guide.
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    let all = series
        .iter()
        .flat_map(|s| s.points.iter().copied().chain(guide(&s.points)));
    for (x, y) in all {
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
    // A hair wider than the decades, so that the end decades keep their tick labels.
    let xr = (10f64.powf(x0) * 0.999..10f64.powf(x1) * 1.001).log_scale();
    let yr = (10f64.powf(y0) * 0.999..10f64.powf(y1) * 1.001).log_scale();

    let mut chart = ChartBuilder::on(root)
        .caption(labels.title, (FONT, 24))
        .margin(16)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(xr, yr)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc(labels.x)
        .y_desc(labels.y)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 18))
        .bold_line_style(RGBColor(200, 200, 200))
        .light_line_style(RGBColor(242, 242, 242))
        .draw()
        .map_err(draw_err)?;

    for s in series {
        let c = RGBColor(s.colour[0], s.colour[1], s.colour[2]);
        chart
            .draw_series(DashedLineSeries::new(
                guide(&s.points),
                8,
                6,
                c.mix(0.45).stroke_width(2),
            ))
            .map_err(draw_err)?;
    }
    for s in series {
        let c = RGBColor(s.colour[0], s.colour[1], s.colour[2]);
        chart
            .draw_series(LineSeries::new(s.points.iter().copied(), c.stroke_width(2)))
            .map_err(draw_err)?
            .label(s.name.as_str())
            .legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (24, 0)], c.stroke_width(2))
                    + Circle::new((12, 0), 4, c.filled())
            });
        chart
            .draw_series(s.points.iter().map(|&p| Circle::new(p, 4, c.filled())))
            .map_err(draw_err)?;
    }
    // A legend entry for the guides (drawn above, one per series, in its tint).
    let grey = RGBColor(120, 120, 120);
    chart
        .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())
        .map_err(draw_err)?
        .label("slope −1/2 (error ∝ 1/√time)")
        .legend(move |(x, y)| {
            EmptyElement::at((x, y))
                + PathElement::new(vec![(0, 0), (8, 0)], grey.mix(0.6).stroke_width(2))
                + PathElement::new(vec![(14, 0), (24, 0)], grey.mix(0.6).stroke_width(2))
        });
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, 15))
        .background_style(WHITE.mix(0.9))
        .border_style(RGBColor(160, 160, 160))
        .margin(10)
        .draw()
        .map_err(draw_err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_read_as_plain_decimals() {
        assert_eq!(tick(&0.001), "0.001");
        assert_eq!(tick(&0.0020000000000000005), "0.002");
        assert_eq!(tick(&1.0), "1");
        assert_eq!(tick(&50.0), "50");
        assert_eq!(tick(&0.0003), "");
        assert_eq!(tick(&0.09999999999), "0.1");
    }

    #[test]
    fn draws_series_in_their_colours_with_text() {
        let dir = std::env::temp_dir().join(format!("sunray-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.png");
        let s = Series {
            name: "red".into(),
            colour: [200, 0, 0],
            points: vec![(0.01, 1.0), (0.1, 0.3), (1.0, 0.1)],
        };
        let labels = Labels {
            title: "a title",
            x: "time (s)",
            y: "RMS error",
        };
        loglog(&[s], &labels, &path).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!((img.width(), img.height()), (W, H));
        let red = img.pixels().filter(|p| p.0 == [200, 0, 0]).count();
        assert!(red > 100, "{red}");
        // Text was drawn: antialiased glyphs leave grey pixels that are neither white, the
        // grid's greys nor the series' colour.
        let greys = img
            .pixels()
            .filter(|p| p.0[0] == p.0[1] && p.0[1] == p.0[2] && p.0[0] > 20 && p.0[0] < 150)
            .count();
        assert!(greys > 200, "{greys}");
        assert!(!path.with_extension("tmp.png").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
