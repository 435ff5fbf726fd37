//! Resource budgets of the glTF import, decided before anything is
//! allocated: from the size of each file, the counts the file declares and
//! the dimensions in each image's header.
//!
//! | limit | default | flag (`gibake bake/render/reference`) |
//! |---|---|---|
//! | bytes of one input file (scene, buffer, image) | 2 GiB | `--max-input-bytes` |
//! | accessor elements read, in total (sparse included) | 2²⁴ | `--max-elements` |
//! | texels decoded, in total over all images | 2²⁶ | `--max-texels` |
//! | texture width or height (larger ones are downscaled, with a warning) | 8192 | `--max-texture-size` |
//! | animation work: keyframes × moving objects | 2²⁶ | `--max-animation-work` |
//! | external URIs outside the scene's directory | refused | `--allow-outside-uris` |
//!
//! Only regular files are read: a FIFO, a device or a directory is refused
//! before it is opened, so `/dev/zero` or a named pipe can neither block the
//! import nor fill the memory.

use std::io::Read;
use std::path::{Component, Path, PathBuf};

use crate::Texture;

/// The import's resource budgets (see the module documentation for the
/// defaults and the command-line flags that raise them).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Largest accepted input file (the scene, an external buffer or image), in bytes.
    pub max_input_bytes: u64,
    /// Most accessor elements read over the whole import (each read counts,
    /// sparse substitutions included).
    pub max_elements: u64,
    /// Most texels decoded over all images (from the image headers, before decoding).
    pub max_texels: u64,
    /// Largest texture width or height kept; larger textures are downscaled
    /// (box filter) with a warning. 8192 is what every WebGPU device supports.
    pub max_texture_size: u32,
    /// Most keyframes × moving objects (the swept bounds sample every key
    /// time for every moving object).
    pub max_animation_work: u64,
    /// Resolve external URIs (relative, `file:`) outside the scene's directory.
    pub allow_outside_uris: bool,
    /// Most primary lights kept (`--max-lights`); a file with more is
    /// refused (each light costs maps and passes).
    pub max_lights: u32,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_input_bytes: 2 << 30,
            max_elements: 1 << 24,
            max_texels: 1 << 26,
            max_texture_size: 8192,
            max_animation_work: 1 << 26,
            allow_outside_uris: false,
            max_lights: 256,
        }
    }
}

/// Why a file may not be read.
#[derive(Debug)]
pub(crate) enum FileRefusal {
    /// The OS error (not found, permission, ...).
    Io(std::io::Error),
    /// Not a regular file (FIFO, device, directory, socket).
    NotRegular(&'static str),
    /// Larger than the limit.
    TooLarge {
        /// Size in bytes.
        len: u64,
        /// The limit.
        max: u64,
    },
}

impl std::fmt::Display for FileRefusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FileRefusal::Io(e) => write!(f, "{e}"),
            FileRefusal::NotRegular(kind) => {
                write!(
                    f,
                    "not a regular file ({kind}); only regular files are read"
                )
            }
            FileRefusal::TooLarge { len, max } => write!(
                f,
                "the file is {len} bytes, over the limit of {max} bytes (raise it with --max-input-bytes)"
            ),
        }
    }
}

/// What kind of file `meta` describes, when it is not a regular file.
fn non_regular_kind(meta: &std::fs::Metadata) -> Option<&'static str> {
    let t = meta.file_type();
    if t.is_file() {
        return None;
    }
    if t.is_dir() {
        return Some("a directory");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return Some("a named pipe");
        }
        if t.is_char_device() || t.is_block_device() {
            return Some("a device");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    Some("not a plain file")
}

/// Reads the whole of `path` if it is a regular file of at most `max` bytes.
/// The type is checked before the file is opened (opening a FIFO blocks).
pub(crate) fn read_regular(path: &Path, max: u64) -> Result<Vec<u8>, FileRefusal> {
    let meta = std::fs::metadata(path).map_err(FileRefusal::Io)?;
    if let Some(kind) = non_regular_kind(&meta) {
        return Err(FileRefusal::NotRegular(kind));
    }
    if meta.len() > max {
        return Err(FileRefusal::TooLarge {
            len: meta.len(),
            max,
        });
    }
    let f = std::fs::File::open(path).map_err(FileRefusal::Io)?;
    let mut buf = Vec::new();
    buf.try_reserve_exact(meta.len() as usize)
        .map_err(|_| FileRefusal::Io(std::io::Error::from(std::io::ErrorKind::OutOfMemory)))?;
    f.take(max + 1)
        .read_to_end(&mut buf)
        .map_err(FileRefusal::Io)?;
    if buf.len() as u64 > max {
        return Err(FileRefusal::TooLarge {
            len: buf.len() as u64,
            max,
        });
    }
    Ok(buf)
}

/// Checks that `path` is a regular file of at most `max` bytes, without reading it.
pub(crate) fn check_regular(path: &Path, max: u64) -> Result<(), FileRefusal> {
    let meta = std::fs::metadata(path).map_err(FileRefusal::Io)?;
    if let Some(kind) = non_regular_kind(&meta) {
        return Err(FileRefusal::NotRegular(kind));
    }
    if meta.len() > max {
        return Err(FileRefusal::TooLarge {
            len: meta.len(),
            max,
        });
    }
    Ok(())
}

/// Whether `file` (a URI resolved against `base`) lies inside `base`: the
/// canonical paths are compared, so `..` and symbolic links cannot escape.
/// A path that cannot be canonicalised (missing) is judged lexically.
pub(crate) fn is_inside(base: &Path, file: &Path) -> bool {
    let canon_base = std::fs::canonicalize(base).unwrap_or_else(|_| lexical(base));
    let canon_file = std::fs::canonicalize(file).unwrap_or_else(|_| lexical(file));
    canon_file.starts_with(&canon_base)
}

fn lexical(p: &Path) -> PathBuf {
    let abs = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(p)
    };
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// Width and height from the header of a PNG or JPEG image, or `None` when
/// the bytes are neither (or the header is damaged).
pub(crate) fn image_dimensions(bytes: &[u8]) -> Option<(u32, u32)> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        // Signature (8), IHDR length (4), "IHDR" (4), width, height.
        if bytes.len() < 24 || &bytes[12..16] != b"IHDR" {
            return None;
        }
        let w = u32::from_be_bytes([bytes[16], bytes[17], bytes[18], bytes[19]]);
        let h = u32::from_be_bytes([bytes[20], bytes[21], bytes[22], bytes[23]]);
        return Some((w, h));
    }
    if bytes.starts_with(&[0xff, 0xd8]) {
        // Walk the marker segments up to the first start-of-frame.
        let mut i = 2usize;
        while i + 4 <= bytes.len() {
            if bytes[i] != 0xff {
                return None;
            }
            let marker = bytes[i + 1];
            if marker == 0xff {
                i += 1;
                continue;
            }
            if marker == 0xd8 || (0xd0..=0xd7).contains(&marker) || marker == 0x01 {
                i += 2;
                continue;
            }
            let len = u16::from_be_bytes([bytes[i + 2], bytes[i + 3]]) as usize;
            let is_sof = matches!(marker, 0xc0..=0xcf) && !matches!(marker, 0xc4 | 0xc8 | 0xcc);
            if is_sof {
                if i + 9 > bytes.len() {
                    return None;
                }
                let h = u16::from_be_bytes([bytes[i + 5], bytes[i + 6]]) as u32;
                let w = u16::from_be_bytes([bytes[i + 7], bytes[i + 8]]) as u32;
                return Some((w, h));
            }
            if len < 2 {
                return None;
            }
            i += 2 + len;
        }
        return None;
    }
    None
}

/// `tex` box-filtered down so that neither side exceeds `max` (aspect kept,
/// each side at least 1), or `None` when it already fits.
pub fn downscale_to_fit(tex: &Texture, max: u32) -> Option<Texture> {
    let max = max.max(1);
    if tex.width <= max && tex.height <= max {
        return None;
    }
    let (w, h) = (tex.width as u64, tex.height as u64);
    let big = w.max(h);
    let nw = ((w * max as u64).div_ceil(big)).clamp(1, max as u64) as u32;
    let nh = ((h * max as u64).div_ceil(big)).clamp(1, max as u64) as u32;
    let mut out = Vec::with_capacity(nw as usize * nh as usize * 4);
    for y in 0..nh as u64 {
        let y0 = y * h / nh as u64;
        let y1 = ((y + 1) * h / nh as u64).max(y0 + 1);
        for x in 0..nw as u64 {
            let x0 = x * w / nw as u64;
            let x1 = ((x + 1) * w / nw as u64).max(x0 + 1);
            let mut sum = [0u64; 4];
            for sy in y0..y1 {
                for sx in x0..x1 {
                    let i = ((sy * w + sx) * 4) as usize;
                    for (c, s) in sum.iter_mut().enumerate() {
                        *s += *tex.rgba8_srgb.get(i + c).unwrap_or(&0) as u64;
                    }
                }
            }
            let n = (y1 - y0) * (x1 - x0);
            for s in sum {
                out.push(((s + n / 2) / n) as u8);
            }
        }
    }
    Some(Texture {
        width: nw,
        height: nh,
        rgba8_srgb: out,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_and_jpeg_headers() {
        let mut png = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR".to_vec();
        png.extend_from_slice(&20000u32.to_be_bytes());
        png.extend_from_slice(&1u32.to_be_bytes());
        assert_eq!(image_dimensions(&png), Some((20000, 1)));
        let jpeg = [
            0xff, 0xd8, 0xff, 0xe0, 0, 4, 0, 0, 0xff, 0xc0, 0, 11, 8, 0, 7, 0, 9,
        ];
        assert_eq!(image_dimensions(&jpeg), Some((9, 7)));
        assert_eq!(image_dimensions(b"GIF89a"), None);
    }

    #[test]
    fn downscale_keeps_aspect_and_average() {
        let t = Texture {
            width: 4,
            height: 2,
            rgba8_srgb: [10u8, 20, 30, 255].repeat(8),
        };
        assert!(downscale_to_fit(&t, 4).is_none());
        let d = downscale_to_fit(&t, 2).expect("downscaled");
        assert_eq!((d.width, d.height), (2, 1));
        assert_eq!(&d.rgba8_srgb[..4], &[10, 20, 30, 255]);
    }

    #[test]
    fn fifo_is_refused_without_blocking() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join("pipe.glb");
        let ok = std::process::Command::new("mkfifo")
            .arg(&p)
            .status()
            .is_ok_and(|s| s.success());
        if ok {
            assert!(matches!(
                read_regular(&p, 1 << 20),
                Err(FileRefusal::NotRegular(_))
            ));
        }
        assert!(matches!(
            read_regular(Path::new("/dev/zero"), 1 << 20),
            Err(FileRefusal::NotRegular(_))
        ));
    }
}
