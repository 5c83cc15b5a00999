//! `vrsc`: the compiler for VRS, the pipeline-function language of volume raycasters.
//!
//! Passes, in order (see `ARCHITECTURE.md`): [`lexer`] → [`parser`] → [`loader`] (imports) →
//! [`check`] (names, types, declarations; builds [`hir`]) → [`compose`] (placement, data flow)
//! → [`lower`] (naga IR) → WGSL.

pub mod ast;
pub mod check;
pub mod compose;
pub mod diag;
pub mod driver;
pub mod hir;
pub mod lexer;
pub mod loader;
pub(crate) mod lower;
pub(crate) mod parser;
pub mod progen;
pub mod scene;
pub mod source;
pub(crate) mod source_text;
pub mod stdlib;
pub mod steps;
pub(crate) mod suggest;
pub mod types;
