//! Follow-on errors of a module that may lack items. When an import fails (a missing file, a
//! cycle) or a file has syntax errors or is not UTF-8, the names it would have defined are
//! unknown to the checker; reporting each use of them would bury the one real mistake under
//! errors that go away with it. Such a module is marked incomplete by the loader, and the
//! unknown-name errors in it, or in a module that imports it directly, are dropped here.

use crate::diag::{Code, Diagnostics};
use crate::loader::ModuleGraph;
use crate::source::SourceMap;
use rustc_hash::FxHashSet;

/// The codes that say a name was not found: what a missing item causes.
const UNKNOWN_NAME_CODES: [Code; 4] =
    [Code::UnknownName, Code::UnknownFunction, Code::UnknownType, Code::UnknownLibrary];

/// Drops the unknown-name errors located in a module that is incomplete or imports one.
pub(super) fn drop_unknown_names_in_incomplete_modules(
    graph: &ModuleGraph,
    sources: &SourceMap,
    diags: &mut Diagnostics,
) {
    let affected: FxHashSet<usize> = graph
        .modules
        .iter()
        .filter(|m| m.incomplete || m.imports.iter().any(|&i| graph.modules.get(i).is_some_and(|t| t.incomplete)))
        .map(|m| m.file)
        .collect();
    if affected.is_empty() {
        return;
    }
    diags.retain(|d| {
        !UNKNOWN_NAME_CODES.contains(&d.code)
            || sources.file_of(d.span.start).is_none_or(|file| !affected.contains(&file))
    });
}
