//! `vrsc`: the compiler for VRS, the pipeline-function language of volume raycasters.
//!
//! Passes, in order (see `ARCHITECTURE.md`): [`lexer`] → [`parser`] → [`loader`] (imports) →
//! [`check`] (names, types, declarations; builds [`hir`]) → [`lower`] (naga IR) → WGSL.

pub mod ast;
pub mod diag;
pub mod hir;
pub mod lexer;
pub mod source;
pub mod steps;
pub mod types;
