//! A line of a render to an error whose pixels are all done, as its checkpoint keeps it: its
//! pixels and, per pixel, what it took ([`PixelSummary`]) and whether it was open after its
//! first samples (what its neighbours' decisions read), 21 bytes a pixel. Its estimates (149
//! bytes a pixel) are needed only while a pixel may take more samples: kept to the end, a
//! 3840 x 2160 image's were 1.2 GB, past REM's checkpoint quota of 1 GiB a host.
//!
//! The bytes (`FinishedLine.settled`): per pixel, its samples as a little-endian `u32`, its
//! estimated error as a little-endian `f32` and 1 if it was open, else 0.

use super::messages::MessageError;
use crate::render::adaptive::{Adaptive, PixelEstimate};
use crate::render::PixelSummary;

/// Bytes of one pixel of a settled line.
pub const BYTES: usize = 9;

/// What a settled line keeps of a pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SettledPixel {
    /// What it took.
    pub summary: PixelSummary,
    /// Whether its first samples' own estimate was above the target.
    pub open: bool,
}

impl SettledPixel {
    /// What a pixel done keeps.
    pub fn of(e: &PixelEstimate) -> SettledPixel {
        SettledPixel {
            summary: e.summary(),
            open: e.is_open(),
        }
    }
}

/// A settled line's pixels as bytes.
pub fn to_bytes(pixels: impl IntoIterator<Item = SettledPixel>) -> Vec<u8> {
    let mut out = Vec::new();
    for p in pixels {
        out.extend_from_slice(&p.summary.samples.to_le_bytes());
        out.extend_from_slice(&p.summary.error.to_le_bytes());
        out.push(u8::from(p.open));
    }
    out
}

/// The inverse of [`to_bytes`], checking there are exactly `width` pixels and that each is
/// one a render to the error `a` leaves done: its first samples at least, `a`'s most at
/// most, a finite error not below 0 and an open byte of 0 or 1.
pub fn from_bytes(
    bytes: &[u8],
    width: u32,
    a: &Adaptive,
) -> Result<Vec<SettledPixel>, MessageError> {
    let bad = |why: String| MessageError::Settled { width, why };
    if bytes.len() != width as usize * BYTES {
        return Err(bad(format!("{} bytes, not {BYTES} per pixel", bytes.len())));
    }
    let mut out = Vec::with_capacity(width as usize);
    for b in bytes.chunks_exact(BYTES) {
        let samples = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        let error = f32::from_le_bytes([b[4], b[5], b[6], b[7]]);
        let x = out.len();
        if !(a.min_samples..=a.max_samples).contains(&samples) {
            return Err(bad(format!(
                "pixel {x} has {samples} samples, not {} to {}",
                a.min_samples, a.max_samples
            )));
        }
        if !(error.is_finite() && error >= 0.0) {
            return Err(bad(format!("pixel {x} has an error of {error}")));
        }
        if b[8] > 1 {
            return Err(bad(format!("pixel {x} has an open byte of {}", b[8])));
        }
        out.push(SettledPixel {
            summary: PixelSummary { samples, error },
            open: b[8] == 1,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn settled_pixels_round_trip_and_bad_ones_are_refused() {
        let a = Adaptive::new(0.01, Some(4), Some(64));
        let mut noisy = PixelEstimate::default();
        for k in 0..4 {
            noisy.add(DVec3::splat(f64::from(k % 2)));
        }
        noisy.first_samples_in(&a);
        let flat = crate::render::adaptive::constant_pixel(DVec3::splat(0.5), &a);
        let line = [SettledPixel::of(&noisy), SettledPixel::of(&flat)];
        assert!(line[0].open && !line[1].open && line[0].summary.error > 0.0);
        let bytes = to_bytes(line);
        assert_eq!(bytes.len(), 2 * BYTES);
        assert_eq!(from_bytes(&bytes, 2, &a).unwrap(), line);
        let refused =
            |bytes: &[u8], width: u32| from_bytes(bytes, width, &a).unwrap_err().to_string();
        assert!(refused(&bytes, 3).contains("18 bytes, not 9 per pixel"));
        let mut few = bytes.clone();
        few[..4].copy_from_slice(&3u32.to_le_bytes());
        assert!(refused(&few, 2).contains("pixel 0 has 3 samples, not 4 to 64"));
        let mut many = bytes.clone();
        many[9..13].copy_from_slice(&65u32.to_le_bytes());
        assert!(refused(&many, 2).contains("pixel 1 has 65 samples"));
        let mut nan = bytes.clone();
        nan[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
        assert!(refused(&nan, 2).contains("error of NaN"));
        let mut open = bytes;
        open[17] = 2;
        assert!(refused(&open, 2).contains("pixel 1 has an open byte of 2"));
    }
}
