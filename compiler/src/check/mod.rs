//! The checker: names, types, declarations and function rules; builds the [`crate::hir`].
//!
//! [`check_program`] runs these passes over every module of the graph:
//! 1. `scope`: collect the items of each module and build its item scope (its own consts and
//!    lib fns plus those of the modules it imports directly); duplicates are reported here.
//! 2. `func`: resolve lib-fn signatures, then check every lib fn and pipeline function body
//!    (`expr`, `call` and `stmt`; constants through `consts`; pipeline headers and placements
//!    through `decls`).
//! 3. `decls`: conflicts between the declarations of different pipeline functions.
//! 4. `callgraph`: recursion, then the [`hir::Program`] in callee-before-caller order, holding
//!    only functions that checked cleanly (and whose callees did).
//!
//! Every error inside a function marks that function failed (`scope::FnCx::failed`); an
//! expression that failed has [`Type::Error`], which every later rule accepts silently, so one
//! mistake gives one diagnostic.

pub(crate) mod builtin_eval;
pub(crate) mod consteval;
pub mod rules;

mod call;
mod callgraph;
mod constfold;
mod consts;
mod decls;
mod expr;
mod follow_on;
mod func;
mod scope;
mod std_cache;
mod stmt;

#[cfg(test)]
mod tests;

use crate::diag::{Diagnostic, Diagnostics};
use crate::hir;
use crate::loader::ModuleGraph;
use crate::source::{SourceMap, Span};
use crate::types::Type;
use scope::{ConstInfo, FnCx, ItemRef, LibInfo, ModuleScope};
use std_cache::StdReuse;

/// Checks every module of the graph and builds the typed program. Errors and warnings go to
/// `diags`; the returned program holds every function that checked cleanly (functions with
/// errors are left out, so lowering only ever sees valid HIR).
///
/// The graph's standard modules are not checked again: their checked functions come from the
/// standard library checked once per process (`std_cache`).
pub fn check_program(graph: &ModuleGraph, sources: &SourceMap, diags: &mut Diagnostics) -> hir::Program {
    check_graph(graph, sources, diags, std_cache::std_checked())
}

fn check_graph(
    graph: &ModuleGraph,
    sources: &SourceMap,
    diags: &mut Diagnostics,
    std: Option<&'static std_cache::StdChecked>,
) -> hir::Program {
    let mut cx = Checker::new(graph, sources, diags);
    cx.collect_items();
    cx.std = std.and_then(|cache| StdReuse::new(cache, graph, &cx.libs));
    let checked = cx.check_items(true);
    follow_on::drop_unknown_names_in_incomplete_modules(graph, sources, diags);
    callgraph::assemble(checked.libs, checked.pipes, checked.removes)
}

/// Every function and `remove` item of a graph, checked, before the program is assembled.
struct CheckedItems {
    /// By provisional lib fn id (`None`: not a lib fn the checker could find again).
    libs: Vec<Option<func::LibOut>>,
    pipes: Vec<func::PipeOut>,
    removes: Vec<hir::Remove>,
}

/// The state of one run of the checker, shared by every function it checks.
struct Checker<'a> {
    graph: &'a ModuleGraph,
    sources: &'a SourceMap,
    diags: &'a mut Diagnostics,
    /// Item scope of each module, by module index.
    scopes: Vec<ModuleScope>,
    /// Every lib fn of every module; the index is its provisional id until the program is built.
    libs: Vec<LibInfo>,
    /// Every `const` item of every module.
    consts: Vec<ConstInfo>,
    /// Constants being evaluated, innermost last (for cycle messages).
    const_stack: Vec<usize>,
    /// The standard modules of the graph, checked once per process and copied from there.
    std: Option<StdReuse>,
    /// The names declared in pipeline headers, for help texts: gathered on the first error
    /// that needs them (see [`Checker::declared_names`]).
    declared: Option<scope::DeclaredNames>,
    /// Current nesting of expressions (across constant evaluation too: a chain of constants
    /// that refer to each other nests as deep as one expression would).
    expr_depth: u32,
    /// Current nesting of blocks.
    block_depth: u32,
    /// E0105 was reported inside a constant expression: a long chain of constants crosses the
    /// limit in each of its constants, but it is one mistake.
    const_too_deep: bool,
}

/// Deepest nesting of expressions, and of blocks, the checker follows before reporting E0105
/// (the parser has the same limits; this one also bounds chains of constants).
const MAX_DEPTH: u32 = 256;

impl<'a> Checker<'a> {
    fn new(graph: &'a ModuleGraph, sources: &'a SourceMap, diags: &'a mut Diagnostics) -> Checker<'a> {
        Checker {
            graph,
            sources,
            diags,
            scopes: Vec::new(),
            libs: Vec::new(),
            consts: Vec::new(),
            const_stack: Vec::new(),
            std: None,
            declared: None,
            expr_depth: 0,
            block_depth: 0,
            const_too_deep: false,
        }
    }

    /// Runs the passes after [`Checker::collect_items`] (and after deciding on [`Checker::std`]).
    /// `conflicts`: whether to check the declarations of different pipeline functions against
    /// each other.
    fn check_items(&mut self, conflicts: bool) -> CheckedItems {
        self.build_scopes();
        self.resolve_signatures();
        self.eval_all_consts();
        let mut libs = self.check_lib_fns();
        let (mut pipes, removes) = self.check_pipelines();
        if conflicts {
            self.check_conflicts(&mut pipes);
        }
        self.check_recursion(&mut libs);
        CheckedItems { libs, pipes, removes }
    }

    /// Reports a diagnostic that belongs to the function being checked: an error marks it failed.
    fn emit(&mut self, f: &mut FnCx, d: Diagnostic) {
        if d.is_error() {
            f.failed = true;
        }
        self.diags.push(d);
    }

    /// The item `name` in the scope of `module`.
    fn item(&self, module: usize, name: &str) -> Option<ItemRef> {
        self.scopes.get(module)?.names.get(name).copied()
    }

    /// The source text of a span for a message, shortened when long.
    fn show(&self, span: Span) -> String {
        let text = self.sources.snippet(span);
        let one_line = text.split_whitespace().collect::<Vec<_>>().join(" ");
        if one_line.chars().count() > 40 {
            let head: String = one_line.chars().take(37).collect();
            format!("{head}...")
        } else {
            one_line
        }
    }

    /// The display name of a module's file.
    fn module_name(&self, module: usize) -> String {
        match self.graph.modules.get(module) {
            Some(m) => self.sources.file(m.file).name.clone(),
            None => String::from("?"),
        }
    }
}

/// A type for the help text of a missing declaration: `TYPE` when nothing better is known.
fn type_or_placeholder(ty: Option<Type>) -> String {
    match ty {
        Some(t) if t.is_plain() && !t.is_error() => t.to_string(),
        _ => String::from("TYPE"),
    }
}

#[cfg(test)]
mod conformance {
    //! Every case of the shared conformance suite: the lines of errors and warnings must be
    //! exactly those the case's `// expect:` lines give.

    use super::check_program;
    use crate::diag::{Diagnostics, Severity};
    use crate::loader::Loader;
    use crate::source::SourceMap;
    use std::path::{Path, PathBuf};

    /// (kind, first line, last line) of each `// expect:` line.
    fn expectations(text: &str) -> Vec<(String, Option<(usize, usize)>)> {
        let mut out = Vec::new();
        for line in text.lines() {
            let Some(rest) = line.trim().strip_prefix("//") else { continue };
            let Some(rest) = rest.trim().strip_prefix("expect:") else { continue };
            let mut words = rest.split_whitespace();
            let kind = words.next().unwrap_or("").to_string();
            let range = match (words.next(), words.next()) {
                (Some("at"), Some(r)) => {
                    let (lo, hi) = r.split_once('-').unwrap_or((r, r));
                    Some((lo.parse().unwrap(), hi.parse().unwrap()))
                }
                _ => None,
            };
            out.push((kind, range));
        }
        out
    }

    fn run_case(entry: &Path) -> Result<(), String> {
        let text = std::fs::read_to_string(entry).map_err(|e| e.to_string())?;
        let expect = expectations(&text);
        if expect.iter().any(|(k, _)| k == "nocrash") {
            return Ok(());
        }
        let mut sources = SourceMap::new();
        let mut diags = Diagnostics::new();
        let graph = {
            let mut loader = Loader::new(&mut sources, &mut diags);
            loader.load_root_file(entry).map_err(|e| e.to_string())?;
            loader.finish()
        };
        check_program(&graph, &sources, &mut diags);
        let found: Vec<(Severity, usize, String)> = diags
            .iter()
            .map(|d| {
                let line = sources.position(d.span.start).map_or(0, |(_, p)| p.line);
                (d.severity, line, format!("{} {}", d.code.as_str(), d.message))
            })
            .collect();
        for (severity, kind) in [(Severity::Error, "error"), (Severity::Warning, "warning")] {
            let ranges: Vec<(usize, usize)> =
                expect.iter().filter(|(k, _)| k == kind).filter_map(|(_, r)| *r).collect();
            let got: Vec<&(Severity, usize, String)> = found.iter().filter(|d| d.0 == severity).collect();
            for (lo, hi) in &ranges {
                if !got.iter().any(|d| (*lo..=*hi).contains(&d.1)) {
                    return Err(format!("no {kind} at {lo}-{hi}; got {found:?}"));
                }
            }
            for d in &got {
                if !ranges.iter().any(|(lo, hi)| (*lo..=*hi).contains(&d.1)) {
                    return Err(format!("unexpected {kind} at line {}: {}", d.1, d.2));
                }
            }
        }
        Ok(())
    }

    #[test]
    fn conformance_cases() {
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/conformance/cases");
        let Ok(entries) = std::fs::read_dir(&dir) else {
            println!("skipped: no conformance cases at {}", dir.display());
            return;
        };
        let mut paths: Vec<PathBuf> = entries.filter_map(Result::ok).map(|e| e.path()).collect();
        paths.sort();
        let mut failures = Vec::new();
        for path in paths {
            let entry = if path.is_dir() { path.join("main.vrs") } else { path.clone() };
            if entry.extension().is_none_or(|x| x != "vrs") {
                continue;
            }
            if let Err(why) = run_case(&entry) {
                failures.push(format!("{}: {why}", path.display()));
            }
        }
        assert!(failures.is_empty(), "conformance failures:\n{}", failures.join("\n"));
    }
}
