//! Placement: instantiates templates (section 7 of the language spec), places every pipeline
//! function and `remove` of the composed modules into the steps (section 6), merges the state and
//! uniform declarations of the placed functions, and checks the data flow of the linear pipeline.
//!
//! Choices where the specification is silent (also in `docs/reference.md`):
//! - Only the pipeline functions and removes of the modules given to [`compose`] are placed; an
//!   `import` brings library functions and constants, never placements.
//! - A template is instantiated instance by instance: every item of the module for the first
//!   instance (in source order), then every item for the second, and so on.
//! - A plain module given instances is placed once; the instances are ignored with a W0701
//!   warning at the scene's module entry. An empty instance list counts as no instances.
//! - `in S[x]` is `after S[x]`. A substep is a function's instantiated name; names are unique per
//!   step (E0203), not across steps.
//! - E0604 also applies to `replace S[x] when active`, and to `replace S[x]` after `replace S`
//!   took the whole step; a second `replace S` of a whole step simply wins.
//! - Conflicts between declarations whose names are equal as written were already reported by the
//!   checker (which drops the conflicting function), so here only declarations whose names became
//!   equal through instantiation are compared for conflicts.
//! - E0605 (no default) applies to every field a placed function declares, kept or left out.
//! - Read-before-write (W0005) follows lifetimes: an `@ray` field read in a sample step is
//!   written by any sample-step write (the previous sample's); a per-sample field is reset before
//!   every sample, so a `ray.setup` write does not reach a sample step. W0005 and W0006 are only
//!   reported for functions of non-standard modules (the standard library relies on defaults),
//!   and never for the fields the entry point requires.

use crate::ast::PlacementKind;
use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::hir::show_const;
use crate::hir::{self, ConstValue, ScalarValue};
use crate::source::{SourceMap, Span};
use crate::steps::Step;
use crate::suggest::did_you_mean;
use crate::types::{Scalar, Type};
use rustc_hash::FxHashMap;
use std::fmt::Write as _;

/// One module given to the composer. Modules are given in placement order: standard modules
/// first, then the scene's shared modules, then the view's.
#[derive(Clone, Debug)]
pub struct ModuleUse {
    /// Index in the loader's `ModuleGraph` (the `module` of its HIR functions).
    pub module: usize,
    /// The scene's instance names, for a template.
    pub instances: Option<Vec<String>>,
    /// Where the scene names the module, for errors about its instances; may be `Span::DUMMY`.
    pub span: Span,
}

/// The composed pipeline.
#[derive(Clone, Debug, Default)]
pub struct Composition {
    /// Every step, in [`Step::ALL`] order, possibly without functions.
    pub steps: Vec<StepFunctions>,
    /// The composed state: fields some placed function reads (or that the entry point requires),
    /// in the order of their first declaration along the pipeline.
    pub fields: Vec<Field>,
    /// Uniforms declared by placed functions, in the order of their first declaration along the
    /// pipeline.
    pub uniforms: Vec<Uniform>,
}

/// The functions of one step, in execution order.
#[derive(Clone, Debug)]
pub struct StepFunctions {
    pub step: Step,
    pub functions: Vec<PlacedFn>,
}

/// One placed (and, for a template, instantiated) pipeline function.
#[derive(Clone, Debug)]
pub struct PlacedFn {
    /// Index into [`hir::Program::pipelines`].
    pub pipeline: usize,
    /// The instantiated name, which is also its substep name.
    pub name: String,
    /// The instance, for a function of a template.
    pub instance: Option<String>,
    /// Per state declaration of the HIR function: its index in [`Composition::fields`], `None`
    /// when the field was left out (nothing reads it).
    pub state: Vec<Option<usize>>,
    /// Per uniform declaration of the HIR function: its index in [`Composition::uniforms`].
    pub uniforms: Vec<usize>,
}

/// A field of the composed state struct.
#[derive(Clone, Debug)]
pub struct Field {
    pub name: String,
    pub ty: Type,
    /// `@ray`: lives for the whole ray.
    pub ray: bool,
    /// The agreed default (the type's zero value when none was given, which is an E0605 error).
    pub default: ConstValue,
    /// Whether some placed function reads / writes it.
    pub read: bool,
    pub written: bool,
    /// The first declaration along the pipeline.
    pub span: Span,
}

/// A uniform of the composed pipeline.
#[derive(Clone, Debug)]
pub struct Uniform {
    pub name: String,
    pub ty: Type,
    /// The first default given.
    pub default: Option<ConstValue>,
    /// The first range given.
    pub range: Option<(ConstValue, ConstValue)>,
    /// The first doc comment given.
    pub doc: Option<String>,
    /// The first declaration along the pipeline.
    pub span: Span,
}

/// One line of the pipeline map: a placed function and where it came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MapEntry {
    pub step: Step,
    pub name: String,
    pub instance: Option<String>,
    /// The file's display name (`std::raycast`, `clip.vrs`).
    pub file: String,
    /// 1-based line and column of the function.
    pub line: usize,
    pub column: usize,
    pub span: Span,
}

impl Composition {
    /// Every placed function with its origin, step by step in execution order.
    pub fn pipeline_map(&self, program: &hir::Program, sources: &SourceMap) -> Vec<MapEntry> {
        let mut out = Vec::new();
        for step in &self.steps {
            for f in &step.functions {
                let span = program.pipelines.get(f.pipeline).map_or(Span::DUMMY, |p| p.span);
                let (file, line, column) = match sources.position(span.start) {
                    Some((id, p)) => (sources.file(id).name.clone(), p.line, p.column),
                    None => (String::from("?"), 0, 0),
                };
                out.push(MapEntry {
                    step: step.step,
                    name: f.name.clone(),
                    instance: f.instance.clone(),
                    file,
                    line,
                    column,
                    span,
                });
            }
        }
        out
    }

    /// The pipeline map as text, for `vrsc pipeline`: every step in order, each placed function
    /// indented under it with `file:line` and its instance.
    ///
    /// ```text
    /// ray.setup
    ///   setup    std::raycast:3
    /// start (empty)
    /// classification.additional
    ///   clip_gm  clip.vrs:6  (instance gm)
    /// ```
    pub fn render_pipeline_map(&self, program: &hir::Program, sources: &SourceMap) -> String {
        let entries = self.pipeline_map(program, sources);
        let width = entries.iter().map(|e| e.name.chars().count()).max().unwrap_or(0);
        let origins: Vec<String> = entries.iter().map(|e| format!("{}:{}", e.file, e.line)).collect();
        let origin_width = origins.iter().map(|o| o.chars().count()).max().unwrap_or(0);
        let mut out = String::new();
        for step in &self.steps {
            if step.functions.is_empty() {
                let _ = writeln!(out, "{} (empty)", step.step);
                continue;
            }
            let _ = writeln!(out, "{}", step.step);
            for (e, origin) in entries.iter().zip(&origins).filter(|(e, _)| e.step == step.step) {
                let line = match &e.instance {
                    Some(i) => format!("  {:<width$}  {origin:<origin_width$}  (instance {i})", e.name),
                    None => format!("  {:<width$}  {origin}", e.name),
                };
                let _ = writeln!(out, "{}", line.trim_end());
            }
        }
        out
    }

    /// The functions of one step.
    pub fn step(&self, step: Step) -> &[PlacedFn] {
        self.steps.iter().find(|s| s.step == step).map_or(&[], |s| &s.functions)
    }

    /// The index of a field by name.
    pub fn field(&self, name: &str) -> Option<usize> {
        self.fields.iter().position(|f| f.name == name)
    }
}

/// Places every pipeline function and `remove` of the given modules, in order, and checks the
/// composed state and uniforms. `is_std(module)` tells standard modules apart (they get no
/// data-flow warnings). Fields named in `required` belong to the entry point, which reads (and
/// may set) them: they are kept whenever a placed function declares them, even if no function
/// reads them, and get no data-flow warnings.
///
/// Errors go to `diags`; the composition is returned whatever happened (check
/// `diags.has_errors()` before emitting).
pub fn compose(
    program: &hir::Program,
    uses: &[ModuleUse],
    is_std: impl Fn(usize) -> bool,
    required: &[&str],
    diags: &mut Diagnostics,
) -> Composition {
    let units = instantiate(program, uses, diags);
    let mut placer = Placer {
        program,
        units: &units,
        steps: vec![Vec::new(); Step::ALL.len()],
        replaced: FxHashMap::default(),
        diags,
    };
    for (u, unit) in units.iter().enumerate() {
        match unit.source {
            Source::Pipeline(_) => placer.place(u),
            Source::Remove(_) => placer.remove(u),
        }
    }
    let placed = placer.steps;
    Merger { program, units: &units, is_std: &is_std, required, diags }.merge(&placed)
}

/// Where an instantiated item comes from.
#[derive(Clone, Copy, Debug)]
enum Source {
    /// Index into [`hir::Program::pipelines`].
    Pipeline(usize),
    /// Index into [`hir::Program::removes`].
    Remove(usize),
}

/// One pipeline function or remove, instantiated.
#[derive(Clone, Debug)]
struct Unit {
    source: Source,
    instance: Option<String>,
    /// The instantiated function name (empty for a remove).
    name: String,
}

impl Unit {
    fn subst(&self, name: &str) -> String {
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

/// `[A-Za-z_][A-Za-z0-9_]*`.
fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
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
fn instantiate(program: &hir::Program, uses: &[ModuleUse], diags: &mut Diagnostics) -> Vec<Unit> {
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
        let listed = u.instances.as_deref().filter(|list| !list.is_empty());
        let instances: Vec<Option<String>> = match (wildcard, listed) {
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
                            Diagnostic::new(
                                Code::InvalidInstance,
                                u.span,
                                format!("instance `{name}` is listed twice"),
                            )
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
        };
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

/// Who took the place of a substep through `replace`.
#[derive(Clone, Copy, Debug)]
struct Replaced {
    /// The `replace` placement.
    span: Span,
    /// The unit that replaced it.
    by: usize,
    /// `replace S` of the whole step, rather than `replace S[x]`.
    whole_step: bool,
}

struct Placer<'a> {
    program: &'a hir::Program,
    units: &'a [Unit],
    /// Per step (in `Step::ALL` order), the units placed there, in order.
    steps: Vec<Vec<usize>>,
    /// (step, substep name) → the replacement that took its place.
    replaced: FxHashMap<(Step, String), Replaced>,
    diags: &'a mut Diagnostics,
}

fn step_index(step: Step) -> usize {
    Step::ALL.iter().position(|s| *s == step).unwrap_or(0)
}

impl<'a> Placer<'a> {
    fn find(&self, s: usize, name: &str) -> Option<usize> {
        self.steps[s].iter().position(|&u| self.units[u].name == name)
    }

    fn pipeline(&self, u: usize) -> Option<&'a hir::PipelineFn> {
        match self.units[u].source {
            Source::Pipeline(i) => self.program.pipelines.get(i),
            Source::Remove(_) => None,
        }
    }

    /// Adds "in instance `gm` of template `clip_$`" for an instantiated unit.
    fn instance_note(&self, d: Diagnostic, u: usize) -> Diagnostic {
        instance_note(self.program, &self.units[u], d)
    }

    fn place(&mut self, u: usize) {
        let Some(p) = self.pipeline(u) else { return };
        let pl = &p.placement;
        let step = pl.step;
        let s = step_index(step);
        let sub = pl.substep.as_deref().map(|x| self.units[u].subst(x));
        let pos = match &sub {
            Some(x) => {
                let pos = self.find(s, x);
                // Taken already: gone, or still held by the earlier replacement (named x).
                if pl.kind == PlacementKind::Replace
                    && let Some(r) = self.replaced.get(&(step, x.clone())).copied()
                    && pos.is_none_or(|i| self.steps[s][i] == r.by)
                {
                    self.double_replace(u, step, x, pl.span, r);
                    return;
                }
                match pos {
                    Some(i) => Some(i),
                    None => {
                        if !pl.when_active {
                            self.unknown_substep(u, step, x, pl.span, false);
                        }
                        return;
                    }
                }
            }
            None => {
                if pl.when_active && self.steps[s].is_empty() {
                    return;
                }
                None
            }
        };
        let whole_replace = pl.kind == PlacementKind::Replace && sub.is_none();
        let replaced_pos = if pl.kind == PlacementKind::Replace { pos } else { None };
        if !whole_replace && let Some(j) = self.find(s, &self.units[u].name).filter(|&j| Some(j) != replaced_pos) {
            self.duplicate(u, step, self.steps[s][j]);
            return;
        }
        let span = pl.span;
        let kind = pl.kind;
        let list = &mut self.steps[s];
        match (kind, pos) {
            (PlacementKind::In | PlacementKind::After, None) => list.push(u),
            (PlacementKind::Before, None) => list.insert(0, u),
            (PlacementKind::Replace, None) => {
                for old in std::mem::take(list) {
                    let name = self.units[old].name.clone();
                    self.replaced.insert((step, name), Replaced { span, by: u, whole_step: true });
                }
                self.steps[s].push(u);
            }
            (PlacementKind::Before, Some(i)) => list.insert(i, u),
            (PlacementKind::In | PlacementKind::After, Some(i)) => list.insert(i + 1, u),
            (PlacementKind::Replace, Some(i)) => {
                let old = std::mem::replace(&mut list[i], u);
                let name = self.units[old].name.clone();
                self.replaced.insert((step, name), Replaced { span, by: u, whole_step: false });
            }
        }
    }

    fn remove(&mut self, u: usize) {
        let Source::Remove(ri) = self.units[u].source else { return };
        let Some(r) = self.program.removes.get(ri) else { return };
        let s = step_index(r.step);
        match r.substep.as_deref().map(|x| self.units[u].subst(x)) {
            None => self.steps[s].clear(),
            Some(x) => match self.find(s, &x) {
                Some(i) => {
                    self.steps[s].remove(i);
                }
                None if r.when_active => {}
                None => self.unknown_substep(u, r.step, &x, r.span, true),
            },
        }
    }

    fn unknown_substep(&mut self, u: usize, step: Step, x: &str, span: Span, is_remove: bool) {
        let s = step_index(step);
        let names: Vec<&str> = self.steps[s].iter().map(|&v| self.units[v].name.as_str()).collect();
        let mut d = Diagnostic::new(Code::UnknownSubstep, span, format!("step `{step}` has no substep `{x}`"))
            .with_label(format!("no function named `{x}` in `{step}` at this point"));
        if let Some(r) = self.replaced.get(&(step, x.to_string())) {
            let label = if r.whole_step {
                format!("`replace {step}` took the place of `{x}` here")
            } else {
                format!("`{x}` was replaced by `{}` here", self.units[r.by].name)
            };
            d = d.with_secondary(r.span, label);
        }
        if let Some(best) = did_you_mean(x, names.iter().copied()) {
            d = d.with_help(format!("did you mean `{step}[{best}]`?"));
        }
        d = if names.is_empty() {
            d.with_note(format!("`{step}` holds no functions at this point"))
        } else {
            let list: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
            d.with_note(format!("substeps of `{step}` at this point: {}", list.join(", ")))
        };
        d = d.with_note(
            "placements apply in module order: standard modules first, then the scene's, each in source order",
        );
        let what = if is_remove { "remove it" } else { "place it" };
        d = d.with_help(format!("add `when active` to {what} only when the substep exists"));
        let d = self.instance_note(d, u);
        self.diags.push(d);
    }

    fn double_replace(&mut self, u: usize, step: Step, x: &str, span: Span, r: Replaced) {
        let earlier = if r.whole_step {
            format!("`replace {step}` already took the place of every function of the step, `{x}` included")
        } else {
            format!("first replaced here by `{}`", self.units[r.by].name)
        };
        let d = Diagnostic::new(Code::DoubleReplace, span, format!("substep `{x}` of `{step}` is replaced twice"))
            .with_label(format!("second replacement of `{x}`"))
            .with_secondary(r.span, earlier)
            .with_note("two replacements would silently fight over one place")
            .with_help(format!(
                "remove one of them, or place this function `before` or `after` `{step}[{}]`",
                self.units[r.by].name
            ));
        let d = self.instance_note(d, u);
        self.diags.push(d);
    }

    fn duplicate(&mut self, u: usize, step: Step, earlier: usize) {
        let name = self.units[u].name.clone();
        let span = self.pipeline(u).map_or(Span::DUMMY, |p| p.span);
        let mut d = Diagnostic::new(Code::Duplicate, span, format!("`{name}` is placed twice in `{step}`"))
            .with_label(format!("a second `{name}` in `{step}`"));
        if let Some(p) = self.pipeline(earlier) {
            d = d.with_secondary(p.span, "placed first here");
        }
        d = d
            .with_note("a function's name is its substep name, so the functions of one step need distinct names")
            .with_help("rename one of them, or `replace` the first");
        let d = self.instance_note(d, u);
        self.diags.push(d);
    }
}

/// Adds "in instance `gm` of template `clip_$`" to a diagnostic about an instantiated unit.
fn instance_note(program: &hir::Program, unit: &Unit, d: Diagnostic) -> Diagnostic {
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

/// A declaration: (unit, index of the declaration in its function).
type DeclRef = (usize, usize);

/// A field being merged.
struct FieldAcc {
    name: String,
    first: DeclRef,
    first_default: Option<DeclRef>,
    /// (position along the pipeline, phase, unit, decl index, read, written).
    uses: Vec<Use>,
}

#[derive(Clone, Copy)]
struct Use {
    position: usize,
    phase: u8,
    unit: usize,
    decl: usize,
    read: bool,
    written: bool,
}

struct UniformAcc {
    first: DeclRef,
    first_default: Option<DeclRef>,
    range: Option<DeclRef>,
    doc: Option<DeclRef>,
}

/// 0 before the sample loop, 1 in it, 2 after it.
fn phase(step: Step) -> u8 {
    match step {
        Step::RaySetup => 0,
        Step::RayFinish => 2,
        _ => 1,
    }
}

struct Merger<'a, F: Fn(usize) -> bool> {
    program: &'a hir::Program,
    units: &'a [Unit],
    is_std: &'a F,
    required: &'a [&'a str],
    diags: &'a mut Diagnostics,
}

impl<'a, F: Fn(usize) -> bool> Merger<'a, F> {
    fn pipe(&self, u: usize) -> &'a hir::PipelineFn {
        match self.units[u].source {
            Source::Pipeline(i) => &self.program.pipelines[i],
            Source::Remove(_) => unreachable!("only pipeline functions are placed"),
        }
    }

    fn state(&self, (u, j): DeclRef) -> &'a hir::StateDecl {
        &self.pipe(u).state[j]
    }

    fn uniform(&self, (u, j): DeclRef) -> &'a hir::UniformDecl {
        &self.pipe(u).uniforms[j]
    }

    /// A uniform's doc comment, with `$` replaced by the instance as in the uniform's name.
    fn uniform_doc(&self, r: DeclRef) -> Option<String> {
        let doc = self.uniform(r).doc.as_ref()?;
        Some(match &self.units[r.0].instance {
            Some(instance) => doc.replace('$', instance),
            None => doc.clone(),
        })
    }

    fn unit_is_std(&self, u: usize) -> bool {
        (self.is_std)(self.pipe(u).module)
    }

    /// "in `name`" or "in `name` (instance `gm`)" for messages about an earlier declaration.
    fn owner(&self, u: usize) -> String {
        match &self.units[u].instance {
            Some(i) => format!("`{}` (instance `{i}`)", self.units[u].name),
            None => format!("`{}`", self.units[u].name),
        }
    }

    fn push(&mut self, u: usize, d: Diagnostic) {
        let d = instance_note(self.program, &self.units[u], d);
        self.diags.push(d);
    }

    fn merge(mut self, placed: &[Vec<usize>]) -> Composition {
        // The placed units along the pipeline.
        let order: Vec<(Step, usize)> =
            Step::ALL.iter().zip(placed).flat_map(|(step, units)| units.iter().map(move |&u| (*step, u))).collect();

        let mut fields: Vec<FieldAcc> = Vec::new();
        let mut field_index: FxHashMap<String, usize> = FxHashMap::default();
        let mut uniforms: Vec<(String, UniformAcc)> = Vec::new();
        let mut uniform_index: FxHashMap<String, usize> = FxHashMap::default();
        // Per unit: field / uniform index of each declaration.
        let mut unit_fields: FxHashMap<usize, Vec<usize>> = FxHashMap::default();
        let mut unit_uniforms: FxHashMap<usize, Vec<usize>> = FxHashMap::default();

        for (position, &(step, u)) in order.iter().enumerate() {
            let decls = self.pipe(u).state.len();
            let mut indices = Vec::with_capacity(decls);
            for j in 0..decls {
                let decl = self.state((u, j));
                let name = self.units[u].subst(&decl.name);
                let use_ =
                    Use { position, phase: phase(step), unit: u, decl: j, read: decl.read, written: decl.written };
                let fi = match field_index.get(&name) {
                    Some(&fi) => {
                        self.check_state(&mut fields[fi], (u, j));
                        fi
                    }
                    None => {
                        field_index.insert(name.clone(), fields.len());
                        let first_default = decl.default.is_some().then_some((u, j));
                        fields.push(FieldAcc { name, first: (u, j), first_default, uses: Vec::new() });
                        fields.len() - 1
                    }
                };
                fields[fi].uses.push(use_);
                indices.push(fi);
            }
            unit_fields.insert(u, indices);

            let decls = self.pipe(u).uniforms.len();
            let mut indices = Vec::with_capacity(decls);
            for j in 0..decls {
                let decl = self.uniform((u, j));
                let name = self.units[u].subst(&decl.name);
                let ui = match uniform_index.get(&name) {
                    Some(&ui) => {
                        self.check_uniform(&name, &mut uniforms[ui].1, (u, j));
                        ui
                    }
                    None => {
                        uniform_index.insert(name.clone(), uniforms.len());
                        let has = |b: bool| b.then_some((u, j));
                        let acc = UniformAcc {
                            first: (u, j),
                            first_default: has(decl.default.is_some()),
                            range: has(decl.range.is_some()),
                            doc: has(decl.doc.is_some()),
                        };
                        uniforms.push((name, acc));
                        uniforms.len() - 1
                    }
                };
                indices.push(ui);
            }
            unit_uniforms.insert(u, indices);
        }

        // Defaults, data flow, and which fields are kept.
        let mut kept: Vec<Option<usize>> = vec![None; fields.len()];
        let mut out_fields = Vec::new();
        for (fi, acc) in fields.iter().enumerate() {
            let first = self.state(acc.first);
            if acc.first_default.is_none() {
                let d = Diagnostic::new(
                    Code::NoDefault,
                    first.span,
                    format!("no declaration of state field `{}` gives a default", acc.name),
                )
                .with_label("declared here without a default")
                .with_note("a field is reset to its default before every sample (an `@ray` field before every ray)")
                .with_help(format!("give a default: `state {}: {} = ...;`", acc.name, first.ty));
                self.push(acc.first.0, d);
            }
            let read = acc.uses.iter().any(|x| x.read);
            let written = acc.uses.iter().any(|x| x.written);
            let required = self.required.contains(&acc.name.as_str());
            if !required {
                self.read_before_write(acc, first.ray);
                if read {
                    self.dead_writes(acc, first.ray);
                }
            }
            if written
                && !read
                && !required
                && let Some(w) = acc.uses.iter().find(|x| x.written && !self.unit_is_std(x.unit))
            {
                let d = Diagnostic::new(
                    Code::WrittenNeverRead,
                    self.state((w.unit, w.decl)).span,
                    format!("state field `{}` is written but no function of the pipeline reads it", acc.name),
                )
                .with_label("written here, never read")
                .with_note("the field is left out of the composed state, so the write has no effect")
                .with_help("read it in a later step, or remove the write");
                self.push(w.unit, d);
            }
            if read || required {
                kept[fi] = Some(out_fields.len());
                let default = match acc.first_default {
                    Some(r) => self.state(r).default.clone().unwrap_or_else(|| zero_value(first.ty)),
                    None => zero_value(first.ty),
                };
                out_fields.push(Field {
                    name: acc.name.clone(),
                    ty: first.ty,
                    ray: first.ray,
                    default,
                    read,
                    written,
                    span: first.span,
                });
            }
        }

        let out_uniforms: Vec<Uniform> = uniforms
            .iter()
            .map(|(name, acc)| {
                let first = self.uniform(acc.first);
                Uniform {
                    name: name.clone(),
                    ty: first.ty,
                    default: acc.first_default.and_then(|r| self.uniform(r).default.clone()),
                    range: acc.range.and_then(|r| self.uniform(r).range.clone()),
                    doc: acc.doc.and_then(|r| self.uniform_doc(r)),
                    span: first.span,
                }
            })
            .collect();

        let steps = Step::ALL
            .iter()
            .zip(placed)
            .map(|(&step, units)| StepFunctions {
                step,
                functions: units
                    .iter()
                    .map(|&u| {
                        let Source::Pipeline(pipeline) = self.units[u].source else {
                            unreachable!("only pipeline functions are placed")
                        };
                        PlacedFn {
                            pipeline,
                            name: self.units[u].name.clone(),
                            instance: self.units[u].instance.clone(),
                            state: unit_fields[&u].iter().map(|&fi| kept[fi]).collect(),
                            uniforms: unit_uniforms[&u].clone(),
                        }
                    })
                    .collect(),
            })
            .collect();

        Composition { steps, fields: out_fields, uniforms: out_uniforms }
    }

    /// Type, lifetime and default of a later declaration against the first ones. Declarations
    /// whose names are equal as written were compared by the checker already.
    fn check_state(&mut self, acc: &mut FieldAcc, later: DeclRef) {
        let decl = self.state(later);
        let first = self.state(acc.first);
        let name = &acc.name;
        if first.name != decl.name {
            let owner = self.owner(acc.first.0);
            if first.ty != decl.ty {
                let d = Diagnostic::new(
                    Code::StateConflict,
                    decl.span,
                    format!("state field `{name}` is declared as {} here but as {} in {owner}", decl.ty, first.ty),
                )
                .with_label(format!("declared as {}", decl.ty))
                .with_secondary(first.span, format!("first declared here as {}", first.ty))
                .with_help(format!("every declaration of `state {name}` must have the same type"));
                self.push(later.0, d);
                return;
            }
            if first.ray != decl.ray {
                let lifetime = |ray: bool| if ray { "`@ray`" } else { "per-sample" };
                let d = Diagnostic::new(
                    Code::StateConflict,
                    decl.span,
                    format!(
                        "state field `{name}` is {} here but {} in {owner}",
                        lifetime(decl.ray),
                        lifetime(first.ray)
                    ),
                )
                .with_label(format!("{} here", lifetime(decl.ray)))
                .with_secondary(first.span, format!("first declared here as {}", lifetime(first.ray)))
                .with_help(if first.ray {
                    "add `@ray` to this declaration"
                } else {
                    "remove `@ray` from this declaration"
                });
                self.push(later.0, d);
                return;
            }
        }
        let Some(value) = &decl.default else { return };
        let Some(earlier_ref) = acc.first_default else {
            acc.first_default = Some(later);
            return;
        };
        let earlier = self.state(earlier_ref);
        if let Some(d) = default_conflict("state field", name, earlier, earlier.default.as_ref(), decl, value, || {
            self.owner(earlier_ref.0)
        }) {
            self.push(later.0, d);
        }
    }

    fn check_uniform(&mut self, name: &str, acc: &mut UniformAcc, later: DeclRef) {
        let decl = self.uniform(later);
        let first = self.uniform(acc.first);
        if first.name != decl.name && first.ty != decl.ty {
            let owner = self.owner(acc.first.0);
            let d = Diagnostic::new(
                Code::UniformConflict,
                decl.span,
                format!("uniform `{name}` is declared as {} here but as {} in {owner}", decl.ty, first.ty),
            )
            .with_label(format!("declared as {}", decl.ty))
            .with_secondary(first.span, format!("first declared here as {}", first.ty))
            .with_help(format!("every declaration of `uniform {name}` must have the same type"));
            self.push(later.0, d);
            return;
        }
        if acc.range.is_none() && decl.range.is_some() {
            acc.range = Some(later);
        }
        if acc.doc.is_none() && decl.doc.is_some() {
            acc.doc = Some(later);
        }
        let Some(value) = &decl.default else { return };
        let Some(earlier_ref) = acc.first_default else {
            acc.first_default = Some(later);
            return;
        };
        let earlier = self.uniform(earlier_ref);
        let conflict = default_conflict("uniform", name, earlier, earlier.default.as_ref(), decl, value, || {
            self.owner(earlier_ref.0)
        });
        if let Some(d) = conflict {
            self.push(later.0, d);
        }
    }

    /// W0006 for a write by a non-standard function that no read reaches (the field is read, but
    /// only before the write, or in a sample the write does not live into): the function's work
    /// is lost, typically because it is placed after the last step that uses the field.
    fn dead_writes(&mut self, acc: &FieldAcc, ray: bool) {
        let lost: Vec<&Use> = acc
            .uses
            .iter()
            .filter(|w| w.written && !self.unit_is_std(w.unit))
            .filter(|w| !acc.uses.iter().any(|r| r.read && later_read(w, r, ray)))
            .collect();
        for w in lost {
            let function = self.pipe(w.unit).name.clone();
            let d = Diagnostic::new(
                Code::WrittenNeverRead,
                self.state((w.unit, w.decl)).span,
                format!("`{function}` writes state field `{}`, but no later function reads it", acc.name),
            )
            .with_label("this write has no effect")
            .with_note("the functions that read the field run before this one in the composed pipeline")
            .with_help("place the function before the step that uses the field (see `vrsc pipeline`)");
            self.push(w.unit, d);
        }
    }

    /// W0005 for every read of the field by a non-standard function that no earlier write
    /// reaches.
    fn read_before_write(&mut self, acc: &FieldAcc, ray: bool) {
        let reaches = |w: &Use, r: &Use| reaches(w, r, ray);
        for r in acc.uses.iter().filter(|r| r.read) {
            if self.unit_is_std(r.unit) || acc.uses.iter().any(|w| reaches(w, r)) {
                continue;
            }
            let decl = self.state((r.unit, r.decl));
            let mut d = Diagnostic::new(
                Code::ReadBeforeWrite,
                decl.first_read.unwrap_or(decl.span),
                format!("state field `{}` is read before any function of the pipeline writes it", acc.name),
            )
            .with_label("read here; it still holds its default");
            if decl.first_read.is_some() {
                d = d.with_secondary(decl.span, "declared here");
            }
            if !ray && acc.uses.iter().any(|w| w.written && w.phase == 0 && r.phase == 1) {
                d = d.with_note("a per-sample field is reset to its default before every sample: a write in `ray.setup` does not reach the sample steps");
            }
            d = d.with_help(format!(
                "write `state.{}` in an earlier step, or place this function after the one that writes it",
                acc.name
            ));
            self.push(r.unit, d);
        }
    }
}

/// Whether read `r` comes after write `w` and sees it: a function's own read counts only for a
/// ray field in the sample loop (the next sample sees the write).
fn later_read(w: &Use, r: &Use, ray: bool) -> bool {
    if r.unit == w.unit {
        return ray && w.phase == 1;
    }
    reaches(w, r, ray)
}

/// Whether write `w` reaches read `r` of a field (`ray`: a field that lives for the whole ray).
fn reaches(w: &Use, r: &Use, ray: bool) -> bool {
    if !w.written {
        return false;
    }
    if w.position <= r.position {
        // A per-sample field is reset before every sample: a write before the loop is lost.
        ray || !(w.phase == 0 && r.phase == 1)
    } else {
        // A ray field written later in the loop reaches the next sample's read.
        ray && w.phase == 1 && r.phase == 1
    }
}

/// E0505 when a later declaration's default differs from the first default given, unless both
/// names are equal as written (the checker compared those).
fn default_conflict<D: HasName>(
    what: &str,
    name: &str,
    earlier: &D,
    earlier_value: Option<&ConstValue>,
    later: &D,
    value: &ConstValue,
    owner: impl FnOnce() -> String,
) -> Option<Diagnostic> {
    let earlier_value = earlier_value?;
    if earlier.name() == later.name() || earlier_value == value || earlier_value.ty != value.ty {
        return None;
    }
    Some(
        Diagnostic::new(
            Code::DefaultConflict,
            later.span(),
            format!(
                "{what} `{name}` has default {} here but {} in {}",
                show_const(value),
                show_const(earlier_value),
                owner()
            ),
        )
        .with_label(format!("default {}", show_const(value)))
        .with_secondary(earlier.span(), format!("first declared here with default {}", show_const(earlier_value)))
        .with_help("give every declaration the same default, or leave the default out here"),
    )
}

trait HasName {
    fn name(&self) -> &str;
    fn span(&self) -> Span;
}

impl HasName for hir::StateDecl {
    fn name(&self) -> &str {
        &self.name
    }
    fn span(&self) -> Span {
        self.span
    }
}

impl HasName for hir::UniformDecl {
    fn name(&self) -> &str {
        &self.name
    }
    fn span(&self) -> Span {
        self.span
    }
}

/// The zero value of a plain type (no components for anything else).
pub fn zero_value(ty: Type) -> ConstValue {
    let zero = |s: Scalar| match s {
        Scalar::Bool => ScalarValue::Bool(false),
        Scalar::I32 => ScalarValue::I32(0),
        Scalar::U32 => ScalarValue::U32(0),
        Scalar::F32 => ScalarValue::F32(0.0),
    };
    let components = match ty {
        Type::Scalar(s) => vec![zero(s)],
        Type::Vector { size, scalar } => vec![zero(scalar); usize::from(size)],
        Type::Matrix { cols, rows } => vec![ScalarValue::F32(0.0); usize::from(cols) * usize::from(rows)],
        _ => Vec::new(),
    };
    ConstValue { ty, components }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::check_program;
    use crate::loader::Loader;

    /// Checked modules: files named `std_*` count as standard modules.
    struct Fx {
        sources: SourceMap,
        program: hir::Program,
        ids: Vec<usize>,
        std: Vec<usize>,
    }

    fn fx(files: &[(&str, &str)]) -> Fx {
        let mut sources = SourceMap::new();
        let mut diags = Diagnostics::new();
        let mut loader = Loader::new(&mut sources, &mut diags);
        let ids: Vec<usize> = files.iter().map(|(n, t)| loader.load_root_source(n, t.to_string(), None)).collect();
        let graph = loader.finish();
        let program = check_program(&graph, &sources, &mut diags);
        let errors: Vec<String> =
            diags.iter().filter(|d| d.is_error()).map(|d| format!("{} {}", d.code.as_str(), d.message)).collect();
        assert!(errors.is_empty(), "check errors: {errors:?}");
        let std = files.iter().zip(&ids).filter(|((n, _), _)| n.starts_with("std_")).map(|(_, &id)| id).collect();
        Fx { sources, program, ids, std }
    }

    impl Fx {
        fn plain(&self, i: usize) -> ModuleUse {
            ModuleUse { module: self.ids[i], instances: None, span: Span::DUMMY }
        }

        fn inst(&self, i: usize, names: &[&str]) -> ModuleUse {
            let instances = Some(names.iter().map(|n| n.to_string()).collect());
            ModuleUse { module: self.ids[i], instances, span: Span::DUMMY }
        }

        /// Every module, plain, in order.
        fn all(&self) -> Vec<ModuleUse> {
            (0..self.ids.len()).map(|i| self.plain(i)).collect()
        }

        fn compose_with(&self, uses: &[ModuleUse], required: &[&str]) -> (Composition, Diagnostics) {
            let mut diags = Diagnostics::new();
            let c = compose(&self.program, uses, |m| self.std.contains(&m), required, &mut diags);
            (c, diags)
        }

        fn compose(&self, uses: &[ModuleUse]) -> (Composition, Diagnostics) {
            self.compose_with(uses, &[])
        }

        /// 1-based line of a span.
        fn line(&self, span: Span) -> usize {
            self.sources.position(span.start).map_or(0, |(_, p)| p.line)
        }
    }

    fn names(c: &Composition, step: Step) -> Vec<&str> {
        c.step(step).iter().map(|f| f.name.as_str()).collect()
    }

    fn codes(d: &Diagnostics) -> Vec<&'static str> {
        d.iter().map(|d| d.code.as_str()).collect()
    }

    fn only(d: &Diagnostics, code: Code) -> &Diagnostic {
        let found: Vec<&Diagnostic> = d.iter().filter(|x| x.code == code).collect();
        assert_eq!(found.len(), 1, "expected one {code:?}, got {:?}", codes(d));
        found[0]
    }

    /// A pipeline function whose body only counts (it reads and writes its own `@ray` field), so
    /// placement tests see no data-flow warnings.
    fn pf(name: &str, placement: &str) -> String {
        format!("pipeline {name} {placement} {{ @ray state n: f32 = 0.0; state.n = state.n + 1.0; }}\n")
    }

    fn module(items: &[(&str, &str)]) -> String {
        items.iter().map(|(n, p)| pf(n, p)).collect()
    }

    /// A standard-like module filling a few steps.
    fn std_base() -> String {
        module(&[("key", "in shading.lights"), ("fill", "in shading.lights"), ("tone", "in shading.tone")])
    }

    #[test]
    fn in_appends_in_module_order() {
        let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &pf("extra", "in shading.lights"))]);
        let (c, d) = f.compose(&f.all());
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::ShadingLights), ["key", "fill", "extra"]);
        assert_eq!(names(&c, Step::ShadingTone), ["tone"]);
        assert_eq!(c.steps.len(), Step::ALL.len());
        assert!(c.steps.iter().map(|s| s.step).eq(Step::ALL.iter().copied()));
        // The placed function points back at its HIR function.
        let extra = &c.step(Step::ShadingLights)[2];
        assert_eq!(f.program.pipelines[extra.pipeline].name, "extra");
        assert_eq!(extra.instance, None);
        assert_eq!(extra.state, [c.field("n")]);
    }

    #[test]
    fn before_and_after_a_step_and_a_group() {
        let user = module(&[
            ("first", "before shading.lights"),
            ("last", "after shading.lights"),
            ("early", "before compositing"),
            ("late", "after compositing"),
        ]);
        let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &user)]);
        let (c, d) = f.compose(&f.all());
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::ShadingLights), ["first", "key", "fill", "last"]);
        assert_eq!(names(&c, Step::CompositingPrimaryColor), ["early"]);
        assert_eq!(names(&c, Step::CompositingAdditional), ["late"]);
    }

    #[test]
    fn before_and_after_a_substep() {
        let user = module(&[
            ("before_fill", "before shading.lights[fill]"),
            ("after_key", "after shading.lights[key]"),
            ("before_key", "before shading.lights[key]"),
            ("after_fill", "after shading.lights[fill]"),
        ]);
        let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &user)]);
        let (c, d) = f.compose(&f.all());
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(
            names(&c, Step::ShadingLights),
            ["before_key", "key", "after_key", "before_fill", "fill", "after_fill"]
        );
    }

    #[test]
    fn replace_a_step_and_a_substep() {
        let user = module(&[
            ("soft", "replace shading.lights[key]"),
            ("my_tone", "replace shading.tone"),
            ("after_soft", "after shading.lights[soft]"),
        ]);
        let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &user)]);
        let (c, d) = f.compose(&f.all());
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::ShadingLights), ["soft", "after_soft", "fill"]);
        assert_eq!(names(&c, Step::ShadingTone), ["my_tone"]);
        // `replace` of an empty step inserts there.
        let f = fx(&[("user.vrs", &pf("only", "replace shading.boundary"))]);
        let (c, d) = f.compose(&f.all());
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::ShadingBoundary), ["only"]);
    }

    #[test]
    fn remove_a_step_and_a_substep() {
        let f =
            fx(&[("std_base.vrs", &std_base()), ("user.vrs", "remove shading.lights[key];\nremove shading.tone;\n")]);
        let (c, d) = f.compose(&f.all());
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::ShadingLights), ["fill"]);
        assert!(names(&c, Step::ShadingTone).is_empty());
        // Removing from an empty step is fine; a missing substep is E0603.
        let f = fx(&[
            ("std_base.vrs", &std_base()),
            ("user.vrs", "remove shading.boundary;\nremove shading.lights[rim];\n"),
        ]);
        let (c, d) = f.compose(&f.all());
        assert_eq!(codes(&d), ["E0603"]);
        assert_eq!(f.line(d.iter().next().unwrap().span), 2);
        assert_eq!(names(&c, Step::ShadingLights), ["key", "fill"]);
    }

    #[test]
    fn removes_and_placements_apply_in_source_order() {
        let user = format!("{}remove shading.tone;\n{}", pf("mine", "in shading.tone"), pf("again", "in shading.tone"));
        let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &user)]);
        let (c, d) = f.compose(&f.all());
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::ShadingTone), ["again"]);
    }

    #[test]
    fn when_active_on_active_and_inactive_targets() {
        let mut user = module(&[
            ("a1", "after shading.lights[key] when active"),
            ("a2", "after shading.lights[rim] when active"),
            ("a3", "in shading.boundary when active"),
            ("a4", "in shading.lights when active"),
            ("a5", "replace shading.tone[nope] when active"),
            ("a6", "before shading.tone when active"),
        ]);
        user.push_str("remove shading.lights[rim] when active;\nremove shading.boundary when active;\n");
        let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &user)]);
        let (c, d) = f.compose(&f.all());
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::ShadingLights), ["key", "a1", "fill", "a4"]);
        assert!(names(&c, Step::ShadingBoundary).is_empty());
        assert_eq!(names(&c, Step::ShadingTone), ["a6", "tone"]);
    }

    #[test]
    fn when_active_sees_earlier_placements() {
        // The first module activates `shading.boundary` (and creates `edge`); the second then
        // finds both. Without the first, the second module's functions are left out.
        let first = pf("edge", "in shading.boundary");
        let second =
            module(&[("b1", "in shading.boundary when active"), ("b2", "before shading.boundary[edge] when active")]);
        let f = fx(&[("first.vrs", &first), ("second.vrs", &second)]);
        let (c, d) = f.compose(&[f.plain(0), f.plain(1)]);
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::ShadingBoundary), ["b2", "edge", "b1"]);
        let (c, d) = f.compose(&[f.plain(1), f.plain(0)]);
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::ShadingBoundary), ["edge"]);
    }

    #[test]
    fn missing_substep_is_e0603_with_a_suggestion() {
        let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &pf("x", "after shading.lights[kye]"))]);
        let (c, d) = f.compose(&f.all());
        let e = only(&d, Code::UnknownSubstep);
        assert_eq!(codes(&d), ["E0603"]);
        assert_eq!(e.span, f.program.pipelines.iter().find(|p| p.name == "x").unwrap().placement.span);
        assert_eq!(e.message, "step `shading.lights` has no substep `kye`");
        assert!(e.notes.iter().any(|n| n == "help: did you mean `shading.lights[key]`?"), "{:?}", e.notes);
        assert!(
            e.notes.iter().any(|n| n == "substeps of `shading.lights` at this point: `key`, `fill`"),
            "{:?}",
            e.notes
        );
        assert!(e.notes.iter().any(|n| n.contains("when active")));
        assert_eq!(names(&c, Step::ShadingLights), ["key", "fill"]);
        // A placement on an empty step's substep says the step is empty.
        let f = fx(&[("user.vrs", &pf("x", "before shading.tone[t]"))]);
        let (_, d) = f.compose(&f.all());
        let e = only(&d, Code::UnknownSubstep);
        assert!(e.notes.iter().any(|n| n == "`shading.tone` holds no functions at this point"), "{:?}", e.notes);
    }

    #[test]
    fn second_replace_is_e0604() {
        let one = pf("soft", "replace shading.lights[key]");
        let two = pf("hard", "replace shading.lights[key]");
        let f = fx(&[("std_base.vrs", &std_base()), ("one.vrs", &one), ("two.vrs", &two)]);
        let (c, d) = f.compose(&f.all());
        assert_eq!(codes(&d), ["E0604"]);
        let e = only(&d, Code::DoubleReplace);
        assert_eq!(e.span, f.program.pipelines.iter().find(|p| p.name == "hard").unwrap().placement.span);
        let earlier = f.program.pipelines.iter().find(|p| p.name == "soft").unwrap().placement.span;
        assert_eq!(e.secondary[0].0, earlier);
        assert_eq!(names(&c, Step::ShadingLights), ["soft", "fill"]);
        // Even with `when active`.
        let two = pf("hard", "replace shading.lights[key] when active");
        let f = fx(&[("std_base.vrs", &std_base()), ("one.vrs", &one), ("two.vrs", &two)]);
        let (_, d) = f.compose(&f.all());
        assert_eq!(codes(&d), ["E0604"]);

        // A replacement that keeps the name holds the place: a second replace is still E0604,
        // but other placements find it.
        let one = pf("key", "replace shading.lights[key]");
        let two = module(&[("after_key", "after shading.lights[key]"), ("hard", "replace shading.lights[key]")]);
        let f = fx(&[("std_base.vrs", &std_base()), ("one.vrs", &one), ("two.vrs", &two)]);
        let (c, d) = f.compose(&f.all());
        assert_eq!(codes(&d), ["E0604"]);
        assert_eq!(names(&c, Step::ShadingLights), ["key", "after_key", "fill"]);
        assert_eq!(f.program.pipelines[c.step(Step::ShadingLights)[0].pipeline].module, f.ids[1]);

        // After `replace S` took the whole step, `replace S[x]` is E0604 too, and `after S[x]`
        // is E0603 pointing at the replacement.
        let one = pf("lights", "replace shading.lights");
        let two = module(&[("hard", "replace shading.lights[fill]"), ("later", "after shading.lights[key]")]);
        let f = fx(&[("std_base.vrs", &std_base()), ("one.vrs", &one), ("two.vrs", &two)]);
        let (c, d) = f.compose(&f.all());
        assert_eq!(codes(&d), ["E0604", "E0603"]);
        let e = only(&d, Code::UnknownSubstep);
        assert_eq!(e.secondary.len(), 1);
        assert!(e.secondary[0].1.contains("`replace shading.lights` took the place of `key`"), "{:?}", e.secondary);
        assert_eq!(names(&c, Step::ShadingLights), ["lights"]);

        // A new function that takes the old name later is a fresh substep: replacing it is fine.
        let one = module(&[
            ("soft", "replace shading.lights[key]"),
            ("key", "in shading.lights"),
            ("hard", "replace shading.lights[key]"),
        ]);
        let f = fx(&[("std_base.vrs", &std_base()), ("one.vrs", &one)]);
        let (c, d) = f.compose(&f.all());
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::ShadingLights), ["soft", "fill", "hard"]);
    }

    #[test]
    fn one_name_twice_in_a_step_is_e0203() {
        let f = fx(&[
            ("one.vrs", &pf("dup", "in start")),
            ("two.vrs", &pf("dup", "in start")),
            ("three.vrs", &pf("dup", "in end")),
        ]);
        let (c, d) = f.compose(&f.all());
        assert_eq!(codes(&d), ["E0203"]);
        let e = only(&d, Code::Duplicate);
        let second = f.program.pipelines.iter().find(|p| p.module == f.ids[1]).unwrap();
        let first = f.program.pipelines.iter().find(|p| p.module == f.ids[0]).unwrap();
        assert_eq!(e.span, second.span);
        assert_eq!(e.secondary[0].0, first.span);
        assert_eq!(names(&c, Step::Start), ["dup"]);
        assert_eq!(names(&c, Step::End), ["dup"]);
        assert_eq!(f.program.pipelines[c.step(Step::Start)[0].pipeline].module, f.ids[0]);
        // A `replace` of a function by one of the same name is no duplicate.
        let f = fx(&[("one.vrs", &pf("dup", "in start")), ("two.vrs", &pf("dup", "replace start[dup]"))]);
        let (c, d) = f.compose(&f.all());
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(f.program.pipelines[c.step(Step::Start)[0].pipeline].module, f.ids[1]);
    }

    const CLIP: &str = "\
lib fn plane_distance(plane: vec4f, p: vec3f) -> f32 {
    return dot(plane.xyz, p) + plane.w;
}

/// Clip one additional volume against a plane.
pipeline clip_$ after classification.additional[$] when active {
    /// The clip plane of volume `$`.
    uniform clip_plane_$: vec4f = vec4f(1.0, 0.0, 0.0, -0.5) in -1.0 .. 1.0;
    state pos: vec3f;
    state color_$: vec4f;
    use plane_distance;

    if plane_distance(clip_plane_$, state.pos) < 0.0 {
        state.color_$ = vec4f(0.0);
    }
}
";

    const VOLUMES: &str = "\
pipeline setup in sampling.primary {
    state pos: vec3f = vec3f(0.5);
    state.pos = state.pos * 1.0;
}
pipeline gm in classification.additional {
    state color_gm: vec4f = vec4f(0.0);
    state.color_gm = vec4f(1.0);
}
pipeline wm in classification.additional {
    state color_wm: vec4f = vec4f(0.0);
    state.color_wm = vec4f(0.5);
}
pipeline blend in compositing.additional {
    @ray state accum: vec4f = vec4f(0.0);
    state color_gm: vec4f;
    state color_wm: vec4f;
    state.accum = state.accum + state.color_gm + state.color_wm;
}
";

    #[test]
    fn template_with_two_instances() {
        let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
        let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["gm", "wm"])]);
        assert!(d.is_empty(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::ClassificationAdditional), ["gm", "clip_gm", "wm", "clip_wm"]);
        let fns = c.step(Step::ClassificationAdditional);
        assert_eq!(fns[1].instance.as_deref(), Some("gm"));
        assert_eq!(fns[3].instance.as_deref(), Some("wm"));
        assert_eq!(fns[1].pipeline, fns[3].pipeline);
        // Each instance has its own uniform, with the template's default, range and doc.
        let uniforms: Vec<&str> = c.uniforms.iter().map(|u| u.name.as_str()).collect();
        assert_eq!(uniforms, ["clip_plane_gm", "clip_plane_wm"]);
        assert_eq!(c.uniforms[0].ty, Type::vec(4, Scalar::F32));
        assert_eq!(c.uniforms[1].default.as_ref().map(show_const).as_deref(), Some("vec4f(1.0, 0.0, 0.0, -0.5)"));
        assert!(c.uniforms[1].range.is_some());
        // `$` in a doc names the instance, as in the uniform's name.
        assert_eq!(c.uniforms[0].doc.as_deref().map(str::trim), Some("The clip plane of volume `gm`."));
        assert_eq!(c.uniforms[1].doc.as_deref().map(str::trim), Some("The clip plane of volume `wm`."));
        assert_eq!(fns[1].uniforms, [0]);
        assert_eq!(fns[3].uniforms, [1]);
        // State names are substituted; `pos` is shared.
        let field = |i: Option<usize>| i.map(|i| c.fields[i].name.as_str());
        assert_eq!(fns[1].state.iter().map(|&s| field(s)).collect::<Vec<_>>(), [Some("pos"), Some("color_gm")]);
        assert_eq!(fns[3].state.iter().map(|&s| field(s)).collect::<Vec<_>>(), [Some("pos"), Some("color_wm")]);
        // Without the `wm` volume, `clip_wm` is left out (when active).
        let f = fx(&[("std_volumes.vrs", &VOLUMES.replace("pipeline wm", "pipeline other")), ("clip.vrs", CLIP)]);
        let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["gm", "wm"])]);
        assert_eq!(names(&c, Step::ClassificationAdditional), ["gm", "clip_gm", "other"]);
        assert!(d.iter().all(|d| !d.is_error()), "{:?}", codes(&d));
        assert_eq!(c.uniforms.len(), 1);
    }

    #[test]
    fn template_without_instances_is_e0606() {
        let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
        for uses in [vec![f.plain(0), f.plain(1)], vec![f.plain(0), f.inst(1, &[])]] {
            let (c, d) = f.compose(&uses);
            let e = only(&d, Code::UninstantiatedTemplate);
            assert_eq!(f.line(e.span), 6, "at the first `$`: the pipeline's name");
            assert!(e.notes.iter().any(|n| n.contains("list instances in the scene")));
            assert_eq!(names(&c, Step::ClassificationAdditional), ["gm", "wm"]);
        }
        // The first `$` may be a declaration or a remove.
        let f = fx(&[(
            "t.vrs",
            "pipeline p in start {\n    state a: f32 = 0.0;\n    state b_$: f32 = 0.0;\n    state.a = state.b_$;\n}\nremove end[$];",
        )]);
        let (_, d) = f.compose(&f.all());
        assert_eq!(f.line(only(&d, Code::UninstantiatedTemplate).span), 3);
        let f = fx(&[("t.vrs", "remove end[$];")]);
        let (_, d) = f.compose(&f.all());
        assert_eq!(f.line(only(&d, Code::UninstantiatedTemplate).span), 1);
    }

    #[test]
    fn bad_instance_names_are_e0607() {
        let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
        let mut bad = f.inst(1, &["g-m", "gm", "9x", "gm"]);
        bad.span = Span::new(3, 7);
        let (c, d) = f.compose(&[f.plain(0), bad]);
        assert_eq!(codes(&d), ["E0607", "E0607", "E0607"]);
        assert!(d.iter().all(|x| x.span == Span::new(3, 7)));
        assert_eq!(d.iter().next().unwrap().message, "`g-m` is not a valid instance name");
        assert_eq!(d.iter().nth(2).unwrap().message, "instance `gm` is listed twice");
        assert_eq!(names(&c, Step::ClassificationAdditional), ["gm", "clip_gm", "wm"]);
    }

    #[test]
    fn plain_module_with_instances_is_placed_once_with_a_warning() {
        let f = fx(&[("std_base.vrs", &std_base()), ("user.vrs", &pf("extra", "in shading.lights"))]);
        let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["a", "b"])]);
        assert_eq!(codes(&d), ["W0701"]);
        assert_eq!(names(&c, Step::ShadingLights), ["key", "fill", "extra"]);
        assert_eq!(c.step(Step::ShadingLights)[2].instance, None);
    }

    #[test]
    fn diagnostics_on_an_instance_name_it() {
        let f = fx(&[("std_base.vrs", &std_base()), ("tint.vrs", &pf("tint_$", "after shading.lights[$]"))]);
        let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["key", "rim"])]);
        assert_eq!(codes(&d), ["E0603"]);
        let e = only(&d, Code::UnknownSubstep);
        assert_eq!(e.message, "step `shading.lights` has no substep `rim`");
        assert!(e.notes.iter().any(|n| n == "in instance `rim` of template `tint_$`"), "{:?}", e.notes);
        assert_eq!(names(&c, Step::ShadingLights), ["key", "tint_key", "fill"]);
    }

    #[test]
    fn field_without_default_is_e0605() {
        let user = "\
pipeline w in start { state weight: f32; state.weight = 1.0; }
pipeline r in end { state weight: f32; state color: vec4f = vec4f(0.0); state.color.a = state.weight; }
";
        let f = fx(&[("user.vrs", user)]);
        let (c, d) = f.compose(&f.all());
        let e = only(&d, Code::NoDefault);
        assert_eq!(f.line(e.span), 1);
        assert!(e.notes.iter().any(|n| n == "help: give a default: `state weight: f32 = ...;`"), "{:?}", e.notes);
        // The field is still there, with its type's zero value.
        let w = c.field("weight").unwrap();
        assert_eq!(show_const(&c.fields[w].default), "0.0");
    }

    #[test]
    fn conflicts_across_an_instantiated_template_and_a_plain_module() {
        let plain = "\
pipeline base in start {
    state value_gm: f32 = 0.0;
    state level_gm: f32 = 0.0;
    uniform gain_gm: f32 = 1.0;
    uniform bias_gm: f32;
    state.value_gm = gain_gm + bias_gm;
    state.level_gm = 1.0;
}
";
        let template = "\
pipeline use_$ in end {
    state value_$: f32 = 1.0;
    @ray state level_$: f32 = 0.0;
    uniform gain_$: f32 = 2.0;
    uniform bias_$: vec2f;
    state.value_$ = state.value_$ + gain_$ + bias_$.x + state.level_$;
}
";
        let f = fx(&[("plain.vrs", plain), ("tmpl.vrs", template)]);
        let (_, d) = f.compose(&[f.plain(0), f.inst(1, &["gm"])]);
        let mut got: Vec<(&str, usize)> =
            d.iter().filter(|x| x.is_error()).map(|x| (x.code.as_str(), f.line(x.span))).collect();
        got.sort();
        assert_eq!(got, [("E0504", 3), ("E0505", 2), ("E0505", 4), ("E0506", 5)]);
        let e = only(&d, Code::StateConflict);
        assert_eq!(f.line(e.secondary[0].0), 3, "the earlier declaration, in plain.vrs");
        assert!(e.notes.iter().any(|n| n == "in instance `gm` of template `use_$`"));
        let e = d.iter().find(|x| x.code == Code::DefaultConflict && f.line(x.span) == 2).unwrap();
        assert_eq!(e.message, "state field `value_gm` has default 1.0 here but 0.0 in `base`");
        // With another instance nothing conflicts.
        let (_, d) = f.compose(&[f.plain(0), f.inst(1, &["wm"])]);
        assert!(!d.has_errors(), "{:?}", codes(&d));
    }

    #[test]
    fn conflicts_as_written_are_left_to_the_checker() {
        // Two templates agreeing as written, and a plain module: no conflict reported here twice.
        let one = "pipeline a_$ in start { state v_$: f32 = 1.0; state.v_$ = 2.0; }";
        let two = "pipeline b_$ in end { state v_$: f32 = 1.0; state o: f32 = 0.0; state.o = state.v_$; }";
        let f = fx(&[("one.vrs", one), ("two.vrs", two)]);
        let (c, d) = f.compose(&[f.inst(0, &["x", "y"]), f.inst(1, &["x"])]);
        assert!(!d.has_errors(), "{:?}", codes(&d));
        assert_eq!(names(&c, Step::Start), ["a_x", "a_y"]);
        assert_eq!(names(&c, Step::End), ["b_x"]);
        // v_x is read (by b_x); v_y only written (by a_y), so left out.
        assert!(c.field("v_x").is_some() && c.field("v_y").is_none());
        // Two plain declarations that conflict as written: the checker reports it (and drops
        // the later function), the composer does not report it again.
        let mut sources = SourceMap::new();
        let mut diags = Diagnostics::new();
        let mut loader = Loader::new(&mut sources, &mut diags);
        loader.load_root_source("p.vrs", "pipeline p in start { state w: f32 = 0.0; state.w = 1.0; }\npipeline q in end { state w: f32 = 1.0; state o: f32 = 0.0; state.o = state.w; }".into(), None);
        let graph = loader.finish();
        let program = check_program(&graph, &sources, &mut diags);
        let checker_errors = diags.error_count();
        assert_eq!(checker_errors, 1, "the checker reports the conflict");
        let mut again = Diagnostics::new();
        compose(&program, &[ModuleUse { module: 0, instances: None, span: Span::DUMMY }], |_| false, &[], &mut again);
        assert!(!again.has_errors(), "{:?}", codes(&again));
    }

    #[test]
    fn read_before_write_is_w0005() {
        let user = "\
pipeline reads in start {
    state weight: f32 = 0.5;
    @ray state hits: f32 = 0.0;
    state late: f32 = 0.0;
    state.late = state.weight + state.hits;
}
pipeline writes in end {
    state weight: f32;
    @ray state hits: f32;
    state.weight = 1.0;
    state.hits = state.hits + 1.0;
}
pipeline setup in ray.setup { state early: f32 = 0.0; state.early = 1.0; }
pipeline uses_early in compositing.alpha {
    state early: f32;
    state late: f32;
    state sum: f32 = 0.0;
    state.sum = state.early + state.late;
}
pipeline finish in ray.finish { state sum: f32; @ray state hits: f32; state.hits = state.sum; }
";
        let f = fx(&[("user.vrs", user)]);
        let (_, d) = f.compose(&f.all());
        let warnings: Vec<(&str, usize)> = d.iter().map(|x| (x.code.as_str(), f.line(x.span))).collect();
        // `weight` (per-sample) is read in `start` but written only in `end`: W0005. `hits` is
        // `@ray`: the previous sample's write reaches it. `early` is written in `ray.setup` but
        // reset before every sample: W0005 with a note. `late`, `sum` are written in time.
        // Each W0005 points at the read. The writes that no read reaches are W0006: `weight` in
        // `end` (line 8), `early` in `ray.setup` (13), `hits` in `ray.finish` (20).
        let mut sorted = warnings.clone();
        sorted.sort();
        assert_eq!(sorted, [("W0005", 5), ("W0005", 18), ("W0006", 8), ("W0006", 13), ("W0006", 20)]);
        let lost = d.iter().find(|x| f.line(x.span) == 20).unwrap();
        assert_eq!(lost.message, "`finish` writes state field `hits`, but no later function reads it");
        let e = d.iter().find(|x| f.line(x.span) == 18).unwrap();
        assert!(e.notes.iter().any(|n| n.contains("reset to its default before every sample")), "{:?}", e.notes);
        // The same functions in a standard module get no warnings.
        let f = fx(&[("std_user.vrs", user)]);
        let (_, d) = f.compose(&f.all());
        assert!(d.is_empty(), "{:?}", codes(&d));
    }

    #[test]
    fn written_never_read_is_w0006_and_left_out() {
        let std = "\
pipeline init in ray.setup {
    @ray state out_color: vec4f = vec4f(0.0);
    @ray state scratch: f32 = 0.0;
    state.out_color = vec4f(1.0);
    state.scratch = 1.0;
}
";
        let user = "\
pipeline debug in end {
    state debug: vec4f = vec4f(0.0);
    state unused: f32 = 0.0;
    @ray state scratch: f32;
    state.debug = vec4f(1.0);
}
";
        let px = "pipeline px in start { state pixel: vec2f = vec2f(0.0); @ray state n: f32 = 0.0; state.n = state.n + state.pixel.x; }";
        let f = fx(&[("std_init.vrs", std), ("user.vrs", user), ("px.vrs", px)]);
        let (c, d) = f.compose_with(&f.all(), &["out_color", "terminate", "pixel"]);
        let warnings: Vec<(&str, usize)> = d.iter().map(|x| (x.code.as_str(), f.line(x.span))).collect();
        // `debug`: W0006 at the user's writer. `scratch` written only by the standard module:
        // left out without a warning. `out_color` is required by the entry point: kept.
        // `pixel` is the entry point's: read without a writer, but no W0005.
        assert_eq!(warnings, [("W0006", 2)]);
        let kept: Vec<&str> = c.fields.iter().map(|x| x.name.as_str()).collect();
        assert_eq!(kept, ["out_color", "pixel", "n"]);
        assert!(c.fields[0].written && !c.fields[0].read && c.fields[0].ray);
        assert_eq!(c.step(Step::RaySetup)[0].state, [Some(0), None]);
        assert_eq!(c.step(Step::End)[0].state, [None, None, None]);
    }

    #[test]
    fn unread_fields_are_left_out() {
        let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
        let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["gm"])]);
        assert!(d.is_empty(), "{:?}", codes(&d));
        // `color_wm` is read by `blend`, `accum` by `blend` itself; all read fields are kept in
        // first-declaration order along the pipeline.
        let kept: Vec<(&str, bool)> = c.fields.iter().map(|x| (x.name.as_str(), x.ray)).collect();
        assert_eq!(kept, [("pos", false), ("color_gm", false), ("color_wm", false), ("accum", true)]);
        // Remove the reader: the colours are written only. `color_wm` has only a standard
        // writer (no warning); `color_gm` is also written by `clip_gm`: W0006 there.
        let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP), ("user.vrs", "remove compositing.additional;")]);
        let (c, d) = f.compose(&[f.plain(0), f.inst(1, &["gm"]), f.plain(2)]);
        let kept: Vec<&str> = c.fields.iter().map(|x| x.name.as_str()).collect();
        assert_eq!(kept, ["pos"]);
        let fns = c.step(Step::ClassificationAdditional);
        assert_eq!(fns[0].state, [None]);
        assert_eq!(fns[1].state, [Some(0), None]);
        assert_eq!(fns[2].state, [None]);
        assert_eq!(codes(&d), ["W0006"]);
        let e = only(&d, Code::WrittenNeverRead);
        assert_eq!(f.line(e.span), 10);
        assert!(e.notes.iter().any(|n| n == "in instance `gm` of template `clip_$`"), "{:?}", e.notes);
    }

    #[test]
    fn pipeline_map_text() {
        let f = fx(&[("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
        let (c, _) = f.compose(&[f.plain(0), f.inst(1, &["gm", "wm"])]);
        let text = c.render_pipeline_map(&f.program, &f.sources);
        let expected = "\
ray.setup (empty)
start (empty)
sampling.primary
  setup    std_volumes.vrs:1
sampling.mask (empty)
sampling.tag (empty)
sampling.additional (empty)
sampling.gradient (empty)
classification.primary (empty)
classification.additional
  gm       std_volumes.vrs:5
  clip_gm  clip.vrs:6          (instance gm)
  wm       std_volumes.vrs:9
  clip_wm  clip.vrs:6          (instance wm)
shading.lights (empty)
shading.boundary (empty)
shading.tone (empty)
compositing.primary_color (empty)
compositing.shading (empty)
compositing.alpha (empty)
compositing.additional
  blend    std_volumes.vrs:13
end (empty)
ray.finish (empty)
";
        assert_eq!(text, expected);
        let map = c.pipeline_map(&f.program, &f.sources);
        assert_eq!(map.len(), 6);
        assert_eq!((map[2].file.as_str(), map[2].line, map[2].instance.as_deref()), ("clip.vrs", 6, Some("gm")));
    }

    #[test]
    fn composition_is_deterministic() {
        let f = fx(&[("std_base.vrs", &std_base()), ("std_volumes.vrs", VOLUMES), ("clip.vrs", CLIP)]);
        let uses = [f.plain(0), f.plain(1), f.inst(2, &["wm", "gm"])];
        let (a, da) = f.compose(&uses);
        let (b, db) = f.compose(&uses);
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        assert_eq!(da.sorted(), db.sorted());
        assert_eq!(names(&a, Step::ClassificationAdditional), ["gm", "clip_gm", "wm", "clip_wm"]);
    }
}
