//! The one decision a pixel rendered to an error takes from its neighbours: after its first
//! samples, it goes on (it is raised) when a pixel within [`RADIUS`] of it, across or down,
//! itself included, is open (its first samples' own estimate above the target:
//! [`PixelEstimate::is_open`]); else it stops there.
//!
//! Why: a pixel whose first samples all miss a thin feature (a checker's edge across a
//! sliver of it, a penumbra's rim) agrees with itself and stops with its error left; alone it
//! needed 16 first samples to make that rare. Its neighbours along the feature mostly hit it,
//! so the neighbourhood sees the feature after 4 samples each, and flat pixels away from any
//! feature stop at 4 (measured in docs/renderer.md, "The neighbourhood": the penumbra
//! reaches RMSE 0.0094 with 5.8 samples a pixel, where 16 a pixel alone gave 0.0082).
//! Openness depends on a pixel's own first samples only, so the decision is the same
//! whatever order the lines come in ([`crate::render::pass`]; the farm decides a line once
//! the lines within [`RADIUS`] of it have their first samples).

use super::adaptive::{Adaptive, PixelEstimate};

/// How far a pixel's neighbourhood reaches: the pixels within 2 of it across and down (a
/// 5 x 5 square). With 1 (3 x 3) a checker's edge along a row, missed by each pixel's first
/// 4 samples about half the time, left runs of three pixels that no neighbour raised (gloss
/// at E = 0.005: RMSE 0.0034 against 0.0019 deciding alone); with 2 it was 0.0019.
pub const RADIUS: u32 = 2;

/// Which pixels of a line its neighbourhoods raise: `near` holds which pixels were open
/// ([`PixelEstimate::is_open`]) in the lines within [`RADIUS`] of it that the image
/// has (the line itself among them), each line with its first samples; column x is raised
/// when one of them has an open pixel within [`RADIUS`] columns of x.
pub fn raised_columns<'a>(near: impl IntoIterator<Item = &'a [bool]>, width: usize) -> Vec<bool> {
    let mut open = vec![false; width];
    for line in near {
        for (o, &e) in open.iter_mut().zip(line) {
            *o |= e;
        }
    }
    let r = RADIUS as usize;
    (0..width)
        .map(|x| open[x.saturating_sub(r)..(x + r + 1).min(width)].contains(&true))
        .collect()
}

/// The pixels of a line that wait for their decision decided: raised when one of the lines
/// `near` it (which pixels of the lines within [`RADIUS`] of it were open, itself among
/// them: [`raised_columns`]) has an open pixel within [`RADIUS`] columns, else stopped.
pub fn decide_line<'a>(
    line: &mut [PixelEstimate],
    near: impl IntoIterator<Item = &'a [bool]>,
    a: &Adaptive,
) {
    let raised = raised_columns(near, line.len());
    for (e, &r) in line.iter_mut().zip(&raised) {
        if e.awaits_decision(a) {
            e.decide(r);
        }
    }
}

/// Every line of a `width`-pixel image (`estimates`, row by row, each pixel with its first
/// samples) decided by [`decide_line`] from the open pixels of the whole image.
pub fn decide_image(estimates: &mut [PixelEstimate], width: usize, a: &Adaptive) {
    let width = width.max(1);
    let open: Vec<bool> = estimates.iter().map(PixelEstimate::is_open).collect();
    let rows: Vec<&[bool]> = open.chunks(width).collect();
    let r = RADIUS as usize;
    for (y, row) in estimates.chunks_mut(width).enumerate() {
        let near = &rows[y.saturating_sub(r)..(y + r + 1).min(rows.len())];
        decide_line(row, near.iter().copied(), a);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A column is raised when an open pixel lies within two columns of it in any line given.
    #[test]
    fn open_pixels_raise_the_columns_within_two() {
        let (o, c) = (true, false);
        let above = [c, c, c, c, c, c, c, c, c];
        let line = [o, c, c, c, c, c, c, c, c];
        let below = [c, c, c, c, c, c, c, o, c];
        let raised = raised_columns([&above[..], &line[..], &below[..]], 9);
        assert_eq!(raised, [o, o, o, c, c, o, o, o, o]);
        assert_eq!(raised_columns([&above[..]], 9), [c; 9]);
        assert!(raised_columns(std::iter::empty(), 3).iter().all(|r| !r));
    }
}
