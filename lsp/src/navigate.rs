//! Go to definition, and find references of state fields across the workspace's modules.

use crate::analysis::Analysis;
use crate::describe;
use crate::symbols::{self, Kind, Owner};
use crate::{scenes, uri};
use lsp_types::{Location, Position, Range};
use vrsc::source::Span;

/// Where the name at `position` is defined. A state field has no single definition: its
/// declarations that give a default are shown (every declaration when none does); a step path
/// leads to the functions placed in that step (or to its substep's function).
pub fn definition(analysis: &Analysis, position: Position) -> Vec<Location> {
    let ws = analysis.workspace();
    let offset = ws.document_offset(analysis.offset(position));
    let Some(symbol) = symbols::at(ws.document_ast(), offset) else { return Vec::new() };
    let spans: Vec<Span> = match &symbol.kind {
        Kind::State => {
            let decls = ws.state_decls(&symbol.name);
            let with_default: Vec<Span> = decls.iter().filter(|d| d.default.is_some()).map(|d| d.name_span).collect();
            if with_default.is_empty() { decls.iter().map(|d| d.name_span).collect() } else { with_default }
        }
        Kind::UniformDecl | Kind::ConstDecl | Kind::LocalDecl | Kind::PipelineName => vec![symbol.span],
        Kind::Name => {
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
            uniform.or_else(local).or_else(constant).into_iter().collect()
        }
        Kind::Function => {
            let visible = ws.visible_modules();
            let mut found = ws.lib_fns(Some(&symbol.name), Some(&visible));
            if found.is_empty() {
                found = ws.lib_fns(Some(&symbol.name), None);
            }
            found.iter().map(|f| f.item.name.span).collect()
        }
        Kind::Step { path, placement } => {
            let step = match vrsc::steps::Step::lookup(&path.step_name()) {
                vrsc::steps::StepLookup::Step(s) => Some(s),
                vrsc::steps::StepLookup::Group { first, last } => {
                    Some(if *placement == Some(vrsc::ast::PlacementKind::Before) { first } else { last })
                }
                vrsc::steps::StepLookup::Unknown => None,
            };
            // The function this placement belongs to is not where the step is defined.
            let mut placed = step.map(|s| ws.placed_in(s)).unwrap_or_default();
            placed.retain(|f| f.item.placement.target.span != path.span);
            let named: Vec<Span> = placed
                .iter()
                .filter(|f| path.substep.as_ref().is_some_and(|sub| sub.name == f.item.name.name))
                .map(|f| f.item.name.span)
                .collect();
            if named.is_empty() { placed.iter().map(|f| f.item.name.span).collect() } else { named }
        }
        Kind::StdModule => {
            let Some(module) = symbol.name.strip_prefix("std::").and_then(|n| ws.std_module(n)) else {
                return Vec::new();
            };
            let base = ws.sources.file(ws.graph.modules[module].file).base;
            vec![Span::new(base, base)]
        }
        Kind::FileImport => return file_import(analysis, &symbol.name).into_iter().collect(),
        Kind::Type | Kind::Member => Vec::new(),
    };
    spans.into_iter().filter_map(|span| ws.location(span, &analysis.uri)).collect()
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
