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
use super::view::{self, Bindings, StepLowering, ViewModule};
use crate::diag::Diagnostic;
use crate::hir;
use crate::lower::{self, ModuleBuilder};
use crate::source::{SourceMap, Span};
use crate::steps::Step;
use crate::types::Type;
use vrs_reflection::BindingKind;

/// Builds and validates the module of a filter composition. Errors are internal (E0901), as
/// for a ray pipeline: what a user can get wrong was reported before.
pub fn emit(program: &hir::Program, comp: &Composition, sources: &SourceMap) -> Result<ViewModule, Diagnostic> {
    let mut b = ModuleBuilder::new();
    let fields: Vec<(String, Type)> = comp.fields.iter().map(|f| (f.name.clone(), f.ty)).collect();
    let state_type = b.add_struct("State", &fields, Span::DUMMY)?;

    let uniforms: Vec<Uniform> = comp.uniforms.iter().filter(|u| !u.ty.is_resource()).cloned().collect();
    let mut bindings = Bindings::default();
    let block = if uniforms.is_empty() {
        None
    } else {
        let members: Vec<(String, Type)> = uniforms.iter().map(|u| (u.name.clone(), u.ty)).collect();
        let binding = bindings.next("uniforms", BindingKind::UniformBlock);
        Some(b.add_uniform_block("Uniforms", "uniforms", &members, binding, Span::DUMMY)?)
    };
    let output_binding = bindings.next("output", BindingKind::OutputImage);
    let output = view::add_storage_image(&mut b, "output", naga::StorageFormat::Rgba8Unorm, output_binding);
    let region = view::add_region(&mut b, bindings.next("region", BindingKind::Region));
    let access = view::bind_uniforms(&mut b, &mut bindings, (comp, &uniforms), block, &[])?;

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
    let state_layout = b.struct_layout(state_type).unwrap_or_else(view::empty_layout);
    let block_type = block.map(|block| b.module.global_variables[block].ty);
    let uniform_layout = block_type.and_then(|ty| b.struct_layout(ty)).unwrap_or_else(view::empty_layout);
    let entry_point = entry::build_filter(&mut b.module, &plan);
    let mut module = b.finish();
    module.entry_points.push(entry_point);
    let info = lower::validate(&module, sources, Span::DUMMY)?;
    Ok(ViewModule { module, info, uniforms, uniform_layout, state_layout, bindings: bindings.list })
}
