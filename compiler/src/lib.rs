//! `vrsc`: the compiler for VRS, the pipeline-function language of volume raycasters.
//!
//! Passes, in order (see `ARCHITECTURE.md`): [`lexer`] → `parser` → [`loader`] (imports) →
//! [`check`] (names, types, declarations; builds [`hir`]) → [`compose`] (placement, data flow)
//! → `lower` (naga IR) → WGSL.
//!
//! # Public API, by what callers do
//!
//! **Build a scene into shaders** (the command line, the runtime, the live session, the Python
//! bindings):
//! - [`compose::build::build_scene`] reads a scene file and composes every view (or one) into a
//!   [`compose::build::BuiltScene`]: per view its [`compose::build::ViewOutput`] (WGSL text and
//!   reflection), plus the source map and every diagnostic.
//!   [`compose::build::build_scene_keeping`] also keeps each view's checked program and naga
//!   module ([`compose::build::Keep`]); [`compose::build::read_scene`] and
//!   [`compose::build::compose_scene_with`] split reading from composing (the language server
//!   composes with unsaved buffers).
//! - [`compose::cache::CompositionCache`] hands back the earlier shaders when a rebuilt scene
//!   only changed what does not shape them (uniform values, camera, data files).
//! - [`compose::backends::translate`] writes a view's shader for another target
//!   ([`compose::backends::Target`]: SPIR-V, GLSL, MSL, HLSL).
//! - [`compose::explain::explain`] and `render_pipeline_map` describe a composed view for people;
//!   [`compose::probe`] builds the variant of a view that reads one state field back.
//!
//! **Check modules without a scene** (the language server, `vrsc check`, tests):
//! - [`driver::check_files`], [`driver::check_files_with`] and [`driver::check_source`] load,
//!   parse and check modules into a [`driver::Checked`] (source map, diagnostics, module graph,
//!   [`hir::Program`]); [`check::check_program`] is the checker alone.
//! - [`ast`] (the syntax trees of [`loader::ModuleGraph`]) for tools that work on the syntax (the
//!   language server's symbols, completion and hover); [`lexer::lex`] the tokens;
//!   [`check::rules`] and [`hir::Builtin`] the language's rules and built-ins as data;
//!   [`steps::Step`] the fixed pipeline steps; [`types::Type`] the types; [`stdlib`] the standard
//!   modules' names and sources.
//!
//! **Read scenes** (the runtime, the live session): [`scene`] parses and validates scene files
//! ([`scene::parse_scene`], [`scene::parse_scene_text`]) into a [`scene::Scene`].
//!
//! **Report problems**: [`diag`] holds [`diag::Diagnostic`], [`diag::Diagnostics`] and the codes
//! ([`diag::Code`]); [`diag::render_plain`] renders them against the [`source::SourceMap`] that
//! every [`source::Span`] points into.
//!
//! **Test the compiler**: [`progen`] generates well-typed modules from a seed or a fuzzer's bytes
//! (the fuzz target and the property tests).

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
