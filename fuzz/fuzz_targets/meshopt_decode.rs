//! Fuzzes the meshopt decoder of `EXT_/KHR_meshopt_compression` buffer
//! views (`gibake_scene::decode::meshopt_view`: meshoptimizer's vertex and
//! index codecs and its filters, behind gibake's precondition checks): any
//! mode, filter, stride, count and compressed bytes give decoded data of
//! the declared length or an error, never a crash or an abort in the C
//! code. Input layout: see `decode::meshopt_fuzz_input`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    gibake_scene::decode::meshopt_fuzz_input(data);
});
