//! Go to definition, and find references of state fields across the workspace's modules.

use crate::analysis::Analysis;
use crate::describe;
use crate::symbols::{self, Kind, Owner};
use crate::workspace::{self, Workspace};
use crate::{scenes, uri};
use lsp_types::{Location, Position, Range};
use vrsc::ast;
use vrsc::source::Span;

/// Where the name at `position` is defined. A state field has no single definition: its
/// declarations that give a default are shown (every declaration when none does); a step path
/// leads to the functions placed in that step (or to its substep's function).
pub fn definition(analysis: &Analysis, position: Position) -> Vec<Location> {
    let ws = analysis.workspace();
    let offset = ws.document_offset(analysis.offset(position));
    let Some(symbol) = symbols::at(ws.document_ast(), offset) else { return Vec::new() };
    let spans: Vec<Span> = match &symbol.kind {
        Kind::State => state_definitions(ws, &symbol.name),
        Kind::UniformDecl | Kind::ConstDecl | Kind::LocalDecl | Kind::PipelineName => vec![symbol.span],
        Kind::Name => name_definition(ws, &symbol).into_iter().collect(),
        Kind::Function => {
            let visible = ws.visible_modules();
            let mut found = ws.lib_fns(Some(&symbol.name), Some(&visible));
            if found.is_empty() {
                found = ws.lib_fns(Some(&symbol.name), None);
            }
            found.iter().map(|f| f.item.name.span).collect()
        }
        Kind::Step { path, placement } => step_definitions(ws, path, *placement),
        Kind::StdModule => {
            let module = symbol.name.strip_prefix("std::").and_then(|n| ws.std_module(n));
            let base = module.map(|m| ws.sources.file(ws.graph.modules[m].file).base);
            base.map(|b| Span::new(b, b)).into_iter().collect()
        }
        Kind::FileImport => return file_import(analysis, &symbol.name).into_iter().collect(),
        Kind::Type | Kind::Member => Vec::new(),
    };
    spans.into_iter().filter_map(|span| ws.location(span, &analysis.uri)).collect()
}

/// The declarations of a state field that give a default, else all of them.
fn state_definitions(ws: &Workspace, name: &str) -> Vec<Span> {
    let decls = ws.state_decls(name);
    let with_default: Vec<Span> = decls.iter().filter(|d| d.default.is_some()).map(|d| d.name_span).collect();
    if with_default.is_empty() { decls.iter().map(|d| d.name_span).collect() } else { with_default }
}

/// A plain name: the enclosing function's uniform, else the nearest local before it, else a
/// constant in scope.
fn name_definition(ws: &Workspace, symbol: &symbols::Symbol<'_>) -> Option<Span> {
    let uniform = match symbol.owner {
        Owner::Pipeline(p) => describe::uniform_span_in(p, &symbol.name),
        _ => None,
    };
    let local = || {
        symbols::locals(symbol.owner)
            .iter()
            .rfind(|s| s.name.name == symbol.name && s.name.span.start <= symbol.span.start)
            .map(|s| s.name.span)
    };
    let constant = || ws.consts(Some(&symbol.name), &ws.visible_modules()).first().map(|c| c.item.name.span);
    uniform.or_else(local).or_else(constant)
}

/// The functions placed in the step a path names (its substep's function when it names one),
/// leaving out the function whose placement the path is.
fn step_definitions(ws: &Workspace, path: &ast::StepPath, placement: Option<ast::PlacementKind>) -> Vec<Span> {
    let Some(step) = workspace::resolve_step(&path.step_name(), placement) else { return Vec::new() };
    let placed: Vec<_> = ws.placed_in(step).into_iter().filter(|f| f.item.placement.target.span != path.span).collect();
    let named: Vec<Span> = placed
        .iter()
        .filter(|f| path.substep.as_ref().is_some_and(|sub| sub.name == f.item.name.name))
        .map(|f| f.item.name.span)
        .collect();
    if named.is_empty() { placed.iter().map(|f| f.item.name.span).collect() } else { named }
}

/// The start of an imported file, relative to the document.
fn file_import(analysis: &Analysis, path: &str) -> Option<Location> {
    let dir = analysis.path.as_deref()?.parent()?;
    let target = scenes::canonical(&dir.join(path));
    target.is_file().then_some(())?;
    Some(Location::new(uri::from_path(&target)?, Range::default()))
}

/// Every use and declaration of the state field at `position` in the document, what it
/// imports, the modules of its scenes and the standard library.
pub fn references(analysis: &Analysis, position: Position, include_declaration: bool) -> Vec<Location> {
    let ws = analysis.workspace();
    let offset = ws.document_offset(analysis.offset(position));
    let Some(symbol) = symbols::at(ws.document_ast(), offset).filter(|s| matches!(s.kind, Kind::State)) else {
        return Vec::new();
    };
    let mut modules: Vec<usize> = (0..ws.graph.modules.len()).collect();
    // The document first, then the others in load order.
    modules.retain(|&m| m != ws.document);
    modules.insert(0, ws.document);
    modules
        .into_iter()
        .flat_map(|m| symbols::state_uses(ws.ast(m), &symbol.name))
        .filter(|(_, is_decl)| include_declaration || !is_decl)
        .filter_map(|(span, _)| ws.location(span, &analysis.uri))
        .collect()
}
