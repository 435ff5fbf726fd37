//! Linear-radiance RGB images: the frames gibake renders and the CPU reference
//! produces.
//!
//! - EXR files hold linear radiance in channels `R`, `G`, `B` as 32-bit
//!   floats, no tone mapping; row 0 is the top of the image.
//! - PNG files are previews: exposure-normalised, ACES-fitted tone map, sRGB.
//! - [`rel_mse`] is the error metric used throughout the project's tests and
//!   reports: per pixel `(x−r)²/(r²+0.01)` averaged over pixels and channels.

use std::path::{Path, PathBuf};

use glam::Vec3;

/// Errors reading or writing images. Each names the file.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The EXR library failed (I/O, damaged file, unsupported layout).
    #[error("{path}: cannot read/write EXR: {source}")]
    Exr {
        /// The file.
        path: PathBuf,
        /// The EXR error.
        #[source]
        source: exr::error::Error,
    },
    /// The file has no R, G, B float channels or inconsistent sizes.
    #[error("{path}: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Writing a PNG failed.
    #[cfg(feature = "png")]
    #[error("{path}: cannot write PNG: {source}")]
    Png {
        /// The file.
        path: PathBuf,
        /// The PNG encoder's error.
        #[source]
        source: png::EncodingError,
    },
    /// Plain I/O failure.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

/// A linear-radiance RGB image, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` pixels.
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Image {
            width,
            height,
            pixels: vec![Vec3::ZERO; width as usize * height as usize],
        }
    }

    /// Builds an image from tightly packed RGBA f32 texels (as read back from a GPU).
    pub fn from_rgba_f32(width: u32, height: u32, rgba: &[f32]) -> Self {
        let pixels = rgba
            .chunks_exact(4)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect();
        Image {
            width,
            height,
            pixels,
        }
    }

    /// Pixel at `(x, y)`.
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    /// Sets pixel `(x, y)`.
    pub fn set(&mut self, x: u32, y: u32, v: Vec3) {
        self.pixels[(y * self.width + x) as usize] = v;
    }

    /// Mean of all pixels.
    pub fn mean(&self) -> Vec3 {
        let s: glam::DVec3 = self.pixels.iter().map(|p| p.as_dvec3()).sum();
        (s / self.pixels.len().max(1) as f64).as_vec3()
    }

    /// Pixel-wise `self − other` (same size required).
    pub fn sub(&self, other: &Image) -> Image {
        let pixels = self
            .pixels
            .iter()
            .zip(&other.pixels)
            .map(|(a, b)| *a - *b)
            .collect();
        Image {
            width: self.width,
            height: self.height,
            pixels,
        }
    }

    /// Writes an EXR with 32-bit float `R`, `G`, `B` channels (linear, no tone
    /// map): scan lines (not tiles, which some minimal readers do not open),
    /// lossless ZIP compression of 16 lines per block, increasing line order.
    pub fn write_exr(&self, path: &Path) -> Result<(), ImageError> {
        use exr::prelude::*;
        let (w, h) = (self.width as usize, self.height as usize);
        let encoding = Encoding {
            compression: Compression::ZIP16,
            blocks: Blocks::ScanLines,
            line_order: LineOrder::Increasing,
        };
        let img = exr::image::Image::from_encoded_channels(
            (w, h),
            encoding,
            SpecificChannels::rgb(|pos: Vec2<usize>| {
                let p = self.pixels[pos.y() * w + pos.x()];
                (p.x, p.y, p.z)
            }),
        );
        img.write().to_file(path).map_err(|source| ImageError::Exr {
            path: path.to_owned(),
            source,
        })
    }

    /// Reads an EXR's `R`, `G`, `B` channels (any sample type) as f32.
    pub fn read_exr(path: &Path) -> Result<self::Image, ImageError> {
        use exr::prelude::*;
        let img = read_first_rgba_layer_from_file(
            path,
            |res, _| {
                let (w, h) = (res.width(), res.height());
                (w, h, vec![Vec3::ZERO; w * h])
            },
            |(w, _h, px): &mut (usize, usize, Vec<Vec3>),
             pos,
             (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b);
            },
        )
        .map_err(|source| ImageError::Exr {
            path: path.to_owned(),
            source,
        })?;
        let (w, h, pixels) = img.layer_data.channel_data.pixels;
        Ok(self::Image {
            width: w as u32,
            height: h as u32,
            pixels,
        })
    }

    /// Writes a tone-mapped sRGB PNG preview. `exposure` scales radiance
    /// before the tone curve; `None` picks one that maps the 99th percentile
    /// of luminance to 0.8. (Cargo feature `png`, on by default.)
    #[cfg(feature = "png")]
    pub fn write_png(&self, path: &Path, exposure: Option<f32>) -> Result<(), ImageError> {
        let exposure = exposure.unwrap_or_else(|| self.auto_exposure());
        write_rgb8_png(path, self.width, self.height, &self.preview_rgb8(exposure))
    }

    /// The tone-mapped sRGB preview [`Image::write_png`] writes, as 8-bit
    /// RGB bytes (rows top to bottom): radiance × `exposure`, the ACES
    /// curve, sRGB encoding. (Cargo feature `png`, on by default.)
    #[cfg(feature = "png")]
    pub fn preview_rgb8(&self, exposure: f32) -> Vec<u8> {
        let mut bytes = Vec::with_capacity(self.pixels.len() * 3);
        for p in &self.pixels {
            for c in p.to_array() {
                let v = aces(c * exposure);
                bytes.push((linear_to_srgb(v) * 255.0 + 0.5) as u8);
            }
        }
        bytes
    }

    /// Writes EXR or PNG depending on the extension (`.png` → preview, anything else → EXR).
    pub fn write(&self, path: &Path) -> Result<(), ImageError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
        {
            #[cfg(feature = "png")]
            Some(e) if e == "png" => self.write_png(path, None),
            #[cfg(not(feature = "png"))]
            Some(e) if e == "png" => Err(ImageError::Invalid {
                path: path.to_owned(),
                message: "PNG output needs gibake-image's `png` feature".into(),
            }),
            _ => self.write_exr(path),
        }
    }

    /// Exposure mapping the 99th percentile of luminance to 0.8 (1 if black).
    pub fn auto_exposure(&self) -> f32 {
        let mut lum: Vec<f32> = self
            .pixels
            .iter()
            .map(|p| p.dot(Vec3::new(0.2126, 0.7152, 0.0722)))
            .filter(|l| l.is_finite() && *l > 0.0)
            .collect();
        if lum.is_empty() {
            return 1.0;
        }
        let k = (lum.len() as f64 * 0.99) as usize;
        let k = k.min(lum.len() - 1);
        let (_, v, _) = lum.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
        if *v > 0.0 { 0.8 / *v } else { 1.0 }
    }

    /// True if every channel of every pixel is finite.
    pub fn all_finite(&self) -> bool {
        self.pixels.iter().all(|p| p.is_finite())
    }
}

#[cfg(feature = "png")]
fn aces(x: f32) -> f32 {
    let x = x.max(0.0);
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

#[cfg(feature = "png")]
fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Writes 8-bit sRGB pixels (`width × height × 3` bytes, rows top to bottom)
/// as a PNG: the one PNG encoder of the workspace (previews here, the bench's
/// plots in `gibake`). (Cargo feature `png`, on by default.)
#[cfg(feature = "png")]
pub fn write_rgb8_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), ImageError> {
    let file = std::fs::File::create(path).map_err(|source| ImageError::Io {
        path: path.to_owned(),
        source,
    })?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().map_err(|source| ImageError::Png {
        path: path.to_owned(),
        source,
    })?;
    w.write_image_data(rgb).map_err(|source| ImageError::Png {
        path: path.to_owned(),
        source,
    })?;
    w.finish().map_err(|source| ImageError::Png {
        path: path.to_owned(),
        source,
    })
}

/// Relative mean squared error of `x` against reference `r`: per pixel and
/// channel `(x−r)²/(r²+0.01)`, averaged. Panics if the sizes differ.
pub fn rel_mse(x: &Image, r: &Image) -> f64 {
    assert_eq!(
        (x.width, x.height),
        (r.width, r.height),
        "rel_mse: image sizes differ"
    );
    let mut s = 0.0f64;
    for (a, b) in x.pixels.iter().zip(&r.pixels) {
        for c in 0..3 {
            let (a, b) = (a[c] as f64, b[c] as f64);
            s += (a - b) * (a - b) / (b * b + 0.01);
        }
    }
    s / (x.pixels.len() as f64 * 3.0)
}

/// Downsamples by an integer factor with a box filter (supersampling resolve).
pub fn box_downsample(img: &Image, factor: u32) -> Image {
    if factor <= 1 {
        return img.clone();
    }
    let (w, h) = (img.width / factor, img.height / factor);
    let mut out = Image::new(w, h);
    let norm = 1.0 / (factor * factor) as f32;
    for y in 0..h {
        for x in 0..w {
            let mut s = Vec3::ZERO;
            for dy in 0..factor {
                for dx in 0..factor {
                    s += img.get(x * factor + dx, y * factor + dy);
                }
            }
            out.set(x, y, s * norm);
        }
    }
    out
}

#[cfg(test)]
mod tests {

    #[test]
    fn frames_are_scan_line_exr_with_lossless_compression() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.exr");
        let mut img = Image::new(5, 3);
        img.set(4, 2, glam::Vec3::new(1.5, -0.0, 3e38));
        img.write_exr(&path).unwrap();
        let meta = exr::meta::MetaData::read_from_file(&path, false).unwrap();
        let header = &meta.headers[0];
        assert_eq!(header.blocks, exr::meta::BlockDescription::ScanLines);
        assert_eq!(header.compression, exr::compression::Compression::ZIP16);
        assert_eq!(Image::read_exr(&path).unwrap(), img);
    }

    use super::*;

    #[test]
    fn exr_round_trip_is_exact() {
        let mut img = Image::new(7, 3);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Vec3::new(i as f32 * 0.5, 1e-7 * i as f32, 3e5);
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        img.write_exr(&path).unwrap();
        let back = Image::read_exr(&path).unwrap();
        assert_eq!(img, back);
    }

    #[test]
    fn damaged_exr_is_an_error_not_a_panic() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        Image::new(4, 4).write_exr(&path).unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        bytes.truncate(bytes.len() / 2);
        std::fs::write(&path, &bytes).unwrap();
        assert!(Image::read_exr(&path).is_err());
    }

    #[test]
    fn rel_mse_is_zero_on_equal_and_positive_otherwise() {
        let a = Image {
            width: 2,
            height: 1,
            pixels: vec![Vec3::ONE, Vec3::ZERO],
        };
        let mut b = a.clone();
        assert_eq!(rel_mse(&a, &b), 0.0);
        b.pixels[1] = Vec3::splat(0.1);
        // (0.1)²/(0.01) = 1 on 3 of 6 channel samples.
        assert!((rel_mse(&b, &a) - 0.5).abs() < 1e-6);
    }
}
