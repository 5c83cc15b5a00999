//! Emission of a view's filter pass (its `filters`): the image-space pipeline, composed by the
//! same composer as the ray pipeline into the steps `filter.setup`, `filter.apply` and
//! `filter.finish`, and emitted as one compute shader that runs once per pixel.
//!
//! Binding layout, all in `@group(0)`: the uniform block `uniforms` when some placed function
//! reads a plain uniform, the output image (`texture_storage_2d<rgba8unorm, write>`, the
//! filtered picture), the `region` the dispatch filters, then every resource uniform in
//! composition order: an `image` as one `texture_2d<f32>` (`picture`, `picture_depth`), a
//! `volume` or `tf` as its texture and sampler.

use super::entry::{self, FilterEntryPlan};
use super::ir::{Composition, Uniform};
use super::view::{self, ModuleHead, StepLowering, ViewModule};
use crate::diag::Diagnostic;
use crate::hir;
use crate::lower::ModuleBuilder;
use crate::source::SourceMap;
use crate::steps::Step;

/// Builds and validates the module of a filter composition. Errors are internal (E0901), as
/// for a ray pipeline: what a user can get wrong was reported before.
pub fn emit(program: &hir::Program, comp: &Composition, sources: &SourceMap) -> Result<ViewModule, Diagnostic> {
    let mut b = ModuleBuilder::new();
    let uniforms: Vec<Uniform> = comp.uniforms.iter().filter(|u| !u.ty.is_resource()).cloned().collect();
    let ModuleHead { state_type, block, output, region, access, bindings } =
        ModuleHead::emit(&mut b, comp, &uniforms, &[])?;

    let steps = StepLowering { program, comp, state_type, access: &access };
    let functions = steps.lower(&mut b, &[Step::FilterSetup, Step::FilterApply, Step::FilterFinish])?;
    let init_state = view::lower_defaults(&mut b, program, comp, state_type, "init_state", |_| true)?;
    let member = |name: &str| comp.field(name).map(|i| i as u32);
    let plan = FilterEntryPlan {
        state_type,
        init_state,
        pixel: member(entry::PIXEL),
        texel: member(entry::TEXEL),
        out_color: member(entry::OUT_COLOR),
        functions,
        output,
        region,
    };
    let parts = (state_type, block, uniforms, bindings);
    view::finish_module(b, parts, |module| entry::build_filter(module, &plan), sources)
}
