//! The mip chain of an albedo texture, made on the CPU when the scene is
//! uploaded ([`crate::mesh::SceneGpu`]).
//!
//! Each level halves the one above (sides rounded down, at least 1): a 2×2
//! box filter in linear light — sRGB decoded, averaged, encoded again —
//! the colour weighted by alpha (a cut-out texel's colour, often black,
//! does not darken the leaves around it; where the whole box is
//! transparent, the plain mean), alpha averaged as it is; the last texel of
//! an odd side folds into its neighbour's box (no texel is dropped). On the CPU rather than in a
//! render pass: it runs once at load (a 2048² texture's chain in a few tens
//! of milliseconds), needs no pipeline per format (an `Rgba8UnormSrgb`
//! texture cannot be a storage target, so a compute pass would not do), and
//! gives the same bytes on every adapter.
//!
//! The camera's G-buffer samples the chain trilinearly with the fragment's
//! own derivatives, so a tiled ground texture no longer aliases in the
//! distance; every alpha test reads the finest level
//! (`mask_texel_alpha` in `mesh.wgsl`).

/// The number of levels of a full chain for a `width × height` texture.
pub fn level_count(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

/// `rgba8_srgb` (`width × height`, row-major, 4 bytes a texel) followed by
/// every smaller level down to 1×1, each tightly packed: the layout
/// `wgpu::util::TextureDataOrder::LayerMajor` uploads.
pub fn chain(width: u32, height: u32, rgba8_srgb: &[u8]) -> Vec<u8> {
    let (mut w, mut h) = (width.max(1) as usize, height.max(1) as usize);
    let mut out = rgba8_srgb.to_vec();
    let mut level: Vec<[f32; 4]> = rgba8_srgb
        .chunks_exact(4)
        .map(|p| {
            [
                SRGB_TO_LINEAR[p[0] as usize],
                SRGB_TO_LINEAR[p[1] as usize],
                SRGB_TO_LINEAR[p[2] as usize],
                f32::from(p[3]) / 255.0,
            ]
        })
        .collect();
    if level.len() != w * h {
        return out;
    }
    while w > 1 || h > 1 {
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        // Source texels of destination index i along a side of n → m.
        let span = |i: usize, n: usize, m: usize| {
            let lo = i * n / m;
            let hi = ((i + 1) * n / m).max(lo + 1);
            lo..hi
        };
        let mut next = vec![[0f32; 4]; nw * nh];
        for y in 0..nh {
            for x in 0..nw {
                // Plain sums (rgb, alpha) and alpha-weighted rgb.
                let (mut sum, mut weighted) = ([0f32; 4], [0f32; 3]);
                let mut count = 0f32;
                for sy in span(y, h, nh) {
                    for sx in span(x, w, nw) {
                        let p = level[sy * w + sx];
                        for c in 0..4 {
                            sum[c] += p[c];
                        }
                        for c in 0..3 {
                            weighted[c] += p[c] * p[3];
                        }
                        count += 1.0;
                    }
                }
                let a = sum[3];
                next[y * nw + x] = if a > 0.0 {
                    [weighted[0] / a, weighted[1] / a, weighted[2] / a, a / count]
                } else {
                    sum.map(|s| s / count)
                };
            }
        }
        for p in &next {
            out.extend_from_slice(&[
                linear_to_srgb(p[0]),
                linear_to_srgb(p[1]),
                linear_to_srgb(p[2]),
                (p[3] * 255.0).round().clamp(0.0, 255.0) as u8,
            ]);
        }
        level = next;
        (w, h) = (nw, nh);
    }
    out
}

/// sRGB byte → linear, for every byte.
static SRGB_TO_LINEAR: std::sync::LazyLock<[f32; 256]> = std::sync::LazyLock::new(|| {
    std::array::from_fn(|i| {
        let c = i as f32 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    })
});

fn linear_to_srgb(l: f32) -> u8 {
    let l = l.clamp(0.0, 1.0);
    let c = if l <= 0.003_130_8 {
        l * 12.92
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    };
    (c * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chain_has_every_level_down_to_one_texel() {
        assert_eq!(level_count(1, 1), 1);
        assert_eq!(level_count(2, 1), 2);
        assert_eq!(level_count(256, 256), 9);
        assert_eq!(level_count(300, 17), 9);
        let c = chain(5, 3, &[128; 5 * 3 * 4]);
        // 5×3, 2×1, 1×1.
        assert_eq!(c.len(), (15 + 2 + 1) * 4);
        // A flat texture stays flat at every level.
        assert!(c.iter().all(|&b| b == 128), "{c:?}");
    }

    #[test]
    fn cut_out_texels_do_not_tint_the_colour() {
        // Two green leaf texels and two transparent black ones: the colour
        // stays the leaves', the alpha halves.
        let px = [0, 200, 0, 255, 0, 0, 0, 0, 0, 0, 0, 0, 0, 200, 0, 255];
        let c = chain(2, 2, &px);
        assert_eq!(&c[16..], &[0, 200, 0, 128]);
    }

    #[test]
    fn levels_average_in_linear_light() {
        // A black and white checker: its average is linear 0.5, sRGB 188,
        // not the byte average 128 (which would darken the distance).
        let mut px = Vec::new();
        for i in 0..4 {
            let v = if i == 0 || i == 3 { 255 } else { 0 };
            px.extend_from_slice(&[v, v, v, 255]);
        }
        let c = chain(2, 2, &px);
        assert_eq!(&c[16..], &[188, 188, 188, 255]);
    }
}
