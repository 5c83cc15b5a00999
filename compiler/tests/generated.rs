//! The checker's promise, on thousands of generated well-typed modules (seeded, so a failure
//! names its seed): a module that `check` accepts lowers to IR that validates, and its WGSL
//! passes naga's WGSL front end and validator, as wgpu runs them when it creates the shader.

use vrsc::progen::{Choices, Verdict, check_clean_validates, generate};

const SEEDS: u64 = 4000;

#[test]
fn check_clean_generated_modules_validate() {
    let mut validated = 0;
    for seed in 1..=SEEDS {
        let text = generate(&mut Choices::Seeded(seed));
        match check_clean_validates(&text) {
            Ok(Verdict::Validated) => validated += 1,
            Ok(Verdict::Rejected) => {}
            Err(why) => {
                panic!("seed {seed}: `check` accepted a module that does not validate:\n{why}\n--- module ---\n{text}")
            }
        }
    }
    // The generator is meant to produce well-typed modules: at least 40% must pass `check`, or the
    // property would hold vacuously.
    assert!(validated * 5 > SEEDS * 2, "only {validated} of {SEEDS} generated modules passed `check`");
}
