//! The image-space diff of two bakes (`gibake diff A B --scene LEVEL`):
//! what a player sees differently in one view, from the two assets'
//! renders of it (`full`, and `indirect` alone), in the figures a reviewer
//! and a CI verdict need, and the pictures an artist reads at a glance.
//!
//! Per view ([`ViewDiff`]), B against A:
//! - **rel MSE** of the `full` frames: `gibake_image::rel_mse`, per pixel
//!   and channel `(b − a)² / (a² + 0.01)`, averaged;
//! - **mean FLIP** of the `full` frames (NVIDIA's perceptual difference,
//!   [`crate::flip`]), both tone-mapped with A's automatic exposure;
//! - the **indirect mean change** per channel: the mean of B's indirect
//!   light over the frame against A's, `mean(B)/mean(A) − 1` (0 when both
//!   are 0, `None` when only A's is);
//! - the **largest local change**: the luminance difference `|L(B) −
//!   L(A)|` of the `full` frames, box-blurred over a window of
//!   `2r + 1` pixels (`r` = [`local_radius`]: a patch the eye takes in, not
//!   one pixel's noise), its largest value divided by A's mean luminance
//!   (so 0.5 reads "a patch changed by half the frame's mean brightness"),
//!   and the pixel where it is.
//!
//! The pictures ([`ViewPictures`]): A and B tone-mapped with one exposure
//! (A's), so equal radiance is an equal grey, and FLIP's error map through
//! its magma colour map with the largest local change outlined.

use gibake_image::Image;
use glam::Vec3;

use crate::flip::{FlipError, FlipMap};

/// Rec. 709 luminance weights.
const LUMA: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

/// The figures of one view (see the module docs).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ViewDiff {
    /// rel MSE of B's `full` frame against A's.
    pub rel_mse: f64,
    /// Mean FLIP of B's `full` frame against A's.
    pub flip: f64,
    /// Mean indirect radiance of A's frame per channel (linear RGB).
    pub indirect_mean_a: [f64; 3],
    /// The same of B's.
    pub indirect_mean_b: [f64; 3],
    /// `mean(B)/mean(A) − 1` per channel (`None` where A's is 0 and B's
    /// not).
    pub indirect_change: [Option<f64>; 3],
    /// The largest blurred luminance change over A's mean luminance.
    pub local_change: f64,
    /// Where it is: pixel (x, y) from the top left.
    pub local_at: [u32; 2],
    /// The blur radius in pixels.
    pub local_radius: u32,
}

/// A view's pictures: 8-bit RGB, `width × height`, rows from the top.
#[derive(Clone, Debug)]
pub struct ViewPictures {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// A's frame, tone-mapped with A's automatic exposure.
    pub a: Vec<u8>,
    /// B's frame, with the same exposure.
    pub b: Vec<u8>,
    /// FLIP's error map in magma, the largest local change outlined.
    pub heat: Vec<u8>,
}

impl ViewPictures {
    /// A | B | heat map side by side, 4 white pixels apart: one picture.
    pub fn strip(&self) -> (u32, u32, Vec<u8>) {
        let gap = 4u32;
        let (w, h) = (self.width, self.height);
        let sw = 3 * w + 2 * gap;
        let mut out = vec![255u8; (sw * h * 3) as usize];
        for (k, src) in [&self.a, &self.b, &self.heat].into_iter().enumerate() {
            let x0 = k as u32 * (w + gap);
            for y in 0..h {
                let from = (y * w * 3) as usize;
                let to = ((y * sw + x0) * 3) as usize;
                out[to..to + (w * 3) as usize].copy_from_slice(&src[from..from + (w * 3) as usize]);
            }
        }
        (sw, h, out)
    }
}

/// The blur radius of the largest local change for a `width × height`
/// frame: 1/40 of its smaller side, at least 2 pixels (4 at 320 × 180).
pub fn local_radius(width: u32, height: u32) -> u32 {
    (width.min(height) / 40).max(2)
}

fn mean3(img: &Image) -> [f64; 3] {
    let m = img.mean();
    [f64::from(m.x), f64::from(m.y), f64::from(m.z)]
}

/// Compares B's `full` and `indirect` frames of one view with A's (all
/// four the same size; see the module docs). Also returns the pictures.
pub fn compare(
    a_full: &Image,
    b_full: &Image,
    a_indirect: &Image,
    b_indirect: &Image,
) -> Result<(ViewDiff, ViewPictures), FlipError> {
    for img in [b_full, a_indirect, b_indirect] {
        if (img.width, img.height) != (a_full.width, a_full.height) {
            return Err(FlipError::SizeMismatch(
                img.width,
                img.height,
                a_full.width,
                a_full.height,
            ));
        }
    }
    let exposure = a_full.auto_exposure();
    let flip: FlipMap = crate::flip::flip_map_exposed(b_full, a_full, exposure)?;
    let (ia, ib) = (mean3(a_indirect), mean3(b_indirect));
    let indirect_change = std::array::from_fn(|c| match (ia[c], ib[c]) {
        (a, b) if a > 0.0 => Some(b / a - 1.0),
        (_, 0.0) => Some(0.0),
        _ => None,
    });
    // The luminance change, blurred; its largest value and where.
    let (w, h) = (a_full.width, a_full.height);
    let r = local_radius(w, h);
    let mut d = Image::new(w, h);
    for (o, (p, q)) in d
        .pixels
        .iter_mut()
        .zip(a_full.pixels.iter().zip(&b_full.pixels))
    {
        let v = (q.dot(LUMA) - p.dot(LUMA)).abs();
        *o = Vec3::splat(if v.is_finite() { v } else { 0.0 });
    }
    let blurred = crate::blur(&d, r);
    let (mut best, mut at) = (0f32, [w / 2, h / 2]);
    for y in 0..h {
        for x in 0..w {
            let v = blurred.get(x, y).x;
            if v > best {
                (best, at) = (v, [x, y]);
            }
        }
    }
    let mean_luma = f64::from(a_full.mean().dot(LUMA));
    let local_change = if mean_luma > 0.0 {
        f64::from(best) / mean_luma
    } else if best > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    let diff = ViewDiff {
        rel_mse: gibake_image::rel_mse(b_full, a_full),
        flip: flip.mean,
        indirect_mean_a: ia,
        indirect_mean_b: ib,
        indirect_change,
        local_change,
        local_at: at,
        local_radius: r,
    };
    let mut heat = flip.magma_rgb8;
    if best > 0.0 {
        outline(&mut heat, w, h, at, r + 2);
    }
    let pictures = ViewPictures {
        width: w,
        height: h,
        a: a_full.preview_rgb8(exposure),
        b: b_full.preview_rgb8(exposure),
        heat,
    };
    Ok((diff, pictures))
}

/// Draws a 1-pixel cyan square of half-side `r` around `at` into `rgb`.
fn outline(rgb: &mut [u8], w: u32, h: u32, at: [u32; 2], r: u32) {
    let (cx, cy, r) = (at[0] as i64, at[1] as i64, r as i64);
    let mut put = |x: i64, y: i64| {
        if x >= 0 && y >= 0 && x < w as i64 && y < h as i64 {
            let i = ((y * w as i64 + x) * 3) as usize;
            rgb[i..i + 3].copy_from_slice(&[0, 255, 255]);
        }
    };
    for k in -r..=r {
        put(cx + k, cy - r);
        put(cx + k, cy + r);
        put(cx - r, cy + k);
        put(cx + r, cy + k);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(w: u32, h: u32, v: f32) -> Image {
        let mut img = Image::new(w, h);
        for p in &mut img.pixels {
            *p = Vec3::splat(v);
        }
        img
    }

    #[test]
    fn identical_frames_differ_by_nothing() {
        let a = flat(64, 36, 0.5);
        let (d, p) = compare(&a, &a, &a, &a).unwrap();
        assert_eq!(d.rel_mse, 0.0);
        assert_eq!(d.flip, 0.0);
        assert_eq!(d.local_change, 0.0);
        assert_eq!(d.indirect_change, [Some(0.0); 3]);
        assert_eq!(p.a, p.b);
        assert_eq!(p.strip().0, 3 * 64 + 8);
    }

    #[test]
    fn a_bright_patch_is_found_where_it_is() {
        let (w, h) = (80, 45);
        let a = flat(w, h, 0.2);
        let mut b = a.clone();
        for y in 30..36 {
            for x in 60..66 {
                b.set(x, y, Vec3::new(1.0, 0.9, 0.8));
            }
        }
        let ind_a = flat(w, h, 0.1);
        let mut ind_b = flat(w, h, 0.1);
        ind_b.pixels[0] = Vec3::new(0.1 + 0.1 * (w * h) as f32, 0.1, 0.1);
        let (d, p) = compare(&a, &b, &ind_a, &ind_b).unwrap();
        assert!(d.rel_mse > 0.0 && d.flip > 0.0, "{d:?}");
        let [x, y] = d.local_at;
        assert!((60..66).contains(&x) && (30..36).contains(&y), "{d:?}");
        // A 6×6 patch up by ~0.7 in luminance, blurred over 5×5: about
        // 0.7 / 0.2 = 3.5 times the mean brightness.
        assert!(d.local_change > 2.0 && d.local_change < 4.0, "{d:?}");
        // Red indirect doubled on average, green and blue unchanged.
        let c = d.indirect_change;
        assert!((c[0].unwrap() - 1.0).abs() < 1e-3, "{c:?}");
        assert!(c[1].unwrap().abs() < 1e-6 && c[2].unwrap().abs() < 1e-6);
        // The heat map is (magma's) black away from the change, and
        // outlined at it.
        assert!(p.heat[..3].iter().all(|&v| v < 8), "{:?}", &p.heat[..3]);
        assert!(p.heat.chunks(3).any(|px| px == [0, 255, 255]));
    }

    #[test]
    fn indirect_light_where_there_was_none_has_no_ratio() {
        let a = flat(8, 8, 0.5);
        let (d, _) = compare(&a, &a, &flat(8, 8, 0.0), &flat(8, 8, 0.3)).unwrap();
        assert_eq!(d.indirect_change, [None; 3]);
        assert!(compare(&a, &flat(8, 9, 0.5), &a, &a).is_err());
    }
}
