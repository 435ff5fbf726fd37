//! Mean FLIP (NVIDIA's perceptual image difference, LDR-FLIP, through the
//! `nv-flip` crate, which builds the reference C++ implementation) between
//! a rendered image and the reference.
//!
//! Both linear HDR images are tone-mapped the same way first: multiplied by
//! one exposure (the reference's [`Image::auto_exposure`]), clamped to
//! [0, 1] and sRGB-encoded to 8 bits, as a viewer would show them. The
//! error map is pooled by its mean (what the FLIP authors recommend as the
//! single number), at the default 67 pixels per degree.

use gibake_image::Image;

/// Why FLIP could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum FlipError {
    /// The images differ in size.
    #[error("FLIP: image sizes differ ({0}×{1} against the reference's {2}×{3})")]
    SizeMismatch(u32, u32, u32, u32),
    /// An empty image.
    #[error("FLIP: empty image")]
    Empty,
}

fn srgb8(v: f32) -> u8 {
    let c = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

fn to_flip(img: &Image, exposure: f32) -> nv_flip::FlipImageRgb8 {
    let mut bytes = Vec::with_capacity(img.pixels.len() * 3);
    for p in &img.pixels {
        for c in 0..3 {
            bytes.push(srgb8(p[c] * exposure));
        }
    }
    nv_flip::FlipImageRgb8::with_data(img.width, img.height, &bytes)
}

/// Mean LDR-FLIP of `test` against `reference` (0 = identical, 1 = the
/// largest difference), both tone-mapped with `exposure`.
pub fn mean_flip_exposed(test: &Image, reference: &Image, exposure: f32) -> Result<f64, FlipError> {
    flip_map_exposed(test, reference, exposure).map(|m| m.mean)
}

/// FLIP's per-pixel error map of `test` against `reference`, both
/// tone-mapped with `exposure` (what [`mean_flip_exposed`] pools).
#[derive(Clone, Debug)]
pub struct FlipMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Per pixel, row-major from the top: 0 (identical) to 1.
    pub values: Vec<f32>,
    /// Their mean (FLIP's own pooling).
    pub mean: f64,
    /// The map through FLIP's magma colour map, 8-bit RGB (black: no
    /// difference, through purple and orange to pale yellow): the heat map
    /// FLIP's authors show.
    pub magma_rgb8: Vec<u8>,
}

/// [`FlipMap`] of `test` against `reference`, both tone-mapped with
/// `exposure`.
pub fn flip_map_exposed(
    test: &Image,
    reference: &Image,
    exposure: f32,
) -> Result<FlipMap, FlipError> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(FlipError::SizeMismatch(
            test.width,
            test.height,
            reference.width,
            reference.height,
        ));
    }
    if test.pixels.is_empty() {
        return Err(FlipError::Empty);
    }
    let map = nv_flip::flip(
        to_flip(reference, exposure),
        to_flip(test, exposure),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    Ok(FlipMap {
        width: test.width,
        height: test.height,
        values: map.to_vec(),
        mean: f64::from(nv_flip::FlipPool::from_image(&map).mean()),
        magma_rgb8: map.apply_color_lut(&nv_flip::magma_lut()).to_vec(),
    })
}

/// Mean LDR-FLIP of `test` against `reference`, both tone-mapped with the
/// reference's automatic exposure.
pub fn mean_flip(test: &Image, reference: &Image) -> Result<f64, FlipError> {
    mean_flip_exposed(test, reference, reference.auto_exposure())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn gradient(w: u32, h: u32, k: f32) -> Image {
        let mut img = Image::new(w, h);
        for y in 0..h {
            for x in 0..w {
                img.set(x, y, Vec3::new(x as f32 / w as f32, y as f32 / h as f32, k));
            }
        }
        img
    }

    #[test]
    fn identical_is_zero_and_error_grows_with_the_difference() {
        let r = gradient(32, 32, 0.5);
        assert_eq!(mean_flip_exposed(&r, &r, 1.0).unwrap(), 0.0);
        let near = mean_flip_exposed(&gradient(32, 32, 0.45), &r, 1.0).unwrap();
        let far = mean_flip_exposed(&gradient(32, 32, 0.0), &r, 1.0).unwrap();
        assert!(
            near > 0.0 && near < far && far <= 1.0,
            "near {near}, far {far}"
        );
    }

    #[test]
    fn size_mismatch_is_an_error() {
        assert!(matches!(
            mean_flip(&gradient(8, 8, 0.0), &gradient(8, 9, 0.0)),
            Err(FlipError::SizeMismatch(8, 8, 8, 9))
        ));
    }
}
