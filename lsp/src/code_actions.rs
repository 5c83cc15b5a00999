//! Code actions: the quick fixes of the diagnostics shown on the requested range.

use crate::analysis::Analysis;
use lsp_types::{CodeAction, CodeActionKind, CodeActionOrCommand, Range, TextEdit, WorkspaceEdit};
use std::collections::HashMap;

/// The fixes of every diagnostic whose range overlaps `range`.
// lsp-types keys `WorkspaceEdit::changes` by `Uri`, whose interior `Cell` is fluent-uri's lazily
// parsed authority: it never changes what the key hashes or compares as (its text).
#[allow(clippy::mutable_key_type)]
pub fn actions(analysis: &Analysis, range: Range) -> Vec<CodeActionOrCommand> {
    let overlaps = |r: &Range| r.start <= range.end && range.start <= r.end;
    analysis
        .diagnostics
        .iter()
        .filter(|r| overlaps(&r.diagnostic.range))
        .filter_map(|r| {
            let fix = r.fix.as_ref()?;
            let at = analysis.lines.position(&analysis.text, fix.offset);
            let edit = TextEdit::new(Range::new(at, at), fix.text.clone());
            let changes = HashMap::from([(analysis.uri.clone(), vec![edit])]);
            Some(CodeActionOrCommand::CodeAction(CodeAction {
                title: fix.title.clone(),
                kind: Some(CodeActionKind::QUICKFIX),
                diagnostics: Some(vec![r.diagnostic.clone()]),
                edit: Some(WorkspaceEdit { changes: Some(changes), ..WorkspaceEdit::default() }),
                is_preferred: Some(true),
                ..CodeAction::default()
            }))
        })
        .collect()
}
