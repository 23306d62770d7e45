//! A [`PixelEstimate`] as bytes, exactly: what the farm's passes carry between hosts and
//! its checkpoints keep, so a pixel goes on elsewhere as if it had never stopped.

use super::{PixelEstimate, BLOCKS};
use glam::DVec3;

impl PixelEstimate {
    /// Bytes of [`PixelEstimate::to_le_bytes`].
    pub const BYTES: usize = 4 + 48 + 12 * BLOCKS as usize + 1;

    /// The estimate exactly, to go on from elsewhere (the farm's passes, its checkpoints):
    /// the count as a little-endian `u32`, then the mean and the sum of squared deviations,
    /// three little-endian `f64` each, each block's mean, three little-endian `f32`, and the
    /// stage byte (1 open, 2 decided, 4 raised).
    pub fn to_le_bytes(&self) -> [u8; Self::BYTES] {
        let mut out = [0u8; Self::BYTES];
        out[..4].copy_from_slice(&self.n.to_le_bytes());
        let wide = self.mean.to_array().into_iter().chain(self.m2.to_array());
        for (i, v) in wide.enumerate() {
            out[4 + 8 * i..12 + 8 * i].copy_from_slice(&v.to_le_bytes());
        }
        for (i, v) in self.blocks.iter().flatten().enumerate() {
            out[52 + 4 * i..56 + 4 * i].copy_from_slice(&v.to_le_bytes());
        }
        out[Self::BYTES - 1] = self.stage;
        out
    }

    /// The inverse of [`PixelEstimate::to_le_bytes`] (bit for bit).
    pub fn from_le_bytes(b: &[u8; Self::BYTES]) -> PixelEstimate {
        let f = |i: usize| {
            let at = 4 + 8 * i;
            f64::from_le_bytes(b[at..at + 8].try_into().unwrap_or_default())
        };
        let g = |i: usize| {
            let at = 52 + 4 * i;
            f32::from_le_bytes(b[at..at + 4].try_into().unwrap_or_default())
        };
        PixelEstimate {
            n: u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            mean: DVec3::new(f(0), f(1), f(2)),
            m2: DVec3::new(f(3), f(4), f(5)),
            blocks: std::array::from_fn(|j| [g(3 * j), g(3 * j + 1), g(3 * j + 2)]),
            stage: b[Self::BYTES - 1],
        }
    }
}
