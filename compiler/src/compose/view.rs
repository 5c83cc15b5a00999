//! Emission of one composed view: the naga module (State struct, uniform block, resource
//! bindings, reached library functions, every placed pipeline function, the compute entry
//! point), validated.
//!
//! Binding layout, all in `@group(0)`: binding 0 is the uniform block `uniforms`, binding 1 the
//! output image (`texture_storage_2d<rgba8unorm, write>`), binding 2 the `region` of the image
//! that a dispatch renders (`vec4<u32>`), then every `volume` and `tf` uniform in composition
//! order, each as its texture and then its sampler.

use super::contribution;
use super::entry::{self, EntryPlan};
use super::ir::{Composition, Uniform};
use crate::ast::{AssignOp, PlacementKind};
use crate::diag::Diagnostic;
use crate::hir::{self, ConstValue, ScalarValue};
use crate::lower::{self, LookupSource, ModuleBuilder, PipelineEnv, StructLayout, UniformAccess};
use crate::source::{SourceMap, Span};
use crate::steps::Step;
use crate::types::Type;
use naga::{Handle, ResourceBinding};
pub use vrs_reflection::{BindingInfo, BindingKind};

/// The uniform the entry point adds when no function declares it: the sample-loop bound.
pub const MAX_SAMPLES: &str = "max_samples";
/// Default of [`MAX_SAMPLES`].
pub const DEFAULT_MAX_SAMPLES: u32 = 1024;

/// A validated view module and the layouts the runtime needs.
pub struct ViewModule {
    pub module: naga::Module,
    pub info: naga::valid::ModuleInfo,
    /// The uniforms in block order (the composition's plain uniforms, then `max_samples` if the
    /// entry point added it) with their layout members.
    pub uniforms: Vec<Uniform>,
    pub uniform_layout: StructLayout,
    pub state_layout: StructLayout,
    pub bindings: Vec<BindingInfo>,
}

/// Builds and validates the module of a composition. Errors are internal (E0901): everything a
/// user can get wrong was reported by the checker or the composer. The module is built in the
/// order its WGSL reads (state, uniforms, bindings, functions step by step, entry point), in one
/// function so that the order is visible.
pub fn emit(
    program: &hir::Program,
    comp: &Composition,
    sources: &SourceMap,
    bricked: &[(String, LookupSource<'_>)],
) -> Result<ViewModule, Diagnostic> {
    let mut b = ModuleBuilder::new();
    let fields: Vec<(String, Type)> = comp.fields.iter().map(|f| (f.name.clone(), f.ty)).collect();
    let state_type = b.add_struct("State", &fields, Span::DUMMY)?;

    let mut uniforms: Vec<Uniform> = comp.uniforms.iter().filter(|u| !u.ty.is_resource()).cloned().collect();
    if !uniforms.iter().any(|u| u.name == MAX_SAMPLES) {
        uniforms.push(Uniform {
            name: MAX_SAMPLES.into(),
            ty: Type::U32,
            default: Some(ConstValue { ty: Type::U32, components: vec![ScalarValue::U32(DEFAULT_MAX_SAMPLES)] }),
            range: None,
            doc: Some("Upper bound of samples per ray (added by the composer).".into()),
            span: Span::DUMMY,
        });
    }
    let members: Vec<(String, Type)> = uniforms.iter().map(|u| (u.name.clone(), u.ty)).collect();
    let mut bindings = Vec::new();
    let mut bind = |name: &str, kind| {
        let binding = bindings.len() as u32;
        bindings.push(BindingInfo { name: name.to_string(), group: 0, binding, kind });
        ResourceBinding { group: 0, binding }
    };
    let block = b.add_uniform_block(
        "Uniforms",
        "uniforms",
        &members,
        bind("uniforms", BindingKind::UniformBlock),
        Span::DUMMY,
    )?;
    let output =
        add_storage_image(&mut b, "output", naga::StorageFormat::Rgba8Unorm, bind("output", BindingKind::OutputImage));
    let region = add_region(&mut b, bind("region", BindingKind::Region));
    let mut access: Vec<UniformAccess> = Vec::with_capacity(comp.uniforms.len());
    for u in &comp.uniforms {
        access.push(match u.ty {
            Type::Volume if let Some((_, lookup)) = bricked.iter().find(|(name, _)| *name == u.name) => {
                let kinds = [
                    BindingKind::BrickPool,
                    BindingKind::VolumeSampler,
                    BindingKind::PageTable,
                    BindingKind::BrickLayout,
                    BindingKind::BrickRequests,
                ];
                UniformAccess::Bricked(b.add_bricked_volume(
                    &u.name,
                    kinds.map(|k| bind(&u.name, k)),
                    u.span,
                    *lookup,
                )?)
            }
            Type::Volume => b.add_volume_binding(
                &u.name,
                bind(&u.name, BindingKind::VolumeTexture),
                bind(&u.name, BindingKind::VolumeSampler),
                u.span,
            ),
            Type::Tf => b.add_tf_binding(
                &u.name,
                bind(&u.name, BindingKind::TfTexture),
                bind(&u.name, BindingKind::TfSampler),
                u.span,
            ),
            _ => {
                let index = uniforms.iter().position(|p| p.name == u.name).unwrap_or_default() as u32;
                UniformAccess::Member { block, index }
            }
        });
    }

    // Last of the bindings, so a view that does not meter keeps its numbering.
    let metering = comp.field(entry::METERED_LUMINANCE).map(|member| {
        let format = naga::StorageFormat::R32Float;
        let image =
            add_storage_image(&mut b, "luminance_image", format, bind("luminance_image", BindingKind::LuminanceImage));
        (image, member as u32)
    });
    // After the luminance image: the mesh layer's images, for the fields the composition has.
    // Both are `texture_2d<f32>` read with `textureLoad` (a depth texture cannot be loaded in
    // every back end's compute shaders; the layer keeps its depth as `r32float` colour).
    let layers =
        [(entry::GEOMETRY_DEPTH, BindingKind::GeometryDepth), (entry::GEOMETRY_COLOR, BindingKind::GeometryColor)];
    let class = naga::ImageClass::Sampled { kind: naga::ScalarKind::Float, multi: false };
    let geometry = layers
        .into_iter()
        .filter_map(|(field, kind)| {
            let member = comp.field(field)? as u32;
            let components = comp.fields[member as usize].ty.components() as u32;
            Some((add_image(&mut b, &format!("{field}_image"), class, bind(field, kind)), member, components))
        })
        .collect();
    let lowered = |steps: &[Step], b: &mut ModuleBuilder| -> Result<Vec<Handle<naga::Function>>, Diagnostic> {
        let mut out = Vec::new();
        for placed in steps.iter().flat_map(|&s| comp.step(s)) {
            let pf = &program.pipelines[placed.pipeline];
            let env = PipelineEnv {
                state_type,
                state_members: placed.state.iter().map(|m| m.map(|i| i as u32)).collect(),
                uniforms: placed.uniforms.iter().map(|&u| access[u]).collect(),
            };
            out.push(b.lower_pipeline_fn(program, pf, &placed.name, &env)?);
        }
        Ok(out)
    };
    let ray_setup = lowered(&[Step::RaySetup], &mut b)?;
    let sample_steps: Vec<Step> = Step::ALL.iter().copied().filter(|s| !s.is_per_ray()).collect();
    let lowered_samples = lowered(&sample_steps, &mut b)?;
    // The entry point runs them in the order of the contribution schedule.
    let sample_fns: Vec<(Step, usize)> =
        sample_steps.iter().flat_map(|&s| (0..comp.step(s).len()).map(move |i| (s, i))).collect();
    let schedule = contribution::schedule(program, comp);
    let handles = |fns: &[(Step, usize)]| -> Vec<Handle<naga::Function>> {
        fns.iter().filter_map(|f| sample_fns.iter().position(|g| g == f).map(|k| lowered_samples[k])).collect()
    };
    let ray_finish = lowered(&[Step::RayFinish], &mut b)?;

    let init_state = lower_defaults(&mut b, program, comp, state_type, "init_state", |_| true)?;
    let reset_sample = lower_defaults(&mut b, program, comp, state_type, "reset_sample", |ray| !ray)?;
    let member = |name: &str| comp.field(name).map(|i| i as u32);
    let plan = EntryPlan {
        state_type,
        pixel: member(entry::PIXEL),
        terminate: member(entry::TERMINATE),
        out_color: member(entry::OUT_COLOR),
        init_state,
        reset_sample,
        ray_setup,
        samples: handles(&schedule.always),
        gate: entry_gate(comp, &schedule),
        contributing: handles(&schedule.contributing),
        sample_end: handles(&schedule.end),
        ray_finish,
        uniforms: block,
        max_samples: uniforms.iter().position(|u| u.name == MAX_SAMPLES).unwrap_or_default() as u32,
        output,
        region,
        metering,
        geometry,
    };
    let state_layout = b.struct_layout(state_type).unwrap_or_else(empty_layout);
    let block_type = b.module.global_variables[block].ty;
    let uniform_layout = b.struct_layout(block_type).unwrap_or_else(empty_layout);
    let entry_point = entry::build(&mut b.module, &plan);
    let mut module = b.finish();
    module.entry_points.push(entry_point);
    let info = lower::validate(&module, sources, Span::DUMMY)?;
    Ok(ViewModule { module, info, uniforms, uniform_layout, state_layout, bindings })
}

/// The entry point's form of the schedule's gate: its flag and fields as `State` members.
fn entry_gate(comp: &Composition, schedule: &contribution::SampleSchedule) -> Option<entry::EntryGate> {
    let members = |fields: &[usize]| fields.iter().map(|&f| f as u32).collect();
    let flag = |name: &str| comp.field(name).map(|i| i as u32);
    match schedule.gate.as_ref()? {
        contribution::Gate::Contributes => Some(entry::EntryGate::Each { flag: flag(contribution::CONTRIBUTES)? }),
        contribution::Gate::SelectedEach => Some(entry::EntryGate::Each { flag: flag(contribution::SELECTED)? }),
        contribution::Gate::SelectedOnce(replay) => Some(entry::EntryGate::Once {
            flag: flag(contribution::SELECTED)?,
            saved: members(&replay.saved),
            restored: members(&replay.restored),
        }),
    }
}

fn empty_layout() -> StructLayout {
    StructLayout { size: 0, alignment: 1, members: Vec::new() }
}

/// A write-only 2D storage image `name` of `format`.
fn add_storage_image(
    b: &mut ModuleBuilder,
    name: &str,
    format: naga::StorageFormat,
    binding: ResourceBinding,
) -> Handle<naga::GlobalVariable> {
    add_image(b, name, naga::ImageClass::Storage { format, access: naga::StorageAccess::STORE }, binding)
}

/// A 2D image `name` of `class` (with no sampler: read with `textureLoad`, or stored to).
fn add_image(
    b: &mut ModuleBuilder,
    name: &str,
    class: naga::ImageClass,
    binding: ResourceBinding,
) -> Handle<naga::GlobalVariable> {
    let inner = naga::TypeInner::Image { dim: naga::ImageDimension::D2, arrayed: false, class };
    let ty = b.module.types.insert(naga::Type { name: None, inner }, naga::Span::UNDEFINED);
    let var = naga::GlobalVariable {
        name: Some(name.into()),
        space: naga::AddressSpace::Handle,
        binding: Some(binding),
        ty,
        init: None,
        memory_decorations: naga::MemoryDecorations::empty(),
    };
    b.module.global_variables.append(var, naga::Span::UNDEFINED)
}

/// `var<uniform> region: vec4<u32>`: the pixels `x0, y0, x1, y1` (end exclusive) of the output
/// image that a dispatch renders, so an application can render a view in tiles or a part of it.
fn add_region(b: &mut ModuleBuilder, binding: ResourceBinding) -> Handle<naga::GlobalVariable> {
    let inner = naga::TypeInner::Vector { size: naga::VectorSize::Quad, scalar: naga::Scalar::U32 };
    let ty = b.module.types.insert(naga::Type { name: None, inner }, naga::Span::UNDEFINED);
    let var = naga::GlobalVariable {
        name: Some("region".into()),
        space: naga::AddressSpace::Uniform,
        binding: Some(binding),
        ty,
        init: None,
        memory_decorations: naga::MemoryDecorations::empty(),
    };
    b.module.global_variables.append(var, naga::Span::UNDEFINED)
}

/// A synthetic pipeline function that writes the default of every field `select(ray)` picks,
/// lowered like any other so the entry point needs no constants of its own.
fn lower_defaults(
    b: &mut ModuleBuilder,
    program: &hir::Program,
    comp: &Composition,
    state_type: Handle<naga::Type>,
    name: &str,
    select: impl Fn(bool) -> bool,
) -> Result<Handle<naga::Function>, Diagnostic> {
    let state: Vec<hir::StateDecl> = comp
        .fields
        .iter()
        .map(|f| hir::StateDecl {
            name: f.name.clone(),
            ty: f.ty,
            ray: f.ray,
            default: Some(f.default.clone()),
            read: false,
            written: true,
            first_read: None,
            span: f.span,
        })
        .collect();
    let stmts = comp
        .fields
        .iter()
        .enumerate()
        .filter(|(_, f)| select(f.ray))
        .map(|(i, f)| hir::Stmt {
            kind: hir::StmtKind::Assign {
                place: hir::Place { root: hir::PlaceRoot::State(i), path: Vec::new(), ty: f.ty, span: f.span },
                op: AssignOp::Assign,
                value: hir::Expr { kind: hir::ExprKind::Const(f.default.clone()), ty: f.ty, span: f.span },
            },
            span: f.span,
        })
        .collect();
    let pf = hir::PipelineFn {
        name: name.into(),
        module: usize::MAX,
        doc: None,
        placement: hir::Placement {
            kind: PlacementKind::In,
            step: Step::Start,
            substep: None,
            when_active: false,
            span: Span::DUMMY,
        },
        state,
        uniforms: Vec::new(),
        uses: Vec::new(),
        locals: Vec::new(),
        body: std::sync::Arc::new(hir::Block { stmts, span: Span::DUMMY }),
        calls: Vec::new(),
        span: Span::DUMMY,
    };
    let env = PipelineEnv {
        state_type,
        state_members: (0..comp.fields.len() as u32).map(Some).collect(),
        uniforms: Vec::new(),
    };
    b.lower_pipeline_fn(program, &pf, name, &env)
}
