//! Any bytes through the whole front end and lowering: nothing may panic.
//! Run: `cargo +nightly fuzz run check_and_lower` (or with `RUSTC_BOOTSTRAP=1` on stable).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let mut checked = vrsc::driver::check_source("fuzz.vrs", &text, None);
    let _ = checked.emit_standalone_wgsl();
});
