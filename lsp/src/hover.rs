//! Hover: what a name under the cursor is, in Markdown.

use crate::analysis::Analysis;
use crate::describe;
use crate::symbols::{self, Kind, Owner, Symbol};
use lsp_types::{Hover, HoverContents, MarkupContent, MarkupKind, Position};

/// The hover text at `position` of the analysed document.
pub fn hover(analysis: &Analysis, position: Position) -> Option<Hover> {
    let ws = analysis.workspace();
    let offset = ws.document_offset(analysis.offset(position));
    let symbol = symbols::at(ws.document_ast(), offset)?;
    let value = text(analysis, &symbol)?;
    let range = ws.location(symbol.span, &analysis.uri).map(|l| l.range);
    Some(Hover { contents: HoverContents::Markup(MarkupContent { kind: MarkupKind::Markdown, value }), range })
}

fn text(analysis: &Analysis, symbol: &Symbol<'_>) -> Option<String> {
    let ws = analysis.workspace();
    let pipeline = match symbol.owner {
        Owner::Pipeline(p) => Some(p),
        _ => None,
    };
    match &symbol.kind {
        Kind::State => Some(describe::state_field(ws, &symbol.name, pipeline)),
        Kind::UniformDecl => describe::uniform(ws, &symbol.name, symbol.span),
        Kind::Name => name(analysis, symbol),
        Kind::Function => describe::function(ws, &symbol.name),
        Kind::ConstDecl => describe::constant(ws, &symbol.name, &ws.visible_modules()),
        Kind::LocalDecl => describe::local(analysis, symbol),
        Kind::PipelineName => pipeline.map(|p| describe::pipeline(ws, p)),
        Kind::Type => Some(describe::type_name(&symbol.name)),
        Kind::Step { path, placement } => Some(describe::step_path(ws, path, *placement)),
        Kind::StdModule => describe::std_module(ws, &symbol.name),
        Kind::FileImport => {
            Some(format!("```vrs\nimport \"{}\";\n```\nA module file, relative to this one.", symbol.name))
        }
        Kind::Member => None,
    }
}

/// A plain name: a declared uniform of the enclosing pipeline function, a constant in scope, or
/// a local or parameter.
fn name(analysis: &Analysis, symbol: &Symbol<'_>) -> Option<String> {
    let ws = analysis.workspace();
    if let Owner::Pipeline(p) = symbol.owner
        && let Some(span) = describe::uniform_span_in(p, &symbol.name)
    {
        return describe::uniform(ws, &symbol.name, span);
    }
    describe::local(analysis, symbol).or_else(|| describe::constant(ws, &symbol.name, &ws.visible_modules()))
}
