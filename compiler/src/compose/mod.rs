//! The composer: instantiates templates (`docs/language.md`, "Instances (`$`)"), places every
//! pipeline function and `remove` of the composed modules into the steps ("Steps and
//! placement"), merges the state and uniform declarations of the placed functions, and checks the
//! data flow of the linear pipeline.
//!
//! Choices `docs/language.md` leaves open (also in `docs/reference.md`):
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

//!
//! [`compose`] runs the passes in order: `instantiate` (templates to units), `place` (units into
//! steps), `merge` (declarations into the composed state and uniforms, data flow). Their result,
//! the `ir::Composition`, is what emission (`view`, `entry`) builds the shader from.

use crate::diag::{Code, Diagnostic, Diagnostics};
use crate::hir;
use crate::steps::{PipelineKind, Step};
use rustc_hash::FxHashMap;

pub mod backends;
pub mod build;
pub mod cache;
pub mod contribution;
pub(crate) mod entry;
pub mod explain;
pub(crate) mod filter;
mod instantiate;
pub(crate) mod ir;
pub(crate) mod layer_check;
pub(crate) mod limits;
mod merge;
pub(crate) mod place;
pub mod probe;
pub(crate) mod reflect;
pub(crate) mod segment;
pub(crate) mod standard;
#[cfg(test)]
mod tests;
pub mod uniform_check;
pub(crate) mod view;

pub use entry::TRANSLUCENT_LAYERS;
use instantiate::{Source, Unit, instantiate};
use ir::{Composition, ModuleUse, NotPlaced};
use merge::Merger;
use place::Placer;
pub use view::MESH_SHADOW_MAP_PREFIX;

/// Places every pipeline function and `remove` of the given modules, in order, and checks the
/// composed state and uniforms. `is_std(module)` tells standard modules apart (they get no
/// data-flow warnings). Fields named in `required` belong to the entry point, which reads (and
/// may set) them: they are kept whenever a placed function declares them, even if no function
/// reads them, and get no data-flow warnings.
///
/// The composition is of pipeline `kind`: a function placed in a step of the other pipeline is
/// an error (E0611) and left out.
///
/// Errors go to `diags`; the composition is returned whatever happened (check
/// `diags.has_errors()` before emitting).
pub fn compose(
    program: &hir::Program,
    uses: &[ModuleUse],
    (kind, is_std): (PipelineKind, impl Fn(usize) -> bool),
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
    let mut ever_placed = vec![false; units.len()];
    for (u, unit) in units.iter().enumerate() {
        match unit.source {
            Source::Pipeline(_) => {
                placer.place(u);
                ever_placed[u] = placer.steps.iter().any(|s| s.contains(&u));
            }
            Source::Remove(_) => placer.remove(u),
        }
    }
    let mut placed = placer.steps;
    leave_out_other_pipeline(program, &units, kind, &mut placed, diags);
    let not_placed = not_placed(program, &units, &placed, &ever_placed);
    let mut composition = Merger { program, units: &units, is_std: &is_std, required, kind, diags }.merge(&placed);
    composition.not_placed = not_placed;
    composition
}

/// Reports (E0611) and leaves out the functions placed in steps that are not of pipeline `kind`.
fn leave_out_other_pipeline(
    program: &hir::Program,
    units: &[Unit],
    kind: PipelineKind,
    placed: &mut [Vec<usize>],
    diags: &mut Diagnostics,
) {
    for (step, units_here) in Step::ALL.iter().zip(placed.iter_mut()) {
        if step.kind() == kind {
            continue;
        }
        for u in units_here.drain(..) {
            let Source::Pipeline(i) = units[u].source else { continue };
            let placement = &program.pipelines[i].placement;
            let list = match step.kind() {
                PipelineKind::Filter => "list its module in the view's `filters`, which compose the filter pipeline",
                PipelineKind::Ray => {
                    "list its module in the view's `modules` (or a `[[module]]`), which compose the ray pipeline"
                }
            };
            diags.push(
                Diagnostic::new(
                    Code::OtherPipeline,
                    placement.span,
                    format!("`{}` goes into `{step}`, a step of {}", units[u].name, step.kind().describe()),
                )
                .with_label(format!("composed here as part of {}", kind.describe()))
                .with_help(list),
            );
        }
    }
}

/// The pipeline functions that were removed after placement, or left out by `when active`
/// (a function refused with an error is neither).
fn not_placed(program: &hir::Program, units: &[Unit], placed: &[Vec<usize>], ever: &[bool]) -> Vec<NotPlaced> {
    let running = |u: usize| placed.iter().any(|s| s.contains(&u));
    let mut out = Vec::new();
    for (u, unit) in units.iter().enumerate() {
        let Source::Pipeline(i) = unit.source else { continue };
        let placement = &program.pipelines[i].placement;
        if running(u) || !(ever[u] || placement.when_active) {
            continue;
        }
        let (name, instance) = (unit.name.clone(), unit.instance.clone());
        out.push(NotPlaced { pipeline: i, name, instance, step: placement.step, removed: ever[u] });
    }
    out
}
