//! The library's front door: runs the passes over files and returns what they produced,
//! together with the source map and every diagnostic.
//!
//! Public face: [`check_files`], [`check_files_with`] and [`check_source`], which load, parse
//! and check modules into a [`Checked`]; [`InputError`] for a root file that cannot be read.
//! The command line, the language server and the Python bindings start here.

use crate::check;
use crate::diag::Diagnostics;
use crate::hir::Program;
use crate::loader::{Loader, ModuleGraph, ParsedFiles};
use crate::lower;
use crate::source::SourceMap;
use std::path::{Path, PathBuf};

/// The result of checking a set of modules.
pub struct Checked {
    /// Every file read (the standard modules included); all spans point into it.
    pub sources: SourceMap,
    /// Every diagnostic of loading, parsing and checking.
    pub diags: Diagnostics,
    /// The modules loaded, with their syntax trees and imports.
    pub graph: ModuleGraph,
    /// The checked program: what the passes after the checker (lowering, composing) take.
    pub program: Program,
}

/// An input file that could not be read (an I/O problem, not a diagnostic).
#[derive(Debug)]
pub struct InputError {
    /// The path as given.
    pub path: PathBuf,
    /// Why it could not be read.
    pub error: std::io::Error,
}

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "cannot read `{}`: {}", self.path.display(), self.error)
    }
}

impl std::error::Error for InputError {}

/// Loads, parses and checks the given files (and everything they import).
pub fn check_files(paths: &[PathBuf]) -> Result<Checked, InputError> {
    check_files_with(paths, ParsedFiles::default())
}

/// [`check_files`], reading the texts of `parsed`'s overlay instead of those files on disk
/// ([`ParsedFiles::with_overlay`]: the language server checks unsaved buffers this way).
pub fn check_files_with(paths: &[PathBuf], parsed: ParsedFiles) -> Result<Checked, InputError> {
    let mut sources = SourceMap::new();
    let mut diags = Diagnostics::new();
    let mut loader = Loader::with_parsed(&mut sources, &mut diags, parsed);
    for path in paths {
        loader.load_root_file(path).map_err(|error| InputError { path: path.clone(), error })?;
    }
    let graph = loader.finish();
    Ok(finish_check(sources, diags, graph))
}

/// Checks one module given as text (tests, fuzzing, editors). Imports resolve relative to `dir`.
pub fn check_source(name: &str, text: &str, dir: Option<&Path>) -> Checked {
    let mut sources = SourceMap::new();
    let mut diags = Diagnostics::new();
    let mut loader = Loader::new(&mut sources, &mut diags);
    loader.load_root_source(name, text.to_string(), dir);
    let graph = loader.finish();
    finish_check(sources, diags, graph)
}

fn finish_check(sources: SourceMap, mut diags: Diagnostics, graph: ModuleGraph) -> Checked {
    let program = check::check_program(&graph, &sources, &mut diags);
    Checked { sources, diags, graph, program }
}

impl Checked {
    /// WGSL of every checked function, each pipeline function lowered on its own
    /// (`vrsc emit`). Errors when the modules have errors or the IR fails validation.
    pub fn emit_standalone_wgsl(&mut self) -> Option<String> {
        if self.diags.has_errors() {
            return None;
        }
        let result = lower::lower_standalone(&self.program, &self.sources)
            .and_then(|(module, info)| lower::write_wgsl(&module, &info));
        match result {
            Ok(wgsl) => Some(wgsl),
            Err(d) => {
                self.diags.push(d);
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_overlay_stands_in_for_the_files_on_disk() {
        let dir = tempfile::tempdir().unwrap();
        let main = dir.path().join("main.vrs");
        let lib = dir.path().join("lib.vrs");
        std::fs::write(&main, "import \"lib.vrs\";\npipeline p in start {\n    use f;\n    f();\n}\n").unwrap();
        std::fs::write(&lib, "lib fn g() {}\n").unwrap();
        let on_disk = check_files(std::slice::from_ref(&main)).unwrap();
        assert!(on_disk.diags.has_errors());
        // The unsaved text of the imported file defines `f`.
        let overlay = [(lib.canonicalize().unwrap(), String::from("lib fn f() {}\n"))];
        let edited = check_files_with(&[main], ParsedFiles::with_overlay(overlay)).unwrap();
        assert!(!edited.diags.has_errors(), "{:?}", edited.diags);
    }
}
