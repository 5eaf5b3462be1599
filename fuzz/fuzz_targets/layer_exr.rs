//! Any bytes given as a layer EXR: header check then full decode, Ok or a typed error, never a
//! panic (the reader's `catch_unwind` is a last line of defence; libFuzzer still reports panics
//! that escape it, and aborts from allocations beyond the limits).
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use pomc::layer_io::{read_exr_bytes, read_header_bytes, ReadLimits};

/// Small limits: the fuzzer looks for crashes, not for the cost of decoding legitimately large
/// images.
const LIMITS: ReadLimits =
    ReadLimits { max_dimension: 4096, max_pixels: 1 << 20, max_channels: 16, max_decoded_bytes: 64 << 20 };

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.exr");
    if let Ok(h) = read_header_bytes(data, path, &LIMITS) {
        assert!(h.width <= LIMITS.max_dimension && h.height <= LIMITS.max_dimension);
        if let Ok(img) = read_exr_bytes(data, path, &LIMITS) {
            assert_eq!((img.width, img.height), (h.width, h.height));
            assert!(img.channels.iter().all(|c| c.data.len() == img.width * img.height));
        }
    }
});
