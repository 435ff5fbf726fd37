//! Fuzzes the WebP decoder of `EXT_texture_webp` images
//! (`gibake_scene::decode::webp`, image-webp): any bytes give an RGBA8
//! texture of the header's size or an error, never a panic, and no image
//! over the texel budget (2²² here) is decoded.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(t) = gibake_scene::decode::webp(data, 1 << 22) {
        assert_eq!(t.rgba8_srgb.len(), t.width as usize * t.height as usize * 4);
    }
});
