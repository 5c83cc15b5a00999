//! Markdown descriptions of what names mean, shared by hover and completion.

use crate::analysis::Analysis;
use crate::symbols::{self, LocalKind, Owner, Symbol};
use crate::workspace::{self, Workspace};
use vrsc::ast::{self, DeclKind, PlacementKind};
use vrsc::check::rules;
use vrsc::source::Span;
use vrsc::steps::{PipelineKind, Step, StepLookup};

/// How many declaring functions a state field's hover lists.
const MAX_LISTED: usize = 8;

fn code(text: &str) -> String {
    format!("```vrs\n{text}\n```")
}

fn with_doc(mut out: String, doc: Option<&str>) -> String {
    if let Some(doc) = doc {
        out.push_str("\n\n");
        out.push_str(doc);
    }
    out
}

/// `sample` or `ray` lifetime, in words.
pub fn lifetime(ray: bool) -> &'static str {
    if ray { "ray: lives for the whole ray (`@ray`)" } else { "sample: reset to its default before every sample" }
}

/// A state field: its type, lifetime, default and doc, as declared by `pipeline` (the enclosing
/// function) or elsewhere in the workspace.
pub fn state_field(ws: &Workspace, name: &str, pipeline: Option<&ast::PipelineFn>) -> String {
    let decls = ws.state_decls(name);
    let own = decls.iter().find(|d| pipeline.is_some_and(|p| std::ptr::eq(d.pipeline, p)));
    let with_default = decls.iter().find(|d| d.default.is_some());
    let Some(shown) = own.or(with_default).or(decls.first()) else {
        return format!("`state.{name}`: no module in the workspace declares this field.");
    };
    let ty = ws.snippet(shown.ty.span);
    let ray = if shown.ray { "@ray " } else { "" };
    let mut out = code(&format!("{ray}state {name}: {ty}"));
    out.push_str(&format!("\n\nLifetime: {}.", lifetime(shown.ray)));
    match with_default {
        Some(d) => out.push_str(&format!(
            "\n\nDefault: `{}` (from `{}` in {}).",
            ws.snippet(d.default.map_or(Span::DUMMY, |e| e.span)),
            d.pipeline.name.name,
            ws.module_label(d.module)
        )),
        None => out.push_str("\n\nDefault: none declared in the workspace (a composed pipeline needs one)."),
    }
    if let Some(doc) = own.and_then(|d| d.doc).or_else(|| decls.iter().find_map(|d| d.doc)) {
        out.push_str(&format!("\n\n{doc}"));
    }
    if let Some(p) = pipeline.filter(|_| own.is_none()) {
        out.push_str(&format!("\n\nNot declared in `{}`: add `{ray}state {name}: {ty};`.", p.name.name));
    }
    let listed: Vec<String> = decls
        .iter()
        .take(MAX_LISTED)
        .map(|d| format!("`{}` ({})", d.pipeline.name.name, ws.module_label(d.module)))
        .collect();
    let more = decls.len().saturating_sub(MAX_LISTED);
    out.push_str(&format!(
        "\n\nDeclared by {}{}.",
        listed.join(", "),
        if more > 0 { format!(" and {more} more") } else { String::new() }
    ));
    out
}

/// The name span of `pipeline`'s declaration of uniform `name`.
pub fn uniform_span_in(pipeline: &ast::PipelineFn, name: &str) -> Option<Span> {
    pipeline.decls.iter().find_map(|d| match &d.kind {
        DeclKind::Uniform { name: n, .. } if n.name == name => Some(n.span),
        _ => None,
    })
}

/// The uniform declared with the name at `name_span`.
pub fn uniform(ws: &Workspace, name: &str, name_span: Span) -> Option<String> {
    let decls = ws.uniform_decls(name);
    let d = decls.iter().find(|d| d.name_span == name_span)?;
    let mut decl = format!("uniform {name}: {}", ws.snippet(d.ty.span));
    if let Some(default) = d.default {
        decl.push_str(&format!(" = {}", ws.snippet(default.span)));
    }
    if let Some((lo, hi)) = d.range {
        decl.push_str(&format!(" in {} .. {}", ws.snippet(lo.span), ws.snippet(hi.span)));
    }
    let doc = d.doc.or_else(|| decls.iter().find_map(|d| d.doc));
    let mut out = with_doc(code(&decl), doc);
    if d.range.is_some() {
        out.push_str("\n\nThe range bounds a slider (each component); values outside it are accepted.");
    }
    Some(out)
}

/// The signature of a library function as written.
pub fn lib_signature(ws: &Workspace, f: &ast::LibFn) -> String {
    let params: Vec<String> = f.params.iter().map(|p| format!("{}: {}", p.name.name, ws.snippet(p.ty.span))).collect();
    let ret = f.ret.as_ref().map_or_else(String::new, |r| format!(" -> {}", ws.snippet(r.span)));
    format!("lib fn {}({}){ret}", f.name.name, params.join(", "))
}

/// A called name: a library function in scope (or anywhere in the workspace), or a built-in.
pub fn function(ws: &Workspace, name: &str) -> Option<String> {
    let visible = ws.visible_modules();
    let mut found = ws.lib_fns(Some(name), Some(&visible));
    if found.is_empty() {
        found = ws.lib_fns(Some(name), None);
    }
    if let Some(f) = found.first() {
        let out = with_doc(code(&lib_signature(ws, f.item)), f.doc);
        return Some(format!("{out}\n\nLibrary function of {}.", ws.module_label(f.module)));
    }
    builtin(name)
}

/// The call form of a built-in: `clamp(e, low, high)`, `abs(x)`.
pub fn builtin_call(builtin: vrsc::hir::Builtin) -> (String, &'static str) {
    let (usage, accepts) = rules::builtin_usage(builtin);
    if usage.contains('(') {
        return (usage.to_string(), accepts);
    }
    let args = match accepts.split_whitespace().nth(1) {
        Some("one") => "x",
        Some("two") => "a, b",
        Some("three") => "a, b, c",
        _ => "…",
    };
    (format!("{usage}({args})"), accepts)
}

/// A built-in function: how it is called and what it accepts.
pub fn builtin(name: &str) -> Option<String> {
    let builtin = rules::builtin_by_name(name)?;
    let (call, accepts) = builtin_call(builtin);
    Some(format!("{}\n\nBuilt-in: {accepts} (WGSL's meaning).", code(&call)))
}

/// A constant's declaration as written: `const PI: f32 = 3.14159265`.
pub fn const_decl(ws: &Workspace, c: &ast::ConstItem) -> String {
    let ty = c.ty.as_ref().map_or_else(String::new, |t| format!(": {}", ws.snippet(t.span)));
    format!("const {}{ty} = {}", c.name.name, ws.snippet(c.value.span))
}

/// A constant in `modules`.
pub fn constant(ws: &Workspace, name: &str, modules: &[usize]) -> Option<String> {
    let found = ws.consts(Some(name), modules);
    let c = found.first()?;
    let decl = const_decl(ws, c.item);
    Some(format!("{}\n\nConstant of {}.", with_doc(code(&decl), c.doc), ws.module_label(c.module)))
}

/// A local variable or parameter: its type from the checked program when the function checked,
/// else as written.
pub fn local(analysis: &Analysis, symbol: &Symbol<'_>) -> Option<String> {
    let ws = analysis.workspace();
    let sites = symbols::locals(symbol.owner);
    let site = sites.iter().rfind(|s| s.name.name == symbol.name && s.name.span.start <= symbol.span.start)?;
    // Without a checked type or a written one, the initializer says what it is.
    let ty = checked_local_type(analysis, site.name.span)
        .or_else(|| site.ty.map(|t| ws.snippet(t.span).to_string()))
        .unwrap_or_else(|| match site.value {
            Some(value) => format!("_ = {}", ws.snippet(value.span)),
            None => String::from("_"),
        });
    let (keyword, what) = match site.kind {
        LocalKind::Let => ("let", "Local constant"),
        LocalKind::Var => ("var", "Local variable"),
        LocalKind::Loop => ("for", "Loop variable"),
        LocalKind::Param => ("", "Parameter"),
    };
    let decl =
        if keyword.is_empty() { format!("{}: {ty}", symbol.name) } else { format!("{keyword} {}: {ty}", symbol.name) };
    let owner = match symbol.owner {
        Owner::Pipeline(p) => format!(" of `{}`", p.name.name),
        Owner::Lib(f) => format!(" of `{}`", f.name.name),
        Owner::Other => String::new(),
    };
    Some(format!("{}\n\n{what}{owner}.", code(&decl)))
}

/// The type the checker gave the local or parameter declared at `name_span` (of the workspace).
fn checked_local_type(analysis: &Analysis, name_span: Span) -> Option<String> {
    let ws = analysis.workspace();
    let local = name_span.start - ws.document_offset(0);
    let base = analysis.sources().file(analysis.file).base;
    let span = Span::new(base + local, base + local + (name_span.end - name_span.start));
    let program = &analysis.checked.program;
    let locals = program.pipelines.iter().flat_map(|p| &p.locals).chain(program.lib_fns.iter().flat_map(|f| &f.locals));
    if let Some(l) = locals.into_iter().find(|l| l.span == span) {
        return Some(l.ty.to_string());
    }
    program
        .lib_fns
        .iter()
        .flat_map(|f| &f.params)
        .find(|p| p.span == span || p.span.start == span.start)
        .map(|p| p.ty.to_string())
}

/// A pipeline function: its placement and doc.
pub fn pipeline(ws: &Workspace, p: &ast::PipelineFn) -> String {
    let head = format!("pipeline {} {}", p.name.name, ws.snippet(p.placement.span));
    let mut out = with_doc(code(&head), None);
    out.push_str(&format!("\n\n{}", placement_meaning(&p.placement.target, Some(p.placement.kind))));
    if p.name.is_template() {
        out.push_str("\n\nA template: a scene instantiates it once per instance name (`$` replaced).");
    }
    out
}

/// A type name.
pub fn type_name(name: &str) -> String {
    let meaning = match name {
        "volume" => {
            "A scalar 3D texture plus its sampler (a data set); only a uniform or a library function's parameter"
        }
        "tf" => {
            "A transfer function: a 1D RGBA lookup texture plus its sampler; only a uniform or a library function's parameter"
        }
        _ if vrsc::types::Type::from_name(name).is_some() => "A WGSL type; calling it constructs or converts a value",
        _ => "Not a type VRS knows",
    };
    format!("{}\n\n{meaning}.", code(name))
}

/// Where a placement puts a function, in words.
fn placement_meaning(path: &ast::StepPath, placement: Option<PlacementKind>) -> String {
    let step = path.step_name();
    let sub = path.substep.as_ref().map(|s| s.name.as_str());
    let target = match Step::lookup(&step) {
        StepLookup::Step(_) => format!("step `{step}`"),
        StepLookup::Group { first, last } => match placement {
            Some(PlacementKind::Before) => format!("step `{first}` (the first of group `{step}`)"),
            Some(PlacementKind::After) => format!("step `{last}` (the last of group `{step}`)"),
            _ => return format!("`{step}` is a group: `in`, `replace` and `remove` need one of its steps."),
        },
        StepLookup::Unknown => {
            let hint = Step::suggest(&step).map_or_else(String::new, |s| format!(" Did you mean `{s}`?"));
            return format!("`{step}` names no pipeline step.{hint}");
        }
    };
    match (placement, sub) {
        (Some(PlacementKind::In), _) => format!("Appended to {target}."),
        (Some(PlacementKind::Before), None) => format!("Inserted at the start of {target}."),
        (Some(PlacementKind::Before), Some(x)) => format!("Inserted just before substep `{x}` of {target}."),
        (Some(PlacementKind::After), None) => format!("Inserted at the end of {target}."),
        (Some(PlacementKind::After), Some(x)) => format!("Inserted just after substep `{x}` of {target}."),
        (Some(PlacementKind::Replace), None) => format!("Takes the place of every function of {target}."),
        (Some(PlacementKind::Replace), Some(x)) => format!("Takes the place of substep `{x}` of {target}."),
        (None, None) => format!("Drops every function of {target}."),
        (None, Some(x)) => format!("Drops substep `{x}` of {target}."),
    }
}

/// When a step runs, in words, and its place in its pipeline.
pub fn step_summary(step: Step) -> String {
    let kind = step.kind();
    let steps: Vec<Step> = Step::ALL.iter().copied().filter(|s| s.kind() == kind).collect();
    let index = steps.iter().position(|s| *s == step).map_or(0, |i| i + 1);
    let when = match step {
        Step::RaySetup => "once per ray, before the sample loop",
        Step::RayFinish => "once per ray, after the sample loop",
        _ if kind == PipelineKind::Filter => "once per pixel of the finished picture (a view's `filters`)",
        _ => "once per sample",
    };
    format!("step {index} of {} of {}, runs {when}", steps.len(), kind.describe())
}

/// A step path of a placement or `remove`: which step it names, what the placement does there
/// and which functions of the workspace fill that step.
pub fn step_path(ws: &Workspace, path: &ast::StepPath, placement: Option<PlacementKind>) -> String {
    let step_name = path.step_name();
    let mut out = format!("`{}`", ws.snippet(path.span));
    let resolved = workspace::resolve_step(&step_name, placement);
    if let Some(step) = resolved {
        out.push_str(&format!(": {}.", step_summary(step)));
    }
    out.push_str(&format!("\n\n{}", placement_meaning(path, placement)));
    let Some(step) = resolved else { return out };
    let placed = ws.placed_in(step);
    if let Some(sub) = &path.substep
        && let Some(f) = placed.iter().find(|f| f.item.name.name == sub.name)
    {
        out.push_str(&format!("\n\nSubstep `{}` ({}):", sub.name, ws.module_label(f.module)));
        if let Some(doc) = f.doc {
            out.push_str(&format!(" {doc}"));
        }
    }
    let listed: Vec<String> =
        placed.iter().map(|f| format!("`{}` ({})", f.item.name.name, ws.module_label(f.module))).collect();
    if !listed.is_empty() {
        out.push_str(&format!("\n\nFunctions placed in `{step}`: {}.", listed.join(", ")));
    }
    out
}

/// A standard module: its opening comment and what it defines.
pub fn std_module(ws: &Workspace, name: &str) -> Option<String> {
    let short = name.strip_prefix("std::")?;
    let module = ws.std_module(short)?;
    let file = ws.sources.file(ws.graph.modules[module].file);
    let intro: Vec<&str> = file
        .text
        .lines()
        .take_while(|l| l.starts_with("//") && !l.starts_with("///"))
        .map(|l| l.trim_start_matches('/').trim())
        .collect();
    let mut out = format!("{}\n\n{}", code(&format!("import {name};")), intro.join(" "));
    let libs: Vec<String> =
        ws.lib_fns(None, Some(&[module])).iter().map(|f| format!("`{}`", f.item.name.name)).collect();
    if !libs.is_empty() {
        out.push_str(&format!("\n\nLibrary functions: {}.", libs.join(", ")));
    }
    let pipelines: Vec<String> = ws
        .pipelines_in(module)
        .iter()
        .map(|p| format!("`{}` ({})", p.name.name, workspace::placement_step(&p.placement).map_or("?", |s| s.name())))
        .collect();
    if !pipelines.is_empty() {
        out.push_str(&format!("\n\nPipeline functions: {}.", pipelines.join(", ")));
    }
    Some(out)
}
