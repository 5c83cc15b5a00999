//! The composition IR: the placed functions step by step, the merged state and uniforms, and
//! the pipeline map. Placement and merging build it; emission and reflection read it.

use crate::hir::{self, ConstValue};
use crate::source::{SourceMap, Span};
use crate::steps::{PipelineKind, Step};
use crate::types::Type;

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
    /// Pipeline functions of the modules that do not run, in module order.
    pub not_placed: Vec<NotPlaced>,
    /// The pipeline composed: a view's raycaster or its filter pass.
    pub kind: PipelineKind,
}

/// A pipeline function that was given to the composer but does not run.
#[derive(Clone, Debug)]
pub struct NotPlaced {
    /// Index into [`hir::Program::pipelines`].
    pub pipeline: usize,
    pub name: String,
    pub instance: Option<String>,
    /// The step its placement names.
    pub step: Step,
    /// Placed, then removed or replaced (`true`); or left out by `when active` (`false`).
    pub removed: bool,
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

    /// The functions of one step.
    pub fn step(&self, step: Step) -> &[PlacedFn] {
        self.steps.iter().find(|s| s.step == step).map_or(&[], |s| &s.functions)
    }

    /// The index of a field by name.
    pub fn field(&self, name: &str) -> Option<usize> {
        self.fields.iter().position(|f| f.name == name)
    }
}
