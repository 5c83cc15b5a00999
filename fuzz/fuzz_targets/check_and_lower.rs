//! Any bytes through the whole front end and lowering: nothing may panic, and a module that
//! `check` accepts must lower, validate and pass naga's WGSL front end (no E0901).
//! The first byte picks the input: even, the rest is VRS text; odd, the rest drives the
//! generator of well-typed modules (`vrsc::progen`), so that the checker's deep rules
//! (constant evaluation, shifts, divisors, indices) are reached, not only the parser.
//! Run: `cargo +nightly fuzz run check_and_lower` (or with `RUSTC_BOOTSTRAP=1` on stable).
#![no_main]

use libfuzzer_sys::fuzz_target;
use vrsc::progen::{Choices, check_clean_validates, generate};

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else { return };
    let text = if mode % 2 == 0 {
        String::from_utf8_lossy(rest).into_owned()
    } else {
        generate(&mut Choices::Bytes(rest))
    };
    if let Err(why) = check_clean_validates(&text) {
        panic!("`check` accepted a module that does not validate:\n{why}\n--- module ---\n{text}");
    }
});
