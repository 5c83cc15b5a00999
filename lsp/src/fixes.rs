//! Quick fixes from the checker's hints: a missing `state`, `uniform` or `use` declaration
//! (E0501, E0502, E0503), inserted after the last declaration of the pipeline function.
//!
//! The checker writes the declaration into its help note between backquotes (`add `state
//! gradient: vec3f;` to the declarations`); the fix inserts exactly that text.

use crate::symbols;
use vrsc::ast::{self, Module};
use vrsc::diag::{Code, Diagnostic};

/// A declaration to insert into the document.
#[derive(Clone, Debug, PartialEq)]
pub struct Fix {
    /// `Add `state gradient: vec3f;``.
    pub title: String,
    /// Byte offset in the document where `text` goes.
    pub offset: usize,
    pub text: String,
}

/// The fix for `d`, if it is a missing declaration. `module` is the document's syntax tree,
/// `base` the global offset of its first byte, `text` the document.
pub fn fix_for(d: &Diagnostic, module: &Module, base: u32, text: &str) -> Option<Fix> {
    if !matches!(d.code, Code::UndeclaredState | Code::UndeclaredUniform | Code::UndeclaredLibrary) {
        return None;
    }
    let decl = d.notes.iter().filter(|n| n.starts_with("help:")).find_map(|n| declaration_in(n))?;
    let pipeline = symbols::pipeline_at(module, d.span.start)?;
    let (offset, text) = declaration_insert(pipeline, base, text, decl);
    Some(Fix { title: format!("Add `{decl}`"), offset, text })
}

/// Where a new declaration `decl` of `pipeline` goes and the text to insert there: a new line
/// after its last declaration (or after the opening brace), indented like its neighbours.
pub fn declaration_insert(pipeline: &ast::PipelineFn, base: u32, text: &str, decl: &str) -> (usize, String) {
    let (offset, indent) = match pipeline.decls.last() {
        Some(last) => {
            (line_end(text, (last.span.end - base) as usize), indent_of(text, (last.span.start - base) as usize))
        }
        None => {
            let open = (pipeline.body.span.start - base) as usize;
            let first = pipeline.body.stmts.first().map(|s| indent_of(text, (s.span.start - base) as usize));
            (line_end(text, open), first.unwrap_or_else(|| format!("{}    ", indent_of(text, open))))
        }
    };
    (offset, format!("\n{indent}{decl}"))
}

/// The first backquoted declaration in a help note.
fn declaration_in(note: &str) -> Option<&str> {
    note.split('`').skip(1).step_by(2).find(|quoted| {
        let starts = ["state ", "@ray state ", "uniform ", "use "].iter().any(|k| quoted.starts_with(k));
        starts && quoted.ends_with(';')
    })
}

/// The offset of the end of the line holding `offset` (before its newline).
fn line_end(text: &str, offset: usize) -> usize {
    let offset = offset.min(text.len());
    text[offset..].find('\n').map_or(text.len(), |i| offset + i).min(text.len())
}

/// The leading whitespace of the line holding `offset`.
fn indent_of(text: &str, offset: usize) -> String {
    let offset = offset.min(text.len());
    let start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    text[start..].chars().take_while(|c| *c == ' ' || *c == '\t').collect()
}

#[cfg(test)]
mod tests {
    use super::declaration_in;

    #[test]
    fn declarations_are_read_from_help_notes() {
        assert_eq!(
            declaration_in("help: add `@ray state accum: vec4f;` to the declarations"),
            Some("@ray state accum: vec4f;")
        );
        assert_eq!(
            declaration_in("help: declare it as a uniform: `uniform tint: vec4f;`"),
            Some("uniform tint: vec4f;")
        );
        assert_eq!(declaration_in("help: add `use brighten;` to the declarations of `p`"), Some("use brighten;"));
        assert_eq!(declaration_in("help: did you mean `gradient`?"), None);
    }
}
