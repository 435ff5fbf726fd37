//! Single-layer EXR encoding and checked decoding (via the `exr` crate).
//!
//! Encoding is deterministic: ZIP (16 scan lines per block), increasing line
//! order (blocks are written in order even when compressed in parallel), no
//! attributes beyond the required ones.

use std::io::Cursor;
use std::path::Path;

use exr::prelude::*;

use crate::AssetError;

/// Samples of one channel.
pub(crate) enum Samples {
    /// 32-bit float.
    F32(Vec<f32>),
    /// 32-bit unsigned integer.
    U32(Vec<u32>),
}

/// The expected sample type of a channel.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Kind {
    F32,
    U32,
}

/// The encoding of every EXR the asset writes.
pub(crate) const ENCODING: Encoding = Encoding {
    compression: Compression::ZIP16,
    blocks: Blocks::ScanLines,
    line_order: LineOrder::Increasing,
};

/// Encodes one layer of `width × height` with the given channels (any order;
/// EXR stores them sorted by name) into EXR bytes.
pub(crate) fn encode(
    width: usize,
    height: usize,
    channels: Vec<(&str, Samples)>,
) -> std::result::Result<Vec<u8>, exr::error::Error> {
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels
        .into_iter()
        .map(|(name, s)| {
            let data = match s {
                Samples::F32(v) => FlatSamples::F32(v),
                Samples::U32(v) => FlatSamples::U32(v),
            };
            AnyChannel::new(name, data)
        })
        .collect();
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        ENCODING,
        AnyChannels::sort(list),
    );
    let image = Image::from_layer(layer);
    let mut out = Cursor::new(Vec::new());
    image.write().to_buffered(&mut out)?;
    Ok(out.into_inner())
}

/// Decodes EXR `bytes` (the file `path`) expecting exactly one flat layer of
/// `width × height` holding at least the channels `expected` (name and type);
/// returns their samples in the order of `expected`. Other channels are
/// ignored. Never panics: a panic inside the decoder becomes an error.
pub(crate) fn decode(
    bytes: &[u8],
    path: &Path,
    width: usize,
    height: usize,
    expected: &[(&str, Kind)],
) -> std::result::Result<Vec<Samples>, AssetError> {
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        decode_inner(bytes, path, width, height, expected)
    }));
    match result {
        Ok(r) => r,
        Err(_) => Err(AssetError::invalid(
            path,
            "damaged EXR (the decoder gave up)",
        )),
    }
}

fn decode_inner(
    bytes: &[u8],
    path: &Path,
    width: usize,
    height: usize,
    expected: &[(&str, Kind)],
) -> std::result::Result<Vec<Samples>, AssetError> {
    let bad = |m: String| AssetError::invalid(path, m);
    // Header first: check dimensions and channels before any pixel allocation.
    let meta = MetaData::read_from_buffered(Cursor::new(bytes), false)
        .map_err(|e| bad(format!("not a readable EXR file: {e}")))?;
    if meta.headers.len() != 1 {
        return Err(bad(format!(
            "expected 1 EXR layer, found {}",
            meta.headers.len()
        )));
    }
    let header = &meta.headers[0];
    if header.deep {
        return Err(bad("expected a flat EXR image, found deep data".into()));
    }
    let size = (header.layer_size.width(), header.layer_size.height());
    if size != (width, height) {
        return Err(bad(format!(
            "EXR is {}x{} but the manifest implies {width}x{height}",
            size.0, size.1
        )));
    }
    for (name, kind) in expected {
        let Some(desc) = header.channels.list.iter().find(|c| c.name.eq(name)) else {
            return Err(bad(format!("EXR has no channel `{name}`")));
        };
        let ok = matches!(
            (kind, desc.sample_type),
            (Kind::F32, SampleType::F32) | (Kind::U32, SampleType::U32)
        );
        if !ok {
            return Err(bad(format!(
                "EXR channel `{name}` is {:?}, expected {kind:?}",
                desc.sample_type
            )));
        }
        if desc.sampling != Vec2(1, 1) {
            return Err(bad(format!("EXR channel `{name}` is subsampled")));
        }
    }

    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| bad(format!("damaged EXR: {e}")))?;
    let mut channels: Vec<(Text, Option<FlatSamples>)> = image
        .layer_data
        .channel_data
        .list
        .into_iter()
        .map(|c| (c.name, Some(c.sample_data)))
        .collect();
    let mut out = Vec::with_capacity(expected.len());
    for (name, _) in expected {
        let data = channels
            .iter_mut()
            .find(|(n, _)| n.eq(name))
            .and_then(|(_, d)| d.take())
            .ok_or_else(|| bad(format!("EXR channel `{name}` could not be read")))?;
        let s = match data {
            FlatSamples::F32(v) => Samples::F32(v),
            FlatSamples::U32(v) => Samples::U32(v),
            FlatSamples::F16(_) => return Err(bad(format!("EXR channel `{name}` is f16"))),
        };
        let len = match &s {
            Samples::F32(v) => v.len(),
            Samples::U32(v) => v.len(),
        };
        if len != width * height {
            return Err(bad(format!(
                "EXR channel `{name}` holds {len} samples, expected {}",
                width * height
            )));
        }
        out.push(s);
    }
    Ok(out)
}

/// Decodes EXR `bytes` the way the loader decodes each of the asset's maps,
/// with the size taken from the file's own header (at most 2048² texels, so
/// a fuzzer's input cannot ask for gigabytes): once as a depth map (`D`),
/// once as the RSM (`D`, `flux.*`, `vpl`). For fuzzing and regression tests.
pub(crate) fn decode_any(bytes: &[u8], path: &Path) -> std::result::Result<(), AssetError> {
    let size = std::panic::catch_unwind(|| {
        MetaData::read_from_buffered(Cursor::new(bytes), false)
            .ok()
            .and_then(|m| {
                m.headers
                    .first()
                    .map(|h| (h.layer_size.width(), h.layer_size.height()))
            })
    })
    .map_err(|_| AssetError::invalid(path, "damaged EXR (the decoder gave up)"))?;
    let Some((w, h)) = size.filter(|&(w, h)| w.saturating_mul(h) <= 2048 * 2048) else {
        return Err(AssetError::invalid(path, "no usable EXR header"));
    };
    let depth = decode(bytes, path, w, h, &[("Z", Kind::F32)]);
    let rsm = decode(
        bytes,
        path,
        w,
        h,
        &[("Z", Kind::F32), ("share", Kind::U32), ("vpl", Kind::U32)],
    );
    depth.and(rsm).map(|_| ())
}

/// Bytes all channels of the EXR `bytes` decode to, from its header alone
/// (`None`: no readable header; the decoder then reports the damage).
pub(crate) fn declared_bytes(bytes: &[u8]) -> Option<u64> {
    let meta = std::panic::catch_unwind(|| MetaData::read_from_buffered(Cursor::new(bytes), false))
        .ok()?
        .ok()?;
    let mut total = 0u64;
    for h in &meta.headers {
        let texels = h.layer_size.width() as u64 * h.layer_size.height() as u64;
        for c in &h.channels.list {
            let per = match c.sample_type {
                SampleType::F16 => 2,
                SampleType::F32 | SampleType::U32 => 4,
            };
            total = total.saturating_add(texels.saturating_mul(per));
        }
    }
    Some(total)
}

impl Samples {
    pub(crate) fn into_f32(self) -> Vec<f32> {
        match self {
            Samples::F32(v) => v,
            Samples::U32(v) => v.into_iter().map(|x| x as f32).collect(),
        }
    }

    pub(crate) fn into_u32(self) -> Vec<u32> {
        match self {
            Samples::U32(v) => v,
            Samples::F32(v) => v.into_iter().map(|x| x as u32).collect(),
        }
    }
}
