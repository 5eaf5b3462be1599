//! Any bytes given as a manifest: diagnostics, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = pomc::manifest::diagnose(data, "fuzz");
});
