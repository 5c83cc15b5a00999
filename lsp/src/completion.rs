//! Completion, chosen by what the line before the cursor says: state fields after `state.`,
//! step paths after a placement keyword (substeps inside `[`), library functions after `use`,
//! types after `:`, standard modules after `import std::`, and otherwise the names a body may
//! use (declared uniforms, locals, constants, library functions, built-ins with their
//! signatures) and keywords.

use crate::analysis::Analysis;
use crate::describe;
use crate::fixes;
use crate::symbols::{self, Owner};
use crate::workspace::Workspace;
use lsp_types::{
    CompletionItem, CompletionItemKind, CompletionTextEdit, Documentation, MarkupContent, MarkupKind, Position, Range,
    TextEdit,
};
use vrsc::ast::{self, DeclKind};
use vrsc::steps::Step;

const GROUPS: &[&str] = &["sampling", "classification", "shading", "compositing"];
const TYPES: &[&str] = &[
    "bool", "i32", "u32", "f32", "vec2f", "vec3f", "vec4f", "vec2i", "vec3i", "vec4i", "vec2u", "vec3u", "vec4u",
    "mat2x2f", "mat3x3f", "mat4x4f", "volume", "tf",
];
const BODY_KEYWORDS: &[&str] = &["let", "var", "if", "else", "for", "break", "continue", "return", "true", "false"];
const ITEM_KEYWORDS: &[&str] = &["import", "const", "lib fn", "pipeline", "remove"];
const DECL_KEYWORDS: &[&str] = &["state", "@ray state", "uniform", "use"];

/// The completion items at `position`.
pub fn complete(analysis: &Analysis, position: Position) -> Vec<CompletionItem> {
    let offset = analysis.offset(position);
    let line_start = analysis.text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let prefix = &analysis.text[line_start..offset];
    let cx = Cx { analysis, ws: analysis.workspace(), offset, position };
    if after_state_dot(prefix).is_some() {
        return cx.state_fields();
    }
    if let Some(place) = placement_context(prefix) {
        return match place {
            Place::Step { keyword, partial } => cx.steps(keyword, partial),
            Place::Substep { step, partial } => cx.substeps(step, partial),
        };
    }
    if prefix.trim_end().ends_with(" when") {
        return vec![keyword_item("active")];
    }
    if let Some(rest) = prefix.trim_start().strip_prefix("import std::") {
        return vrsc::stdlib::names()
            .filter(|n| n.starts_with(rest))
            .map(|n| CompletionItem {
                label: n.to_string(),
                kind: Some(CompletionItemKind::MODULE),
                ..Default::default()
            })
            .collect();
    }
    if prefix.trim_start().starts_with("use ") {
        return cx.lib_fns(None);
    }
    if after_colon(prefix) {
        return TYPES.iter().map(|t| simple(t, CompletionItemKind::CLASS, None)).collect();
    }
    cx.names()
}

struct Cx<'a> {
    analysis: &'a Analysis,
    ws: &'a Workspace,
    /// Local byte offset of the cursor.
    offset: usize,
    position: Position,
}

impl Cx<'_> {
    fn global(&self) -> u32 {
        self.ws.document_offset(self.offset)
    }

    fn pipeline(&self) -> Option<&ast::PipelineFn> {
        symbols::pipeline_at(self.ws.document_ast(), self.global())
    }

    /// An edit replacing the `len` bytes before the cursor with `text`.
    fn replace_before(&self, len: usize, text: &str) -> CompletionTextEdit {
        let start = self.analysis.lines.position(&self.analysis.text, self.offset - len);
        CompletionTextEdit::Edit(TextEdit::new(Range::new(start, self.position), text.to_string()))
    }

    /// Fields the enclosing function declares first, then every other field of the workspace;
    /// choosing one of those also adds its declaration.
    fn state_fields(&self) -> Vec<CompletionItem> {
        let pipeline = self.pipeline();
        let declared: Vec<(String, String, bool)> = pipeline
            .map(|p| {
                p.decls
                    .iter()
                    .filter_map(|d| match &d.kind {
                        DeclKind::State { ray, name, ty, .. } => {
                            Some((name.name.clone(), self.ws.snippet(ty.span).to_string(), *ray))
                        }
                        _ => None,
                    })
                    .collect()
            })
            .unwrap_or_default();
        let mut items: Vec<CompletionItem> = declared
            .iter()
            .map(|(name, ty, ray)| CompletionItem {
                label: name.clone(),
                kind: Some(CompletionItemKind::FIELD),
                detail: Some(format!("{}state {name}: {ty}", if *ray { "@ray " } else { "" })),
                documentation: Some(markdown(describe::state_field(self.ws, name, pipeline))),
                sort_text: Some(format!("0{name}")),
                ..Default::default()
            })
            .collect();
        for (name, decl) in self.ws.state_names() {
            // Clients filter what is typed (`partial`) themselves, fuzzily.
            if declared.iter().any(|(n, _, _)| *n == name) {
                continue;
            }
            let ray = if decl.ray { "@ray " } else { "" };
            let declaration = format!("{ray}state {name}: {};", self.ws.snippet(decl.ty.span));
            let additional = pipeline.map(|p| {
                let (offset, text) =
                    fixes::declaration_insert(p, self.ws.document_offset(0), &self.analysis.text, &declaration);
                let at = self.analysis.lines.position(&self.analysis.text, offset);
                vec![TextEdit::new(Range::new(at, at), text)]
            });
            items.push(CompletionItem {
                label: name.clone(),
                kind: Some(CompletionItemKind::FIELD),
                detail: Some(format!("{declaration} (adds the declaration)")),
                documentation: Some(markdown(describe::state_field(self.ws, &name, None))),
                sort_text: Some(format!("1{name}")),
                additional_text_edits: additional,
                ..Default::default()
            });
        }
        items
    }

    /// Step names (and group names for `before`/`after`) matching what is typed.
    fn steps(&self, keyword: &str, partial: &str) -> Vec<CompletionItem> {
        let groups = if matches!(keyword, "before" | "after") { GROUPS } else { &[] };
        Step::ALL
            .iter()
            .map(|s| (s.name(), describe::step_summary(*s)))
            .chain(
                groups
                    .iter()
                    .map(|g| (*g, format!("group: its {} step", if keyword == "before" { "first" } else { "last" }))),
            )
            .filter(|(name, _)| name.starts_with(partial))
            .map(|(name, summary)| CompletionItem {
                label: name.to_string(),
                kind: Some(CompletionItemKind::ENUM_MEMBER),
                detail: Some(summary),
                text_edit: Some(self.replace_before(partial.len(), name)),
                ..Default::default()
            })
            .collect()
    }

    /// The substeps of `step`: the functions the workspace places there.
    fn substeps(&self, step: &str, partial: &str) -> Vec<CompletionItem> {
        let Some(step) = Step::ALL.iter().find(|s| s.name() == step) else { return Vec::new() };
        let mut seen = Vec::new();
        let mut items = Vec::new();
        for f in self.ws.placed_in(*step) {
            let name = &f.item.name.name;
            if seen.contains(name) || !name.starts_with(partial) {
                continue;
            }
            seen.push(name.clone());
            items.push(CompletionItem {
                label: name.clone(),
                kind: Some(CompletionItemKind::ENUM_MEMBER),
                detail: Some(format!("substep of {step} ({})", self.ws.module_label(f.module))),
                documentation: f.doc.map(|d| markdown(d.to_string())),
                ..Default::default()
            });
        }
        if "$".starts_with(partial) && !seen.iter().any(|s| s == "$") {
            items.push(simple(
                "$",
                CompletionItemKind::ENUM_MEMBER,
                Some("the instance's own substep (in a template)"),
            ));
        }
        items
    }

    /// Library functions in scope; `declared` limits them to a `use` list.
    fn lib_fns(&self, declared: Option<&[String]>) -> Vec<CompletionItem> {
        let visible = self.ws.visible_modules();
        self.ws
            .lib_fns(None, Some(&visible))
            .iter()
            .filter(|f| declared.is_none_or(|list| list.contains(&f.item.name.name)))
            .map(|f| CompletionItem {
                label: f.item.name.name.clone(),
                kind: Some(CompletionItemKind::FUNCTION),
                detail: Some(describe::lib_signature(self.ws, f.item)),
                documentation: f.doc.map(|d| markdown(d.to_string())),
                ..Default::default()
            })
            .collect()
    }

    /// What an expression or statement may name here.
    fn names(&self) -> Vec<CompletionItem> {
        let global = self.global();
        let owner = match (self.pipeline(), symbols::lib_at(self.ws.document_ast(), global)) {
            (Some(p), _) => Owner::Pipeline(p),
            (None, Some(f)) => Owner::Lib(f),
            (None, None) => return ITEM_KEYWORDS.iter().map(|k| keyword_item(k)).collect(),
        };
        let mut items = match owner {
            Owner::Pipeline(p) => self.pipeline_names(p),
            _ => self.lib_fns(None),
        };
        for site in symbols::locals(owner).iter().filter(|s| s.name.span.end <= global) {
            items.push(simple(&site.name.name, CompletionItemKind::VARIABLE, None));
        }
        for c in self.ws.consts(None, &self.ws.visible_modules()) {
            let detail = Some(describe::const_decl(self.ws, c.item));
            items.push(CompletionItem {
                label: c.item.name.name.clone(),
                kind: Some(CompletionItemKind::CONSTANT),
                detail,
                ..Default::default()
            });
        }
        items.extend(builtin_items());
        let types = TYPES.iter().filter(|t| !matches!(**t, "volume" | "tf"));
        items.extend(types.map(|t| simple(t, CompletionItemKind::CLASS, None)));
        items.extend(BODY_KEYWORDS.iter().map(|k| keyword_item(k)));
        let mut seen = std::collections::HashSet::new();
        items.retain(|i| seen.insert(i.label.clone()));
        items
    }

    /// What a pipeline function's body may name beyond locals and constants: its uniforms, the
    /// library functions it uses, `state`, and the declaration keywords before the first
    /// statement.
    fn pipeline_names(&self, p: &ast::PipelineFn) -> Vec<CompletionItem> {
        let mut items = Vec::new();
        let mut uses = Vec::new();
        for decl in &p.decls {
            match &decl.kind {
                DeclKind::Uniform { name, ty, .. } => items.push(CompletionItem {
                    label: name.name.clone(),
                    kind: Some(CompletionItemKind::VARIABLE),
                    detail: Some(format!("uniform {}: {}", name.name, self.ws.snippet(ty.span))),
                    documentation: describe::uniform(self.ws, &name.name, name.span).map(markdown),
                    ..Default::default()
                }),
                DeclKind::Use { names } => uses.extend(names.iter().map(|n| n.name.clone())),
                DeclKind::State { .. } => {}
            }
        }
        items.extend(self.lib_fns(Some(&uses)));
        if p.body.stmts.first().is_none_or(|s| self.global() <= s.span.start) {
            items.extend(DECL_KEYWORDS.iter().map(|k| keyword_item(k)));
        }
        items.push(keyword_item("state"));
        items
    }
}

/// Every built-in, with how it is called and what it accepts.
fn builtin_items() -> impl Iterator<Item = CompletionItem> {
    vrsc::check::rules::builtins().iter().map(|(builtin, name)| {
        let (call, accepts) = describe::builtin_call(*builtin);
        CompletionItem {
            label: name.to_string(),
            kind: Some(CompletionItemKind::FUNCTION),
            detail: Some(call),
            documentation: Some(markdown(format!("Built-in: {accepts}."))),
            ..Default::default()
        }
    })
}

fn markdown(value: String) -> Documentation {
    Documentation::MarkupContent(MarkupContent { kind: MarkupKind::Markdown, value })
}

fn simple(label: &str, kind: CompletionItemKind, detail: Option<&str>) -> CompletionItem {
    CompletionItem {
        label: label.to_string(),
        kind: Some(kind),
        detail: detail.map(String::from),
        ..Default::default()
    }
}

fn keyword_item(keyword: &str) -> CompletionItem {
    simple(keyword, CompletionItemKind::KEYWORD, None)
}

fn is_ident_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_' || c == '$'
}

/// The part of a field name typed after `state.`, if the cursor follows `state.`.
fn after_state_dot(prefix: &str) -> Option<&str> {
    let partial_start = prefix.trim_end_matches(is_ident_char).len();
    let before = prefix[..partial_start].strip_suffix("state.")?;
    (!before.ends_with(is_ident_char)).then_some(&prefix[partial_start..])
}

/// What a placement being typed needs.
enum Place<'a> {
    Step { keyword: &'a str, partial: &'a str },
    Substep { step: &'a str, partial: &'a str },
}

/// A placement on this line: `pipeline NAME KEYWORD path` or `remove path`, the path being typed.
fn placement_context(prefix: &str) -> Option<Place<'_>> {
    let partial_start = prefix.trim_end_matches(|c: char| is_ident_char(c) || c == '.' || c == '[').len();
    let partial = &prefix[partial_start..];
    let words: Vec<&str> = prefix[..partial_start].split_whitespace().collect();
    let keyword = match words.as_slice() {
        ["pipeline", _, keyword] => *keyword,
        ["remove"] => "remove",
        _ => return None,
    };
    if !matches!(keyword, "before" | "after" | "in" | "replace" | "remove") || !prefix[..partial_start].ends_with(' ') {
        return None;
    }
    match partial.split_once('[') {
        Some((step, sub)) => Some(Place::Substep { step, partial: sub }),
        None => Some(Place::Step { keyword, partial }),
    }
}

/// Whether the cursor is in a type position: after a single `:`.
fn after_colon(prefix: &str) -> bool {
    let before = prefix.trim_end_matches(is_ident_char).trim_end();
    before.ends_with(':') && !before.ends_with("::")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contexts_are_read_from_the_line() {
        assert_eq!(after_state_dot("    x = state.gra"), Some("gra"));
        assert_eq!(after_state_dot("    x = mystate.gra"), None);
        assert!(matches!(
            placement_context("pipeline glow after shading.li"),
            Some(Place::Step { keyword: "after", partial: "shading.li" })
        ));
        assert!(matches!(
            placement_context("pipeline glow after shading.lights[ke"),
            Some(Place::Substep { step: "shading.lights", partial: "ke" })
        ));
        assert!(matches!(placement_context("remove "), Some(Place::Step { keyword: "remove", partial: "" })));
        assert!(placement_context("    for i in 0").is_none());
        assert!(after_colon("    state g: vec"));
        assert!(!after_colon("import std::"));
    }
}
