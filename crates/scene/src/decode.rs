//! Decoders for the compressed data real exporters write, each a pure
//! function of its input bytes (the importer charges their output to the
//! [`crate::Limits`] budgets before calling them; the fuzz targets call
//! them directly):
//!
//! - [`meshopt_view`]: one buffer view of `EXT_meshopt_compression` /
//!   `KHR_meshopt_compression` (meshoptimizer's vertex and index codecs and
//!   its four filters), through the `meshopt` crate;
//! - [`webp`]: a WebP image (`EXT_texture_webp`, or a WebP image named as a
//!   plain source), through `image-webp`.
//!
//! Every precondition meshoptimizer's C code asserts on (strides, counts,
//! filter/stride pairs) is checked here first and refused with a message:
//! nothing reaches the C decoder that it would abort on.

use crate::Texture;

/// `mode` of a meshopt-compressed buffer view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshoptMode {
    /// Vertex attributes (meshoptimizer's vertex codec), stride a multiple of 4 up to 256.
    Attributes,
    /// A triangle list (the index-buffer codec), stride 2 or 4, count a multiple of 3.
    Triangles,
    /// Any index sequence (the index-sequence codec), stride 2 or 4.
    Indices,
}

impl MeshoptMode {
    /// The mode named by the extension's `mode` string.
    pub fn parse(s: &str) -> Option<MeshoptMode> {
        match s {
            "ATTRIBUTES" => Some(MeshoptMode::Attributes),
            "TRIANGLES" => Some(MeshoptMode::Triangles),
            "INDICES" => Some(MeshoptMode::Indices),
            _ => None,
        }
    }
}

/// `filter` of a meshopt-compressed buffer view (applied after decoding,
/// in place, to `ATTRIBUTES` data).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshoptFilter {
    /// No filter.
    None,
    /// Octahedral unit vectors (normals, tangents), stride 4 or 8.
    Octahedral,
    /// Quaternions (rotations), stride 8.
    Quaternion,
    /// Exponent/mantissa floats, stride a multiple of 4.
    Exponential,
    /// YCoCg colours (`KHR_meshopt_compression` only), stride 4 or 8.
    Color,
}

impl MeshoptFilter {
    /// The filter named by the extension's `filter` string (absent = `NONE`).
    pub fn parse(s: &str) -> Option<MeshoptFilter> {
        match s {
            "NONE" => Some(MeshoptFilter::None),
            "OCTAHEDRAL" => Some(MeshoptFilter::Octahedral),
            "QUATERNION" => Some(MeshoptFilter::Quaternion),
            "EXPONENTIAL" => Some(MeshoptFilter::Exponential),
            "COLOR" => Some(MeshoptFilter::Color),
            _ => None,
        }
    }
}

/// One element of `N` bytes, for meshoptimizer's vertex codec (which takes
/// the element size from the type).
#[derive(Clone, Copy)]
struct Elem<const N: usize>([u8; N]);

impl<const N: usize> Default for Elem<N> {
    fn default() -> Self {
        Elem([0; N])
    }
}

fn vertex_buffer<const N: usize>(source: &[u8], count: usize) -> Result<Vec<u8>, String> {
    let v: Vec<Elem<N>> =
        meshopt::decode_vertex_buffer(source, count).map_err(|e| e.to_string())?;
    Ok(v.iter().flat_map(|e| e.0).collect())
}

/// Calls `vertex_buffer::<stride>` for every stride meshoptimizer accepts
/// (multiples of 4 up to 256).
macro_rules! by_stride {
    ($source:expr, $count:expr, $stride:expr, [$($n:literal)*]) => {
        match $stride {
            $($n => vertex_buffer::<$n>($source, $count),)*
            s => Err(format!("byteStride {s} is not a multiple of 4 between 4 and 256")),
        }
    };
}

/// Decodes one meshopt-compressed buffer view: `count` elements of `stride`
/// bytes from the compressed bytes `source`, then `filter` in place.
/// Returns exactly `count × stride` bytes.
///
/// The output is allocated before the codec looks at `source`, so the
/// caller bounds `count × stride` first (the importer charges it to the
/// element and byte budgets).
pub fn meshopt_view(
    source: &[u8],
    count: usize,
    stride: usize,
    mode: MeshoptMode,
    filter: MeshoptFilter,
) -> Result<Vec<u8>, String> {
    if filter != MeshoptFilter::None && mode != MeshoptMode::Attributes {
        return Err(format!(
            "filter {filter:?} is only allowed with mode ATTRIBUTES, not {mode:?}"
        ));
    }
    let mut out = match mode {
        MeshoptMode::Attributes => by_stride!(source, count, stride, [
            4 8 12 16 20 24 28 32 36 40 44 48 52 56 60 64
            68 72 76 80 84 88 92 96 100 104 108 112 116 120 124 128
            132 136 140 144 148 152 156 160 164 168 172 176 180 184 188 192
            196 200 204 208 212 216 220 224 228 232 236 240 244 248 252 256
        ])?,
        MeshoptMode::Triangles | MeshoptMode::Indices => {
            if mode == MeshoptMode::Triangles && !count.is_multiple_of(3) {
                return Err(format!(
                    "mode TRIANGLES needs a count that is a multiple of 3, not {count}"
                ));
            }
            let e = |e: meshopt::Error| e.to_string();
            match (stride, mode) {
                (2, MeshoptMode::Triangles) => {
                    let v: Vec<u16> = meshopt::decode_index_buffer(source, count).map_err(e)?;
                    v.iter().flat_map(|i| i.to_le_bytes()).collect()
                }
                (4, MeshoptMode::Triangles) => {
                    let v: Vec<u32> = meshopt::decode_index_buffer(source, count).map_err(e)?;
                    v.iter().flat_map(|i| i.to_le_bytes()).collect()
                }
                (2, _) => {
                    let v: Vec<u16> = meshopt::decode_index_sequence(source, count).map_err(e)?;
                    v.iter().flat_map(|i| i.to_le_bytes()).collect()
                }
                (4, _) => {
                    let v: Vec<u32> = meshopt::decode_index_sequence(source, count).map_err(e)?;
                    v.iter().flat_map(|i| i.to_le_bytes()).collect()
                }
                (s, _) => return Err(format!("byteStride {s} of an index view is not 2 or 4")),
            }
        }
    };
    apply_filter(&mut out, stride, filter)?;
    Ok(out)
}

/// Little-endian 16-bit lanes of `bytes`, filtered in place by `f`.
fn with_i16<T>(bytes: &mut [u8], f: impl FnOnce(&mut [[i16; 4]]) -> T) -> T {
    let mut lanes: Vec<[i16; 4]> = bytes
        .chunks_exact(8)
        .map(|c| std::array::from_fn(|k| i16::from_le_bytes([c[2 * k], c[2 * k + 1]])))
        .collect();
    let r = f(&mut lanes);
    for (c, l) in bytes.chunks_exact_mut(8).zip(&lanes) {
        for k in 0..4 {
            c[2 * k..2 * k + 2].copy_from_slice(&l[k].to_le_bytes());
        }
    }
    r
}

/// Applies a meshopt filter in place to decoded `ATTRIBUTES` data.
fn apply_filter(data: &mut [u8], stride: usize, filter: MeshoptFilter) -> Result<(), String> {
    let need = |ok: bool, what: &str| {
        if ok {
            Ok(())
        } else {
            Err(format!(
                "filter {filter:?} needs byteStride {what}, not {stride}"
            ))
        }
    };
    match filter {
        MeshoptFilter::None => {}
        MeshoptFilter::Octahedral | MeshoptFilter::Color => {
            need(stride == 4 || stride == 8, "4 or 8")?;
            let octahedral = filter == MeshoptFilter::Octahedral;
            if stride == 4 {
                let mut lanes: Vec<[i8; 4]> = data
                    .chunks_exact(4)
                    .map(|c| [c[0] as i8, c[1] as i8, c[2] as i8, c[3] as i8])
                    .collect();
                if octahedral {
                    meshopt::decode_filter_oct(&mut lanes);
                    for (c, l) in data.chunks_exact_mut(4).zip(&lanes) {
                        for k in 0..4 {
                            c[k] = l[k] as u8;
                        }
                    }
                } else {
                    let mut u: Vec<[u8; 4]> = data
                        .chunks_exact(4)
                        .map(|c| [c[0], c[1], c[2], c[3]])
                        .collect();
                    meshopt::decode_filter_color(&mut u);
                    for (c, l) in data.chunks_exact_mut(4).zip(&u) {
                        c.copy_from_slice(l);
                    }
                }
            } else if octahedral {
                with_i16(data, meshopt::decode_filter_oct);
            } else {
                let mut u: Vec<[u16; 4]> = data
                    .chunks_exact(8)
                    .map(|c| std::array::from_fn(|k| u16::from_le_bytes([c[2 * k], c[2 * k + 1]])))
                    .collect();
                meshopt::decode_filter_color(&mut u);
                for (c, l) in data.chunks_exact_mut(8).zip(&u) {
                    for k in 0..4 {
                        c[2 * k..2 * k + 2].copy_from_slice(&l[k].to_le_bytes());
                    }
                }
            }
        }
        MeshoptFilter::Quaternion => {
            need(stride == 8, "8")?;
            with_i16(data, meshopt::decode_filter_quat);
        }
        MeshoptFilter::Exponential => {
            need(stride.is_multiple_of(4), "a multiple of 4")?;
            // Each 32-bit component is decoded on its own.
            let mut w: Vec<[u32; 1]> = data
                .chunks_exact(4)
                .map(|c| [u32::from_le_bytes([c[0], c[1], c[2], c[3]])])
                .collect();
            meshopt::decode_filter_exp(&mut w);
            for (c, x) in data.chunks_exact_mut(4).zip(&w) {
                c.copy_from_slice(&x[0].to_le_bytes());
            }
        }
    }
    Ok(())
}

/// The fuzz targets' entry to [`meshopt_view`] (`fuzz/fuzz_targets/
/// meshopt_decode.rs`, and the replay of kept inputs in
/// `tests/fuzz_regressions.rs`): byte 0 picks the mode, byte 1 the filter,
/// byte 2 the stride (`4·(b mod 64 + 1)` for attributes, 2 or 4 for
/// indices), bytes 3–4 the count (little-endian, at most 65535), the rest
/// is the compressed data. Panics only if a successful decode has the
/// wrong length.
#[doc(hidden)]
pub fn meshopt_fuzz_input(input: &[u8]) {
    let [m, f, s, c0, c1, data @ ..] = input else {
        return;
    };
    let mode = [
        MeshoptMode::Attributes,
        MeshoptMode::Triangles,
        MeshoptMode::Indices,
    ][*m as usize % 3];
    let filter = [
        MeshoptFilter::None,
        MeshoptFilter::Octahedral,
        MeshoptFilter::Quaternion,
        MeshoptFilter::Exponential,
        MeshoptFilter::Color,
    ][*f as usize % 5];
    let stride = match mode {
        MeshoptMode::Attributes => 4 * (*s as usize % 64 + 1),
        _ => 2 + 2 * (*s as usize % 2),
    };
    let count = u16::from_le_bytes([*c0, *c1]) as usize;
    if let Ok(out) = meshopt_view(data, count, stride, mode, filter) {
        assert_eq!(out.len(), count * stride, "decoded length");
    }
}

/// Whether `bytes` start like a WebP file (`RIFF....WEBP`).
pub fn is_webp(bytes: &[u8]) -> bool {
    bytes.len() >= 12 && &bytes[..4] == b"RIFF" && &bytes[8..12] == b"WEBP"
}

/// Width and height from a WebP header, without decoding the image.
pub fn webp_dimensions(bytes: &[u8]) -> Result<(u32, u32), String> {
    let d = image_webp::WebPDecoder::new(std::io::Cursor::new(bytes))
        .map_err(|e| format!("not a readable WebP image: {e}"))?;
    Ok(d.dimensions())
}

/// Decodes a WebP image (lossy or lossless, with or without alpha; the
/// first frame of an animation) into RGBA8, refusing images of more than
/// `max_texels` texels before decoding them. WebP stores sRGB-encoded
/// colour, kept as is (like a PNG's).
pub fn webp(bytes: &[u8], max_texels: u64) -> Result<Texture, String> {
    let mut d = image_webp::WebPDecoder::new(std::io::Cursor::new(bytes))
        .map_err(|e| format!("not a readable WebP image: {e}"))?;
    let (w, h) = d.dimensions();
    let texels = u64::from(w) * u64::from(h);
    if texels > max_texels {
        return Err(format!(
            "{w}x{h} WebP is over the limit of {max_texels} texels"
        ));
    }
    let size = d
        .output_buffer_size()
        .ok_or_else(|| format!("{w}x{h} WebP is too large"))?;
    // The decoder's own allocations stay within a few times the image.
    d.set_memory_limit(size.saturating_mul(4).max(1 << 20));
    let mut buf = vec![0u8; size];
    d.read_image(&mut buf)
        .map_err(|e| format!("cannot decode WebP: {e}"))?;
    let rgba8_srgb = if d.has_alpha() {
        buf
    } else {
        buf.chunks_exact(3)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect()
    };
    Ok(Texture {
        width: w,
        height: h,
        rgba8_srgb,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meshopt_round_trips_vertices_and_indices() {
        let verts: Vec<[u32; 3]> = (0..100u32).map(|i| [i, i * 7, i ^ 0x55]).collect();
        let enc = meshopt::encode_vertex_buffer(&verts).expect("encode");
        let dec = meshopt_view(&enc, 100, 12, MeshoptMode::Attributes, MeshoptFilter::None)
            .expect("decode");
        let want: Vec<u8> = verts
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        assert_eq!(dec, want);
        let idx: Vec<u32> = vec![0, 1, 2, 2, 1, 3, 3, 1, 4];
        let enc = meshopt::encode_index_buffer(&idx, 5).expect("encode");
        let dec =
            meshopt_view(&enc, 9, 2, MeshoptMode::Triangles, MeshoptFilter::None).expect("decode");
        let got: Vec<u32> = dec
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes([c[0], c[1]]) as u32)
            .collect();
        assert_eq!(got, idx);
        let enc = meshopt::encode_index_sequence(&idx, 5).expect("encode");
        let dec =
            meshopt_view(&enc, 9, 4, MeshoptMode::Indices, MeshoptFilter::None).expect("decode");
        let got: Vec<u32> = dec
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        assert_eq!(got, idx);
    }

    #[test]
    fn meshopt_filters_decode_what_the_encoder_wrote() {
        // Octahedral normals, 16-bit.
        let n = [[0.6f32, 0.0, 0.8, 0.0], [0.0, -1.0, 0.0, 0.0]];
        let f: Vec<[i16; 4]> = meshopt::encode_filter_oct(&n, 16);
        let bytes: Vec<u8> = f.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let enc = meshopt::encode_vertex_buffer(&f).expect("encode");
        let dec = meshopt_view(
            &enc,
            2,
            8,
            MeshoptMode::Attributes,
            MeshoptFilter::Octahedral,
        )
        .expect("decode");
        assert_ne!(dec, bytes, "the filter changed the data");
        for (i, want) in n.iter().enumerate() {
            let c = &dec[8 * i..8 * i + 8];
            let v: Vec<f32> = (0..3)
                .map(|k| i16::from_le_bytes([c[2 * k], c[2 * k + 1]]) as f32 / 32767.0)
                .collect();
            for k in 0..3 {
                assert!((v[k] - want[k]).abs() < 1e-3, "{v:?} vs {want:?}");
            }
        }
        // Exponential floats.
        let x = [[1.5f32, -2.25, 1000.0]];
        let f = meshopt::encode_filter_exp::<3>(&x, 24, meshopt::EncodeExpMode::Separate);
        let enc = meshopt::encode_vertex_buffer(&f).expect("encode");
        let dec = meshopt_view(
            &enc,
            1,
            12,
            MeshoptMode::Attributes,
            MeshoptFilter::Exponential,
        )
        .expect("decode");
        for k in 0..3 {
            let v =
                f32::from_le_bytes([dec[4 * k], dec[4 * k + 1], dec[4 * k + 2], dec[4 * k + 3]]);
            assert!((v - x[0][k]).abs() < 1e-3 * x[0][k].abs(), "{v}");
        }
    }

    #[test]
    fn meshopt_quaternion_and_color_filters() {
        let q = glam::Quat::from_axis_angle(glam::Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        let f = meshopt::encode_filter_quat(&[q.to_array()], 12);
        let enc = meshopt::encode_vertex_buffer(&f).expect("encode");
        let dec = meshopt_view(
            &enc,
            1,
            8,
            MeshoptMode::Attributes,
            MeshoptFilter::Quaternion,
        )
        .expect("decode");
        let got: Vec<f32> = (0..4)
            .map(|k| i16::from_le_bytes([dec[2 * k], dec[2 * k + 1]]) as f32 / 32767.0)
            .collect();
        let got = glam::Quat::from_slice(&got).normalize();
        assert!(got.dot(q).abs() > 0.9999, "{got} vs {q}");

        let c = [[0.8f32, 0.2, 0.4, 1.0], [0.1, 0.9, 0.3, 0.5]];
        let f: Vec<[u8; 4]> = meshopt::encode_filter_color(&c, 8);
        let enc = meshopt::encode_vertex_buffer(&f).expect("encode");
        let dec = meshopt_view(&enc, 2, 4, MeshoptMode::Attributes, MeshoptFilter::Color)
            .expect("decode");
        for (i, want) in c.iter().enumerate() {
            for k in 0..4 {
                let v = dec[4 * i + k] as f32 / 255.0;
                assert!(
                    (v - want[k]).abs() < 0.02,
                    "colour {i}.{k}: {v} vs {}",
                    want[k]
                );
            }
        }
    }

    #[test]
    fn meshopt_refuses_what_the_c_code_would_assert_on() {
        let m = MeshoptMode::Attributes;
        assert!(meshopt_view(&[0xa0; 64], 4, 6, m, MeshoptFilter::None).is_err());
        assert!(meshopt_view(&[0xa0; 64], 4, 260, m, MeshoptFilter::None).is_err());
        assert!(meshopt_view(&[0xa0; 64], 4, 12, m, MeshoptFilter::Octahedral).is_err());
        assert!(meshopt_view(&[0xa0; 64], 4, 4, m, MeshoptFilter::Quaternion).is_err());
        let t = MeshoptMode::Triangles;
        assert!(meshopt_view(&[0xe0; 64], 4, 2, t, MeshoptFilter::None).is_err());
        assert!(meshopt_view(&[0xe0; 64], 3, 3, t, MeshoptFilter::None).is_err());
        assert!(meshopt_view(&[0xe0; 64], 3, 2, t, MeshoptFilter::Octahedral).is_err());
        // Garbage is an error, not a panic.
        assert!(meshopt_view(&[1, 2, 3], 100, 16, m, MeshoptFilter::None).is_err());
    }

    #[test]
    fn webp_header_garbage_is_an_error() {
        assert!(!is_webp(b"\x89PNG\r\n\x1a\n"));
        let mut fake = b"RIFF\x10\0\0\0WEBPVP8X".to_vec();
        fake.extend_from_slice(&[0; 10]);
        assert!(is_webp(&fake));
        assert!(webp(&fake, 1 << 20).is_err());
        assert!(webp(b"RIFF", 1 << 20).is_err());
    }
}
