//! Textures and images: decodes embedded or external PNG, JPEG and WebP
//! images into RGBA8 (sRGB kept as in the file), checks headers and sizes
//! against the texel budget, and scales oversized textures down. Formats
//! gibake does not decode (KTX2/Basis Universal, AVIF) are refused with a
//! message naming their extension and the command that converts them.

use std::path::Path;

use super::Ctx;
use super::extensions::conversion_hint;
use crate::limits;
use crate::{SceneError, Texture, decode};

/// An image encoding recognised from its first bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ImageKind {
    Png,
    Jpeg,
    Webp,
    /// KTX 2.0 (`KHR_texture_basisu`).
    Ktx2,
    /// AVIF (`EXT_texture_avif`): an ISO-BMFF `ftyp` box with an AVIF brand.
    Avif,
    Unknown,
}

impl ImageKind {
    pub(super) fn sniff(head: &[u8]) -> ImageKind {
        if head.starts_with(b"\x89PNG") {
            ImageKind::Png
        } else if head.starts_with(&[0xff, 0xd8, 0xff]) {
            ImageKind::Jpeg
        } else if decode::is_webp(head) {
            ImageKind::Webp
        } else if head.starts_with(b"\xabKTX 20\xbb\r\n\x1a\n") {
            ImageKind::Ktx2
        } else if head.len() >= 12
            && &head[4..8] == b"ftyp"
            && (&head[8..12] == b"avif" || &head[8..12] == b"avis")
        {
            ImageKind::Avif
        } else {
            ImageKind::Unknown
        }
    }

    fn mime(self) -> Option<&'static str> {
        match self {
            ImageKind::Png => Some("image/png"),
            ImageKind::Jpeg => Some("image/jpeg"),
            ImageKind::Webp => Some("image/webp"),
            ImageKind::Ktx2 => Some("image/ktx2"),
            ImageKind::Avif => Some("image/avif"),
            ImageKind::Unknown => None,
        }
    }
}

/// The first 64 KiB of `file` (enough for a PNG or JPEG header), empty on error.
pub(super) fn head_bytes(file: &Path) -> Vec<u8> {
    use std::io::Read;
    let mut out = Vec::new();
    if let Ok(f) = std::fs::File::open(file) {
        let _ = f.take(1 << 16).read_to_end(&mut out);
    }
    out
}

/// The encoding of an image file from its first bytes.
pub(super) fn sniff_image(file: &Path) -> std::io::Result<ImageKind> {
    use std::io::Read;
    let mut head = [0u8; 16];
    let mut f = std::fs::File::open(file)?;
    let mut n = 0;
    while n < head.len() {
        let k = f.read(&mut head[n..])?;
        if k == 0 {
            break;
        }
        n += k;
    }
    Ok(ImageKind::sniff(&head[..n]))
}

/// Converts any decoded image to RGBA8 (RGB kept sRGB-encoded as in the file).
pub(super) fn to_rgba8(d: &gltf::image::Data) -> Option<Texture> {
    use gltf::image::Format;
    let (w, h) = (d.width as usize, d.height as usize);
    let n = w.checked_mul(h)?;
    let p = &d.pixels;
    let u16_at = |i: usize| -> u8 {
        let v = u16::from_ne_bytes([p[2 * i], p[2 * i + 1]]) as u32;
        ((v * 255 + 32767) / 65535) as u8
    };
    let f32_at = |i: usize| -> u8 {
        let v = f32::from_ne_bytes([p[4 * i], p[4 * i + 1], p[4 * i + 2], p[4 * i + 3]]);
        (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
    };
    let (channels, bytes_per) = match d.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    if p.len() != n.checked_mul(channels * bytes_per)? {
        return None;
    }
    let comp = |i: usize| -> u8 {
        match bytes_per {
            1 => p[i],
            2 => u16_at(i),
            _ => f32_at(i),
        }
    };
    let mut out = Vec::with_capacity(n * 4);
    for px in 0..n {
        let b = px * channels;
        let rgba = match channels {
            1 => {
                let l = comp(b);
                [l, l, l, 255]
            }
            2 => {
                let l = comp(b);
                [l, l, l, comp(b + 1)]
            }
            3 => [comp(b), comp(b + 1), comp(b + 2), 255],
            _ => [comp(b), comp(b + 1), comp(b + 2), comp(b + 3)],
        };
        out.extend_from_slice(&rgba);
    }
    Some(Texture {
        width: d.width,
        height: d.height,
        rgba8_srgb: out,
    })
}

impl<'a> Ctx<'a> {
    /// Counts a `w × h` image against the texel budget, before it is decoded.
    pub(super) fn charge_texels(&self, what: &str, w: u32, h: u32) -> Result<(), SceneError> {
        let n = w as u64 * h as u64;
        let total = self.texels_decoded.get().saturating_add(n);
        let max = self.limits.max_texels;
        if total > max {
            return Err(self.invalid(format!(
                "{what}: {w}x{h} texels would bring the texels decoded to {total}, over the limit of {max} (raise it with --max-texels)"
            )));
        }
        self.texels_decoded.set(total);
        Ok(())
    }

    pub(super) fn decode_image(&self, i: usize) -> Result<Texture, SceneError> {
        let img = self
            .root
            .images
            .get(i)
            .ok_or_else(|| self.invalid(format!("image {i} does not exist")))?;
        let what = match &img.name {
            Some(n) => format!("image {i} '{n}'"),
            None => format!("image {i}"),
        };
        let mime = img.mime_type.as_ref().map(|m| m.0.as_str());
        let file_uri;
        let source = if let Some(v) = img.buffer_view {
            let v = v.value();
            let (bytes, _) = self
                .view_bytes(v)
                .map_err(|e| self.invalid(format!("{what}: {e}")))?;
            if self.check_image_header(&what, bytes)? == ImageKind::Webp {
                return self.decode_webp(&what, bytes);
            }
            let view =
                self.document.views().nth(v).ok_or_else(|| {
                    self.invalid(format!("{what}: bufferView {v} does not exist"))
                })?;
            let mime_type = mime.ok_or_else(|| {
                self.invalid(format!("{what}: bufferView image without mimeType"))
            })?;
            gltf::image::Source::View { view, mime_type }
        } else if let Some(uri) = img.uri.as_deref() {
            if uri.starts_with("data:") {
                let bytes = gltf::buffer::Data::from_source(gltf::buffer::Source::Uri(uri), None)
                    .map_err(|e| self.invalid(format!("{what}: bad data URI: {e}")))?;
                if self.check_image_header(&what, &bytes.0)? == ImageKind::Webp {
                    return self.decode_webp(&what, &bytes.0);
                }
                gltf::image::Source::Uri {
                    uri,
                    mime_type: mime,
                }
            } else {
                let file = self.resolve_uri(uri, &what)?;
                let cannot_read = |e: &dyn std::fmt::Display| {
                    self.invalid(format!(
                        "{what}: cannot read '{uri}' ({}): {e}",
                        file.display()
                    ))
                };
                if let Err(e) = limits::check_regular(&file, self.limits.max_input_bytes) {
                    return Err(cannot_read(&e));
                }
                let head = sniff_image(&file).map_err(|e| cannot_read(&e))?;
                if head == ImageKind::Webp {
                    let bytes = limits::read_regular(&file, self.limits.max_input_bytes)
                        .map_err(|e| cannot_read(&e))?;
                    self.check_image_header(&what, &bytes)?;
                    return self.decode_webp(&what, &bytes);
                }
                self.check_image_header(&what, &head_bytes(&file))?;
                let s = file.to_str().ok_or_else(|| {
                    self.invalid(format!(
                        "{what}: path {} is not valid UTF-8",
                        file.display()
                    ))
                })?;
                file_uri = format!("file:{s}");
                // Without a mimeType the gltf crate goes by the extension;
                // give it the type from the file's magic bytes instead.
                gltf::image::Source::Uri {
                    uri: &file_uri,
                    mime_type: mime.or(head.mime()),
                }
            }
        } else {
            return Err(self.invalid(format!("{what} has neither uri nor bufferView")));
        };
        let data = gltf::image::Data::from_source(source, Some(&self.base), &self.buffers)
            .map_err(|e| self.invalid(format!("{what}: cannot decode: {e}")))?;
        to_rgba8(&data).ok_or_else(|| self.invalid(format!("{what}: unexpected pixel data size")))
    }

    /// Decodes a WebP image whose header [`Ctx::check_image_header`] has
    /// already charged to the texel budget.
    fn decode_webp(&self, what: &str, bytes: &[u8]) -> Result<Texture, SceneError> {
        decode::webp(bytes, self.limits.max_texels)
            .map_err(|e| self.invalid(format!("{what}: {e}")))
    }

    /// Recognises the image's encoding from its first bytes, reads its size
    /// from its header and charges it to the texel budget, before anything
    /// is decoded. An encoding gibake does not decode is refused here, with
    /// the extension it belongs to and the command that converts it.
    pub(super) fn check_image_header(
        &self,
        what: &str,
        bytes: &[u8],
    ) -> Result<ImageKind, SceneError> {
        let kind = ImageKind::sniff(bytes);
        match kind {
            ImageKind::Png | ImageKind::Jpeg => {
                if let Some((w, h)) = limits::image_dimensions(bytes) {
                    self.charge_texels(what, w, h)?;
                }
                // A damaged header: the decoder rejects it without decoding.
            }
            ImageKind::Webp => {
                let (w, h) = decode::webp_dimensions(bytes)
                    .map_err(|e| self.invalid(format!("{what}: {e}")))?;
                self.charge_texels(what, w, h)?;
            }
            ImageKind::Ktx2 => {
                return Err(self.not_supported(format!(
                    "{what} is a KTX2 (Basis Universal) texture of KHR_texture_basisu, which gibake does not decode; {}",
                    conversion_hint("KHR_texture_basisu")
                )));
            }
            ImageKind::Avif => {
                return Err(self.not_supported(format!(
                    "{what} is an AVIF image of EXT_texture_avif, which gibake does not decode; {}",
                    conversion_hint("EXT_texture_avif")
                )));
            }
            ImageKind::Unknown => {
                return Err(self.not_supported(format!(
                    "{what}: cannot decode: unsupported image encoding, not PNG, JPEG or WebP (the ones gibake reads; the first bytes are {})",
                    hex_head(bytes)
                )));
            }
        }
        Ok(kind)
    }

    /// Downscales a texture larger than `--max-texture-size`, with a warning.
    pub(super) fn fit_texture(&mut self, tex: Texture, image: usize) -> Texture {
        let max = self.limits.max_texture_size;
        match limits::downscale_to_fit(&tex, max) {
            None => tex,
            Some(small) => {
                self.warn(format!(
                    "image {image}: {}x{} is larger than {max} texels on a side, downscaled to {}x{} (raise --max-texture-size up to the GPU's limit to keep it)",
                    tex.width, tex.height, small.width, small.height
                ));
                small
            }
        }
    }
}

/// The first bytes of `b` in hex, for messages.
fn hex_head(b: &[u8]) -> String {
    if b.is_empty() {
        return "none (empty)".into();
    }
    b.iter()
        .take(8)
        .map(|x| format!("{x:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}
