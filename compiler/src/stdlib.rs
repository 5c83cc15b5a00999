//! The standard library's VRS sources, embedded at build time from the workspace's `stdlib/`
//! folder (see `build.rs`), so the compiler needs no files at run time.

include!(concat!(env!("OUT_DIR"), "/stdlib_table.rs"));

/// Names of every standard module, sorted.
pub fn names() -> impl Iterator<Item = &'static str> {
    STDLIB.iter().map(|(n, _)| *n)
}

/// Every standard module as (name, source), sorted by name.
pub fn modules() -> impl Iterator<Item = (&'static str, &'static str)> {
    STDLIB.iter().copied()
}

/// Position of standard module `name` in [`modules`].
pub fn index(name: &str) -> Option<usize> {
    STDLIB.iter().position(|(n, _)| *n == name)
}
