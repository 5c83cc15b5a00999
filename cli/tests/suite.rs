//! The command line's integration tests, one module per file beside this one, in one test
//! binary: a binary per file cost a link each, and one process lets the test threads share out
//! the long tests of every file. `cargo test -p vrsc-cli --test suite docs::` runs one file's
//! tests.

mod support {
    pub mod loopback;
}

mod bricks;
mod budgets;
mod conformance;
mod docs;
mod layout;
mod lsp;
mod mistakes;
mod probe;
mod remote;
mod view;
mod watch;
