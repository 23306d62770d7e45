//! The view labels, set in DejaVu Sans (embedded from assets/fonts/, so no system font is
//! needed) and rasterized with antialiasing by `ab_glyph`.

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use std::sync::OnceLock;

static FONT_BYTES: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// The embedded font, parsed once; None only if the embedded file were not a font.
fn font() -> Option<&'static FontRef<'static>> {
    static FONT: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(FONT_BYTES).ok())
        .as_ref()
}

/// Calls `plot(x, y, coverage)` for each pixel `text` touches, its top-left corner at
/// (x, y), `px` pixels from ascent to descent; coverage is in 0..=1.
pub fn draw_text(text: &str, x: f32, y: f32, px: f32, plot: &mut dyn FnMut(i64, i64, f32)) {
    let Some(font) = font() else { return };
    let scale = PxScale::from(px);
    let scaled = font.as_scaled(scale);
    let baseline = y + scaled.ascent();
    let mut caret = x;
    let mut prev = None;
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = prev {
            caret += scaled.kern(p, id);
        }
        prev = Some(id);
        let glyph = id.with_scale_and_position(scale, point(caret, baseline));
        caret += scaled.h_advance(id);
        if let Some(outline) = font.outline_glyph(glyph) {
            let b = outline.px_bounds();
            outline.draw(|gx, gy, cov| {
                plot(b.min.x as i64 + gx as i64, b.min.y as i64 + gy as i64, cov);
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_font_draws_every_label_inside_its_box() {
        assert!(font().is_some());
        for label in ["FRONT", "TOP", "SIDE", "PERSPECTIVE"] {
            let (mut ink, mut right, mut bottom) = (0.0f32, 0i64, 0i64);
            draw_text(label, 4.0, 4.0, 14.0, &mut |x, y, c| {
                // Antialiasing may bleed one pixel past the box's corner.
                assert!(x >= 3 && y >= 3, "{label}: ({x}, {y})");
                ink += c;
                right = right.max(x);
                bottom = bottom.max(y);
            });
            // Capitals about 10 pixels high and 8 wide each: some ink, within the box.
            assert!(ink > 20.0 * label.len() as f32, "{label}: {ink}");
            assert!(
                bottom <= 4 + 14 && right <= 4 + 11 * label.len() as i64,
                "{label}"
            );
        }
    }
}
