//! Instantiation: the modules given to the composer as units (pipeline functions and removes),
//! once per instance for a template, with `$` replaced by the instance name.

use super::ir::ModuleUse;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::hir;
use crate::lexer::is_identifier;
use crate::source::Span;

/// Where an instantiated item comes from.
#[derive(Clone, Copy, Debug)]
pub(super) enum Source {
    /// Index into [`hir::Program::pipelines`].
    Pipeline(usize),
    /// Index into [`hir::Program::removes`].
    Remove(usize),
}

/// One pipeline function or remove, instantiated.
#[derive(Clone, Debug)]
pub(super) struct Unit {
    pub(super) source: Source,
    pub(super) instance: Option<String>,
    /// The instantiated function name (empty for a remove).
    pub(super) name: String,
}

impl Unit {
    pub(super) fn subst(&self, name: &str) -> String {
        subst(name, self.instance.as_deref())
    }
}

/// `name` with every `$` replaced by the instance.
pub(crate) fn subst(name: &str, instance: Option<&str>) -> String {
    match instance {
        Some(i) => name.replace('$', i),
        None => name.to_string(),
    }
}

/// The first (by position) item of the module that makes it a template, with a description.
fn first_wildcard(program: &hir::Program, pipes: &[usize], removes: &[usize]) -> Option<(Span, String)> {
    let mut found: Vec<(Span, String)> = Vec::new();
    for &pi in pipes {
        let p = &program.pipelines[pi];
        if p.name.contains('$') {
            found.push((p.span, format!("pipeline `{}`", p.name)));
        }
        if let Some(x) = p.placement.substep.as_deref().filter(|x| x.contains('$')) {
            found.push((p.placement.span, format!("step path `{}[{x}]`", p.placement.step)));
        }
        for s in p.state.iter().filter(|s| s.name.contains('$')) {
            found.push((s.span, format!("state field `{}`", s.name)));
        }
        for u in p.uniforms.iter().filter(|u| u.name.contains('$')) {
            found.push((u.span, format!("uniform `{}`", u.name)));
        }
    }
    for &ri in removes {
        let r = &program.removes[ri];
        if let Some(x) = r.substep.as_deref().filter(|x| x.contains('$')) {
            found.push((r.span, format!("step path `{}[{x}]`", r.step)));
        }
    }
    found.into_iter().min_by_key(|(span, _)| (span.start, span.end))
}

/// Expands the modules into their items, once per instance for a template.
pub(super) fn instantiate(program: &hir::Program, uses: &[ModuleUse], diags: &mut Diagnostics) -> Vec<Unit> {
    let mut units = Vec::new();
    for u in uses {
        let pipes: Vec<usize> =
            (0..program.pipelines.len()).filter(|&i| program.pipelines[i].module == u.module).collect();
        let removes: Vec<usize> =
            (0..program.removes.len()).filter(|&i| program.removes[i].module == u.module).collect();
        // Source order within the file: pipelines and removes interleaved by position.
        let mut items: Vec<(Span, Source)> = pipes
            .iter()
            .map(|&i| (program.pipelines[i].span, Source::Pipeline(i)))
            .chain(removes.iter().map(|&i| (program.removes[i].span, Source::Remove(i))))
            .collect();
        items.sort_by_key(|(span, _)| span.start);
        let wildcard = first_wildcard(program, &pipes, &removes);
        let instances = instances(u, wildcard, diags);
        for instance in instances {
            for &(_, source) in &items {
                let name = match source {
                    Source::Pipeline(i) => subst(&program.pipelines[i].name, instance.as_deref()),
                    Source::Remove(_) => String::new(),
                };
                units.push(Unit { source, instance: instance.clone(), name });
            }
        }
    }
    units
}

/// The instances a module is placed for: its listed ones for a template (E0606 without any,
/// E0607 for a bad or repeated name), once without an instance for a plain module (W0701 when
/// it is given instances anyway).
fn instances(u: &ModuleUse, wildcard: Option<(Span, String)>, diags: &mut Diagnostics) -> Vec<Option<String>> {
    let listed = u.instances.as_deref().filter(|list| !list.is_empty());
    match (wildcard, listed) {
        (Some((span, what)), None) => {
            let mut d =
                Diagnostic::new(Code::UninstantiatedTemplate, span, "a template module is used without instances")
                    .with_label(format!("{what} contains the wildcard `$`, so this module is a template"));
            if !u.span.is_dummy() {
                d = d.with_secondary(u.span, "used here without instances");
            }
            diags.push(
                d.with_note("every `$` is replaced by an instance name, once per instance")
                    .with_help("list instances in the scene: `instances = [\"a\", \"b\"]`"),
            );
            Vec::new()
        }
        (Some(_), Some(list)) => {
            let mut valid: Vec<Option<String>> = Vec::new();
            for name in list {
                if !is_identifier(name) {
                    diags.push(
                        Diagnostic::new(
                            Code::InvalidInstance,
                            u.span,
                            format!("`{name}` is not a valid instance name"),
                        )
                        .with_label("instances of this module")
                        .with_note("instance names are identifiers: a letter or `_`, then letters, digits or `_`"),
                    );
                } else if valid.iter().any(|v| v.as_deref() == Some(name.as_str())) {
                    diags.push(
                        Diagnostic::new(Code::InvalidInstance, u.span, format!("instance `{name}` is listed twice"))
                            .with_label("instances of this module")
                            .with_help("list each instance once"),
                    );
                } else {
                    valid.push(Some(name.clone()));
                }
            }
            valid
        }
        (None, Some(list)) => {
            diags.push(
                Diagnostic::new(
                    Code::SceneIgnored,
                    u.span,
                    "`instances` has no effect on a module that is not a template",
                )
                .with_label(format!("{} instance(s) ignored", list.len()))
                .with_note("a template is a module whose names or step paths contain `$`; this one is placed once")
                .with_help("remove `instances`, or write `$` where the instance name belongs"),
            );
            vec![None]
        }
        (None, None) => vec![None],
    }
}

/// Adds "in instance `gm` of template `clip_$`" to a diagnostic about an instantiated unit.
pub(super) fn instance_note(program: &hir::Program, unit: &Unit, d: Diagnostic) -> Diagnostic {
    let Some(instance) = &unit.instance else { return d };
    let template = match unit.source {
        Source::Pipeline(i) => program.pipelines.get(i).map(|p| p.name.clone()),
        Source::Remove(i) => program.removes.get(i).map(|r| match &r.substep {
            Some(x) => format!("remove {}[{x}]", r.step),
            None => format!("remove {}", r.step),
        }),
    };
    match template {
        Some(t) => d.with_note(format!("in instance `{instance}` of template `{t}`")),
        None => d.with_note(format!("in instance `{instance}`")),
    }
}
