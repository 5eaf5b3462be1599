//! Any bytes given as a layer EXR: header check then full decode, Ok or a typed error, never a
//! panic out of the reader.
//!
//! libfuzzer-sys installs a panic hook that aborts on *any* panic, even one caught by the
//! reader's `catch_unwind` guard around the `exr` crate (whose decoders can panic on malformed
//! data when built with overflow checks, as here: see
//! `layer_io::tests::fuzz_regression_b44_overflow_is_an_error`). The contract under test is
//! that no panic escapes `read_exr_bytes`, so the hook is replaced by a silent one: a panic that
//! escapes still reaches libfuzzer-sys's own `catch_unwind`, which aborts and reports it.
#![no_main]

use std::path::Path;
use std::sync::Once;

use libfuzzer_sys::fuzz_target;
use pomc::layer_io::{read_exr_bytes, read_header_bytes, ReadLimits};

/// Small limits: the fuzzer looks for crashes, not for the cost of decoding legitimately large
/// images.
const LIMITS: ReadLimits =
    ReadLimits { max_dimension: 4096, max_pixels: 1 << 20, max_channels: 16, max_decoded_bytes: 64 << 20 };

static QUIET: Once = Once::new();

fuzz_target!(|data: &[u8]| {
    QUIET.call_once(|| std::panic::set_hook(Box::new(|_| {})));
    let path = Path::new("fuzz.exr");
    if let Ok(h) = read_header_bytes(data, path, &LIMITS) {
        assert!(h.width <= LIMITS.max_dimension && h.height <= LIMITS.max_dimension);
        if let Ok(img) = read_exr_bytes(data, path, &LIMITS) {
            assert_eq!((img.width, img.height), (h.width, h.height));
            assert!(img.channels.iter().all(|c| c.data.len() == img.width * img.height));
        }
    }
});
