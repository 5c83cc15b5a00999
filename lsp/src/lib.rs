//! `vrsc lsp`: the VRS language server, over stdio, synchronous (lsp-server).
//!
//! On every change it runs the same checker as `vrsc check` on the document (open documents
//! stand in for their files on disk) and composes every scene of the workspace that lists the
//! document, so composition errors show on the module's lines. Hover, completion, go to
//! definition, references of state fields and quick fixes read the syntax trees of the document,
//! its imports, its scenes' modules and the standard library (`workspace.rs`). Definitions in the
//! standard library point at copies of its embedded sources in a cache folder
//! ([`stdlib_files`]).
//!
//! Public API:
//! - [`run_stdio`]: the server over standard input and output (`vrsc lsp`); [`serve`], the same
//!   over any `lsp-server` connection (the tests' in-memory one); [`capabilities`], what it
//!   offers the client.
//! - [`uri`]: `file:` URIs to paths and back ([`uri::to_path`], [`uri::from_path`]).
//! - [`stdlib_files`]: where the standard library's sources are written for editors
//!   ([`stdlib_files::folder`], [`stdlib_files::path_of`], [`stdlib_files::module_of`]).

mod analysis;
mod code_actions;
mod completion;
mod describe;
mod fixes;
mod hover;
mod navigate;
mod scenes;
mod server;
pub mod stdlib_files;
mod symbols;
mod text;
pub mod uri;
mod workspace;

pub use server::{capabilities, run_stdio, serve};
