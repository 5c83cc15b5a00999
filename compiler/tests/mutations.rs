//! Robustness: thousands of random mutations of the fixtures (byte flips, truncations, token
//! shuffles, duplications) of the fixtures and of generated modules go through the whole front end
//! and lowering; none may panic, and every mutant that `check` accepts must validate.

mod common;

use std::panic::{AssertUnwindSafe, catch_unwind};
use vrsc::progen::{Choices, check_clean_validates, generate};

/// xorshift64*: deterministic, so a failure names a reproducible seed.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: usize) -> usize {
        if n == 0 { 0 } else { (self.next() % n as u64) as usize }
    }
}

const PIECES: &[&str] = &[
    "(",
    ")",
    "{",
    "}",
    "[",
    "]",
    ";",
    ",",
    ".",
    "..",
    "$",
    "state",
    "state.",
    "uniform",
    "use",
    "@ray",
    "let",
    "var",
    "for",
    "in",
    "if",
    "else",
    "return",
    "break",
    "fn",
    "lib",
    "pipeline",
    "remove",
    "replace",
    "when active",
    "0",
    "1.0",
    "0x",
    "1e",
    "u",
    "f",
    "vec3f",
    "mat4x4f",
    "volume",
    "tf",
    "+",
    "-",
    "*",
    "/",
    "<<",
    "==",
    "&&",
    "!",
    "=",
    "+=",
    "/*",
    "*/",
    "//",
    "///",
    "\"",
    "import",
    "::",
    "->",
    ":",
    "é",
    "\u{0}",
];

fn mutate(rng: &mut Rng, src: &[u8]) -> Vec<u8> {
    let mut out = src.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(out.len() + 1);
        match rng.below(6) {
            0 if !out.is_empty() => {
                let i = at.min(out.len() - 1);
                out[i] ^= 1 << rng.below(8);
            }
            1 => out.truncate(at),
            2 => {
                let piece = PIECES[rng.below(PIECES.len())].as_bytes();
                out.splice(at..at, piece.iter().copied());
            }
            3 if !out.is_empty() => {
                let end = (at + rng.below(16)).min(out.len());
                out.drain(at.min(end)..end);
            }
            4 => {
                // Swap two whitespace-separated tokens.
                let text = String::from_utf8_lossy(&out).into_owned();
                let mut words: Vec<&str> = text.split(' ').collect();
                let (a, b) = (rng.below(words.len()), rng.below(words.len()));
                words.swap(a, b);
                out = words.join(" ").into_bytes();
            }
            _ => {
                let end = (at + rng.below(64)).min(out.len());
                let copy = out[at.min(end)..end].to_vec();
                out.splice(at..at, copy);
            }
        }
    }
    out
}

/// The promise: `text` does not panic the front end, and if `check` accepts it, it validates.
/// `what` names the input in the failure.
fn assert_keeps_the_promise(what: &str, text: &str) {
    match catch_unwind(AssertUnwindSafe(|| check_clean_validates(text))) {
        Ok(Ok(_)) => {}
        Ok(Err(why)) => panic!("{what} passed `check` but not validation:\n{why}\n{text}"),
        Err(_) => panic!("{what} panicked; input:\n{text}"),
    }
}

#[test]
fn random_mutations_never_panic() {
    let mut sources = Vec::new();
    for folder in ["diagnostics", "emit"] {
        for (name, path) in common::cases(folder) {
            if let Ok(text) = std::fs::read(&path) {
                sources.push((name, text));
            }
        }
    }
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let rounds = 3000;
    for round in 0..rounds {
        let (name, src) = &sources[round % sources.len()];
        let mutated = mutate(&mut rng, src);
        let text = String::from_utf8_lossy(&mutated).into_owned();
        assert_keeps_the_promise(&format!("round {round}: a mutation of {name}"), &text);
    }
}

/// Mutations of generated well-typed modules: they reach the checker's deep rules (constant
/// evaluation, divisors, shifts, indices) far more often than mutations of the fixtures.
#[test]
fn mutations_of_generated_modules_keep_the_promise() {
    let mut rng = Rng(0xD1B5_4A32_D192_ED03);
    for round in 0..2000u64 {
        let source = generate(&mut Choices::Seeded(round + 1));
        let mutated = mutate(&mut rng, source.as_bytes());
        let text = String::from_utf8_lossy(&mutated).into_owned();
        assert_keeps_the_promise(&format!("round {round}: a mutant"), &text);
    }
}

/// Inputs the fuzzer (`fuzz/check_and_lower`) found breaking the promise, kept so that it stays
/// kept: each must fail `check` or validate.
#[test]
fn fuzz_findings_keep_the_promise() {
    let cases = common::cases("fuzz");
    assert!(!cases.is_empty(), "tests/fixtures/fuzz holds the fuzzer's findings");
    for (name, path) in cases {
        let text = std::fs::read_to_string(&path).expect("a fuzz finding");
        assert_keeps_the_promise(&name, &text);
    }
}
