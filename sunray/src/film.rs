//! The image being rendered and its output formats, chosen by file extension: `.png` (8-bit
//! RGB), `.ppm` (binary P6) and `.pfm` (32-bit float RGB, for error measurement). Colours are
//! linear; 8-bit output clamps to [0, 1] and rounds. Files are written to a temporary name in
//! the same directory and renamed, so a failed write never leaves a half image. A PNG can
//! also be made in memory, of the image or of a copy shrunk by box averaging (what a farm
//! job shows on remd's web page).

use std::io::Write;
use std::path::{Path, PathBuf};

/// Why an image could not be written.
#[derive(Debug, thiserror::Error)]
pub enum FilmError {
    /// The file's extension is not png, ppm, pfm or exr; the text is the (lower-cased) extension.
    #[error("unknown image format {0:?} (use .png, .ppm, .pfm or .exr)")]
    UnknownFormat(String),
    /// Writing or renaming the file failed.
    #[error("writing {path}: {source}")]
    Io {
        /// The file that was being written.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The PNG (or OpenEXR) encoder failed.
    #[error("encoding {} {path}: {source}", if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) { "OpenEXR" } else { "PNG" })]
    Png {
        /// The file that was being written.
        path: PathBuf,
        /// The encoder's error.
        source: image::ImageError,
    },
}

/// An image file format, chosen by the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// 8-bit RGB PNG (clamped to [0, 1] and rounded).
    Png,
    /// Binary PPM (P6), 8-bit, clamped and rounded like PNG.
    Ppm,
    /// Portable float map: 32-bit linear RGB, little-endian, rows stored bottom to top.
    Pfm,
    /// OpenEXR: 32-bit float linear RGB, the values PFM holds (the `image` crate's encoder).
    Exr,
}

impl Format {
    /// The format the path's extension names (case-insensitive); other extensions are an error.
    pub fn from_path(path: &Path) -> Result<Format, FilmError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        match ext.as_str() {
            "png" => Ok(Format::Png),
            "ppm" => Ok(Format::Ppm),
            "pfm" => Ok(Format::Pfm),
            "exr" => Ok(Format::Exr),
            _ => Err(FilmError::UnknownFormat(ext)),
        }
    }
}

/// A linear RGB image, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Pixels per row.
    pub width: u32,
    /// Rows (scanlines).
    pub height: u32,
    /// Linear RGB, row-major from the top-left pixel, `width * height` entries.
    pub pixels: Vec<[f32; 3]>,
}

impl Film {
    /// A black image of the given size.
    pub fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            pixels: vec![[0.0; 3]; width as usize * height as usize],
        }
    }

    /// Stores a rendered scanline.
    pub fn set_line(&mut self, y: u32, line: &[[f32; 3]]) {
        let w = self.width as usize;
        let start = y as usize * w;
        self.pixels[start..start + w].copy_from_slice(&line[..w]);
    }

    /// 8-bit RGB, clamped and rounded.
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.pixels.iter().flat_map(|p| p.map(to_byte)).collect()
    }

    /// The image as an 8-bit RGB PNG, in memory.
    pub fn to_png(&self) -> Result<Vec<u8>, image::ImageError> {
        let mut out = Vec::new();
        let enc = image::codecs::png::PngEncoder::new(&mut out);
        image::ImageEncoder::write_image(
            enc,
            &self.to_rgb8(),
            self.width,
            self.height,
            image::ExtendedColorType::Rgb8,
        )?;
        Ok(out)
    }

    /// The image as OpenEXR: linear 32-bit float RGB, row 0 at the top, as rendered.
    pub fn to_exr(&self) -> Result<Vec<u8>, image::ImageError> {
        let floats: Vec<f32> = self.pixels.iter().flatten().copied().collect();
        let mut out = std::io::Cursor::new(Vec::new());
        let enc = image::codecs::openexr::OpenExrEncoder::new(&mut out);
        image::ImageEncoder::write_image(
            enc,
            &bytemuck_f32(&floats),
            self.width,
            self.height,
            image::ExtendedColorType::Rgb32F,
        )?;
        Ok(out.into_inner())
    }

    /// The image shrunk by a whole `factor` each way (0 counts as 1): each pixel is the mean
    /// of a `factor` x `factor` box of this one, over the pixels of the box inside the image
    /// (the last column and row of boxes may be cut), so `width.div_ceil(factor)` by
    /// `height.div_ceil(factor)`. Values are clamped to [0, 1] (NaN as 0) before averaging,
    /// as 8-bit output shows them, so a highlight does not bleed into its box.
    pub fn downscaled(&self, factor: u32) -> Film {
        let f = factor.max(1) as usize;
        let (sw, sh) = (self.width as usize, self.height as usize);
        let (w, h) = (sw.div_ceil(f), sh.div_ceil(f));
        let mut out = Film::new(w as u32, h as u32);
        for (y, row) in self.pixels.chunks(sw.max(1)).enumerate() {
            let Some(sums) = out.pixels.get_mut(y / f * w..(y / f + 1) * w) else {
                break;
            };
            for (sum, cell) in sums.iter_mut().zip(row.chunks(f)) {
                for p in cell {
                    for (s, v) in sum.iter_mut().zip(p) {
                        *s += to_unit(*v);
                    }
                }
            }
        }
        for (i, p) in out.pixels.iter_mut().enumerate() {
            let (x, y) = (i % w * f, i / w * f);
            let n = (f.min(sw - x) * f.min(sh - y)) as f32;
            *p = p.map(|v| v / n);
        }
        out
    }

    /// Writes the image in the format its extension names, via a temporary file.
    pub fn write(&self, path: &Path) -> Result<(), FilmError> {
        let format = Format::from_path(path)?;
        let bytes = self.encode(format, path)?;
        write_atomically(path, &bytes)
    }

    /// The image's bytes in `format`; `path` only names the file in errors.
    pub fn encode(&self, format: Format, path: &Path) -> Result<Vec<u8>, FilmError> {
        let (w, h) = (self.width, self.height);
        Ok(match format {
            Format::Png => self.to_png().map_err(|source| FilmError::Png {
                path: path.to_path_buf(),
                source,
            })?,
            Format::Ppm => {
                let mut out = format!("P6\n{w} {h}\n255\n").into_bytes();
                out.extend(self.to_rgb8());
                out
            }
            Format::Exr => self.to_exr().map_err(|source| FilmError::Png {
                path: path.to_path_buf(),
                source,
            })?,
            Format::Pfm => {
                // PFM rows run bottom to top; a negative scale means little-endian.
                let mut out = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
                for row in (0..h as usize).rev() {
                    for p in &self.pixels[row * w as usize..(row + 1) * w as usize] {
                        for c in p {
                            out.extend_from_slice(&c.to_le_bytes());
                        }
                    }
                }
                out
            }
        })
    }
}

/// Native-endian bytes of `floats`, as the `image` encoders take 32-bit float samples.
fn bytemuck_f32(floats: &[f32]) -> Vec<u8> {
    floats.iter().flat_map(|f| f.to_ne_bytes()).collect()
}

fn to_byte(v: f32) -> u8 {
    (to_unit(v) * 255.0).round() as u8
}

/// A linear value as 8-bit output shows it: clamped to [0, 1], NaN as 0.
fn to_unit(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

/// Writes `bytes` to `path` through a temporary file in the same directory and a rename.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), FilmError> {
    let io = |source| FilmError::Io {
        path: path.to_path_buf(),
        source,
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn film() -> Film {
        let mut f = Film::new(2, 2);
        f.pixels = vec![
            [0.0, 0.5, 1.0],
            [2.0, -1.0, 0.2],
            [0.1, 0.1, 0.1],
            [1.0, 1.0, 1.0],
        ];
        f
    }

    /// OpenEXR holds the linear floats as rendered, highlights and negatives included: read
    /// back with the `image` crate they are the film's (and the PFM's) bit for bit.
    #[test]
    fn exr_reads_back_the_linear_values() {
        let mut f = Film::new(3, 2);
        f.pixels = vec![
            [0.0, 0.5, 1.0],
            [2.5, -1.0, 0.2],
            [0.1, 1e-7, 3.25],
            [1.0, 1.0, 1.0],
            [f32::MIN_POSITIVE, 0.333_333_34, 7.0],
            [0.0, 0.0, 0.0],
        ];
        let bytes = f.encode(Format::Exr, Path::new("x.exr")).unwrap();
        let back = image::load_from_memory(&bytes).unwrap().to_rgb32f();
        assert_eq!((back.width(), back.height()), (3, 2));
        let read: Vec<[f32; 3]> = back.pixels().map(|p| p.0).collect();
        assert_eq!(read, f.pixels);
        assert_eq!(Format::from_path(Path::new("A.EXR")).unwrap(), Format::Exr);
    }

    #[test]
    fn bytes_are_clamped_and_rounded() {
        assert_eq!(&film().to_rgb8()[..6], &[0, 128, 255, 255, 0, 51]);
    }

    #[test]
    fn formats_by_extension_and_round_trip_png() {
        let dir = std::env::temp_dir().join(format!("sunray-film-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = dir.join("a.png");
        film().write(&png).unwrap();
        let back = image::open(&png).unwrap().to_rgb8();
        assert_eq!(back.as_raw(), &film().to_rgb8());
        let ppm = dir.join("a.ppm");
        film().write(&ppm).unwrap();
        assert!(std::fs::read(&ppm).unwrap().starts_with(b"P6\n2 2\n255\n"));
        let pfm = dir.join("a.pfm");
        film().write(&pfm).unwrap();
        let bytes = std::fs::read(&pfm).unwrap();
        assert_eq!(bytes.len(), "PF\n2 2\n-1.0\n".len() + 4 * 3 * 4);
        assert!(matches!(
            film().write(&dir.join("a.gif")),
            Err(FilmError::UnknownFormat(_))
        ));
        // No temporary files are left behind.
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert_eq!(left.len(), 3);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn downscaling_averages_whole_and_cut_boxes() {
        // 3x3 by 2: the top-left box has four pixels, the right and bottom ones two, the
        // corner one. Values are clamped first (2.0 counts as 1, -1 as 0).
        let mut f = Film::new(3, 3);
        let v = [0.0, 0.2, 2.0, 0.4, 0.6, 0.5, -1.0, 0.8, 0.3];
        f.pixels = v.iter().map(|&x| [x, x, 1.0]).collect();
        let small = f.downscaled(2);
        assert_eq!((small.width, small.height), (2, 2));
        let got: Vec<f32> = small.pixels.iter().map(|p| p[0]).collect();
        let want = [
            (0.0 + 0.2 + 0.4 + 0.6) / 4.0,
            (1.0 + 0.5) / 2.0,
            0.8 / 2.0,
            0.3,
        ];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-6, "{got:?} != {want:?}");
        }
        assert!(small.pixels.iter().all(|p| p[2] == 1.0));
        // Factor 1 (and 0) only clamps: the same bytes as the image's own.
        assert_eq!(f.downscaled(1).to_rgb8(), f.to_rgb8());
        assert_eq!(f.downscaled(0).to_rgb8(), f.to_rgb8());
        let png = image::load_from_memory(&small.to_png().unwrap()).unwrap();
        assert_eq!((png.width(), png.height()), (2, 2));
    }

    #[test]
    fn failed_write_leaves_no_file() {
        let path = Path::new("/nonexistent-dir-sunray/x.png");
        assert!(film().write(path).is_err());
        assert!(!path.exists());
    }
}
