//! Fuzzes `gibake diff`'s tolerance parsing: any text is an error or a
//! finite number in [0, 1] — never a value that makes `diff` lie.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Ok(v) = gibake_asset::parse_tolerance("--map-rel", text) {
            assert!(v.is_finite() && (0.0..=1.0).contains(&v), "{text:?} → {v}");
        }
    }
});
