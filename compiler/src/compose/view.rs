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
use super::segment;
use crate::ast::{AssignOp, PlacementKind};
use crate::diag::Diagnostic;
use crate::hir::{self, ConstValue, ScalarValue};
use crate::lower::{self, LookupSource, ModuleBuilder, PipelineEnv, StructLayout, UniformAccess};
use crate::source::{SourceMap, Span};
use crate::steps::Step;
use crate::types::{Scalar, Type};
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
/// order its WGSL reads (state, uniforms, bindings, functions step by step, entry point), so
/// that the order is visible here.
pub fn emit(
    program: &hir::Program,
    comp: &Composition,
    sources: &SourceMap,
    bricked: &[(String, LookupSource<'_>)],
) -> Result<ViewModule, Diagnostic> {
    let mut b = ModuleBuilder::new();
    let uniforms = block_uniforms(comp);
    let ModuleHead { state_type, block, output, region, access, mut bindings } =
        ModuleHead::emit(&mut b, comp, &uniforms, bricked)?;
    // `max_samples` is always a member.
    let block = block.ok_or_else(|| lower::internal(Span::DUMMY, "a view without a uniform block"))?;
    // Last of the bindings, so a view that does not meter keeps its numbering.
    let metering = add_metering_image(&mut b, &mut bindings, comp);
    let geometry = add_geometry_images(&mut b, &mut bindings, comp);
    let history = add_history_buffer(&mut b, &mut bindings, comp);

    let steps = StepLowering { program, comp, state_type, access: &access };
    let ray_setup = steps.lower(&mut b, &[Step::RaySetup])?;
    let sample_steps: Vec<Step> = Step::ALL.iter().copied().filter(|s| s.is_sample_step()).collect();
    let lowered_samples = steps.lower(&mut b, &sample_steps)?;
    // The entry point runs them in the order of the contribution schedule.
    let sample_fns: Vec<(Step, usize)> =
        sample_steps.iter().flat_map(|&s| (0..comp.step(s).len()).map(move |i| (s, i))).collect();
    let schedule = contribution::schedule(program, comp);
    let handles = |fns: &[(Step, usize)]| -> Vec<Handle<naga::Function>> {
        fns.iter().filter_map(|f| sample_fns.iter().position(|g| g == f).map(|k| lowered_samples[k])).collect()
    };
    let ray_finish = steps.lower(&mut b, &[Step::RayFinish])?;

    let init_state = lower_defaults(&mut b, program, comp, state_type, "init_state", |_| true)?;
    let reset_sample = lower_defaults(&mut b, program, comp, state_type, "reset_sample", |ray| !ray)?;
    let member = |name: &str| comp.field(name).map(|i| i as u32);
    let (samples, contributing, sample_end) =
        (handles(&schedule.always), handles(&schedule.contributing), handles(&schedule.end));
    let bricked_fns: Vec<_> = access
        .iter()
        .filter_map(|a| match a {
            UniformAccess::Bricked(fns) => Some(*fns),
            _ => None,
        })
        .collect();
    let segment = segment::variants(&mut b.module, &bricked_fns, [&samples, &contributing, &sample_end]).map(|s| {
        let groups = [&schedule.always, &schedule.contributing, &schedule.end];
        let before_check = groups.iter().zip(s.run_before_last_check()).flat_map(|(g, n)| g[..n].iter().copied());
        let saved = contribution::ray_fields_written_by(program, comp, before_check).into_iter();
        segment::SegmentVariants { saved: saved.map(|f| f as u32).collect(), ..s }
    });
    let plan = EntryPlan {
        state_type,
        segment,
        pixel: member(entry::PIXEL),
        terminate: member(entry::TERMINATE),
        out_color: member(entry::OUT_COLOR),
        init_state,
        reset_sample,
        ray_setup,
        samples,
        gate: entry_gate(comp, &schedule),
        contributing,
        sample_end,
        ray_finish,
        uniforms: block,
        max_samples: block_member(&uniforms, MAX_SAMPLES, Span::DUMMY)?,
        output,
        region,
        metering,
        geometry,
        history,
    };
    let parts = (state_type, Some(block), uniforms, bindings);
    finish_module(b, parts, |module| entry::build(module, &plan), sources)
}

/// What every compute shader of a view begins with, in binding order: the `State` struct of
/// the composition's fields, the uniform block (none without plain uniforms), the output image,
/// the `region`, then the bindings of the composition's resource uniforms.
pub(super) struct ModuleHead {
    pub(super) state_type: Handle<naga::Type>,
    pub(super) block: Option<Handle<naga::GlobalVariable>>,
    pub(super) output: Handle<naga::GlobalVariable>,
    pub(super) region: Handle<naga::GlobalVariable>,
    /// How the lowered functions reach each uniform of the composition.
    pub(super) access: Vec<UniformAccess>,
    pub(super) bindings: Bindings,
}

impl ModuleHead {
    /// Adds the head to `b`: `uniforms` are the block's members, `bricked` the lookups of the
    /// bricked volumes.
    pub(super) fn emit(
        b: &mut ModuleBuilder,
        comp: &Composition,
        uniforms: &[Uniform],
        bricked: &[(String, LookupSource<'_>)],
    ) -> Result<ModuleHead, Diagnostic> {
        let fields: Vec<(String, Type)> = comp.fields.iter().map(|f| (f.name.clone(), f.ty)).collect();
        let state_type = b.add_struct("State", &fields, Span::DUMMY)?;
        let mut bindings = Bindings::default();
        let block = if uniforms.is_empty() {
            None
        } else {
            let members: Vec<(String, Type)> = uniforms.iter().map(|u| (u.name.clone(), u.ty)).collect();
            let binding = bindings.next("uniforms", BindingKind::UniformBlock);
            Some(b.add_uniform_block("Uniforms", "uniforms", &members, binding, Span::DUMMY)?)
        };
        let output_binding = bindings.next("output", BindingKind::OutputImage);
        let output = add_storage_image(b, "output", naga::StorageFormat::Rgba8Unorm, output_binding);
        let region = add_region(b, bindings.next("region", BindingKind::Region));
        let access = bind_uniforms(b, &mut bindings, (comp, uniforms), block, bricked)?;
        Ok(ModuleHead { state_type, block, output, region, access, bindings })
    }
}

/// Finishes the module of `b`: the layouts of its state and uniform block (`parts`: the state
/// type, the block, its uniforms and every binding), the entry point `entry` builds, validation.
pub(super) fn finish_module(
    mut b: ModuleBuilder,
    (state_type, block, uniforms, bindings): (
        Handle<naga::Type>,
        Option<Handle<naga::GlobalVariable>>,
        Vec<Uniform>,
        Bindings,
    ),
    entry: impl FnOnce(&mut naga::Module) -> naga::EntryPoint,
    sources: &SourceMap,
) -> Result<ViewModule, Diagnostic> {
    let state_layout = b.struct_layout(state_type).unwrap_or_else(empty_layout);
    let block_type = block.map(|block| b.module.global_variables[block].ty);
    let uniform_layout = block_type.and_then(|ty| b.struct_layout(ty)).unwrap_or_else(empty_layout);
    let entry_point = entry(&mut b.module);
    let mut module = b.finish();
    module.entry_points.push(entry_point);
    let info = lower::validate(&module, sources, Span::DUMMY)?;
    Ok(ViewModule { module, info, uniforms, uniform_layout, state_layout, bindings: bindings.list })
}

/// The uniforms of the block, in its order: the composition's plain uniforms, then
/// [`MAX_SAMPLES`] when no function declares it.
fn block_uniforms(comp: &Composition) -> Vec<Uniform> {
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
    uniforms
}

/// The member of the uniform block that holds uniform `name`. The block holds every plain
/// uniform of the composition, so a missing one is a compiler bug, not a default.
fn block_member(uniforms: &[Uniform], name: &str, span: Span) -> Result<u32, Diagnostic> {
    match uniforms.iter().position(|u| u.name == name) {
        Some(index) => Ok(index as u32),
        None => Err(lower::internal(span, format!("uniform `{name}` is not in the uniform block"))),
    }
}

/// The bindings of a view, numbered in the order they are added (all in group 0).
#[derive(Default)]
pub(super) struct Bindings {
    pub(super) list: Vec<BindingInfo>,
}

impl Bindings {
    /// The next binding, for `name`'s resource of `kind`.
    pub(super) fn next(&mut self, name: &str, kind: BindingKind) -> ResourceBinding {
        let binding = self.list.len() as u32;
        self.list.push(BindingInfo { name: name.to_string(), group: 0, binding, kind });
        ResourceBinding { group: 0, binding }
    }
}

/// How the lowered functions reach each uniform of the composition, in its order: a member of
/// the uniform block `block` (whose members are `uniforms`), or the bindings of a volume
/// (bricked when `bricked` names its lookup), a transfer function or an image (a filter's
/// input buffer, [`image_binding_kind`]).
pub(super) fn bind_uniforms(
    b: &mut ModuleBuilder,
    bindings: &mut Bindings,
    (comp, uniforms): (&Composition, &[Uniform]),
    block: Option<Handle<naga::GlobalVariable>>,
    bricked: &[(String, LookupSource<'_>)],
) -> Result<Vec<UniformAccess>, Diagnostic> {
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
                let globals = kinds.map(|k| bindings.next(&u.name, k));
                UniformAccess::Bricked(b.add_bricked_volume(&u.name, globals, u.span, *lookup)?)
            }
            Type::Volume => b.add_volume_binding(
                &u.name,
                bindings.next(&u.name, BindingKind::VolumeTexture),
                bindings.next(&u.name, BindingKind::VolumeSampler),
                u.span,
            ),
            Type::Tf => b.add_tf_binding(
                &u.name,
                bindings.next(&u.name, BindingKind::TfTexture),
                bindings.next(&u.name, BindingKind::TfSampler),
                u.span,
            ),
            Type::Image => {
                let kind = image_binding_kind(&u.name)
                    .ok_or_else(|| lower::internal(u.span, format!("`{}` is no buffer of a picture", u.name)))?;
                b.add_image_binding(&u.name, bindings.next(&u.name, kind), u.span)
            }
            _ => match block {
                Some(block) => UniformAccess::Member { block, index: block_member(uniforms, &u.name, u.span)? },
                None => return Err(lower::internal(u.span, "a plain uniform without a uniform block")),
            },
        });
    }
    Ok(access)
}

/// The buffer of a view's picture that the `image` uniform `name` reads, if it names one:
/// `picture` (its colour) or `picture_depth` (its mesh layer's depth), read by filters, or
/// `mesh_shadow_map_NAME` (a shadow group's shadow map), read by the ray pipeline.
pub fn image_binding_kind(name: &str) -> Option<BindingKind> {
    match name {
        PICTURE => Some(BindingKind::Picture),
        PICTURE_DEPTH => Some(BindingKind::GeometryDepth),
        _ if name.strip_prefix(MESH_SHADOW_MAP_PREFIX).is_some_and(|light| !light.is_empty()) => {
            Some(BindingKind::MeshShadowMap)
        }
        _ => None,
    }
}

/// The `image` uniform of the ray pipeline that reads the shadow map of the shadow group
/// following light NAME is this prefix and NAME (`std::mesh_shadow`).
pub const MESH_SHADOW_MAP_PREFIX: &str = "mesh_shadow_map_";

/// The `image` uniform of a filter pass that reads the view's picture (premultiplied colour).
pub const PICTURE: &str = "picture";
/// The `image` uniform of a filter pass that reads the depth of the view's mesh layer.
pub const PICTURE_DEPTH: &str = "picture_depth";

/// The metering image and the `State` member it stores, when the composition meters luminance.
fn add_metering_image(
    b: &mut ModuleBuilder,
    bindings: &mut Bindings,
    comp: &Composition,
) -> Option<(Handle<naga::GlobalVariable>, u32)> {
    comp.field(entry::METERED_LUMINANCE).map(|member| {
        let format = naga::StorageFormat::R32Float;
        let binding = bindings.next("luminance_image", BindingKind::LuminanceImage);
        (add_storage_image(b, "luminance_image", format, binding), member as u32)
    })
}

/// After the luminance image: the mesh layer's images, for the fields the composition has, each
/// with the `State` members loaded from it. All are read with `textureLoad` (a depth texture
/// cannot be loaded in every back end's compute shaders; the layer keeps its depths as
/// `r32float` colour): `geometry_depth` and `geometry_color` from a `texture_2d<f32>` each, the
/// translucent layers' depths and colours from a `texture_2d_array<f32>` each, layer N into
/// field N.
fn add_geometry_images(b: &mut ModuleBuilder, bindings: &mut Bindings, comp: &Composition) -> Vec<entry::LayerLoad> {
    let images: [(&str, &[&str], BindingKind); 4] = [
        (entry::GEOMETRY_DEPTH, &[entry::GEOMETRY_DEPTH], BindingKind::GeometryDepth),
        (entry::GEOMETRY_COLOR, &[entry::GEOMETRY_COLOR], BindingKind::GeometryColor),
        ("translucent_depth", &entry::TRANSLUCENT_DEPTH, BindingKind::TranslucentDepth),
        ("translucent_color", &entry::TRANSLUCENT_COLOR, BindingKind::TranslucentColor),
    ];
    let class = naga::ImageClass::Sampled { kind: naga::ScalarKind::Float, multi: false };
    let mut loads = Vec::new();
    for (name, fields, kind) in images {
        let members: Vec<(Option<u32>, u32)> = (0u32..)
            .zip(fields)
            .filter_map(|(layer, field)| Some(((fields.len() > 1).then_some(layer), comp.field(field)? as u32)))
            .collect();
        if members.is_empty() {
            continue;
        }
        let arrayed = fields.len() > 1;
        let image = add_image(b, &format!("{name}_image"), (class, arrayed), bindings.next(name, kind));
        loads.extend(members.into_iter().map(|(layer, member)| entry::LayerLoad {
            image,
            layer,
            member,
            components: comp.fields[member as usize].ty.components() as u32,
        }));
    }
    loads
}

/// After the mesh layer's images: the pixels' history across frames, when the composition has a
/// `history: vec4f` field (and, beside it, `history_samples: f32`): `var<storage, read_write>
/// history: array<vec4f>`, two elements per pixel of the target.
fn add_history_buffer(
    b: &mut ModuleBuilder,
    bindings: &mut Bindings,
    comp: &Composition,
) -> Option<entry::HistoryPlan> {
    let typed = |name: &str, ty: Type| comp.field(name).filter(|&i| comp.fields[i].ty == ty).map(|i| i as u32);
    let mean = typed(entry::HISTORY, Type::Vector { size: 4, scalar: Scalar::F32 })?;
    let samples = typed(entry::HISTORY_SAMPLES, Type::Scalar(Scalar::F32));
    let binding = bindings.next("history", BindingKind::History);
    let vec4f = naga::TypeInner::Vector { size: naga::VectorSize::Quad, scalar: naga::Scalar::F32 };
    let vec4f = b.module.types.insert(naga::Type { name: None, inner: vec4f }, naga::Span::UNDEFINED);
    let array = naga::TypeInner::Array { base: vec4f, size: naga::ArraySize::Dynamic, stride: 16 };
    let ty = b.module.types.insert(naga::Type { name: None, inner: array }, naga::Span::UNDEFINED);
    let var = naga::GlobalVariable {
        name: Some("history".into()),
        space: naga::AddressSpace::Storage { access: naga::StorageAccess::LOAD | naga::StorageAccess::STORE },
        binding: Some(binding),
        ty,
        init: None,
        memory_decorations: naga::MemoryDecorations::empty(),
    };
    let buffer = b.module.global_variables.append(var, naga::Span::UNDEFINED);
    Some(entry::HistoryPlan { buffer, mean, samples })
}

/// What lowering the placed pipeline functions of a step needs.
pub(super) struct StepLowering<'a> {
    pub(super) program: &'a hir::Program,
    pub(super) comp: &'a Composition,
    pub(super) state_type: Handle<naga::Type>,
    pub(super) access: &'a [UniformAccess],
}

impl StepLowering<'_> {
    /// The functions placed in `steps`, lowered in order.
    pub(super) fn lower(
        &self,
        b: &mut ModuleBuilder,
        steps: &[Step],
    ) -> Result<Vec<Handle<naga::Function>>, Diagnostic> {
        let mut out = Vec::new();
        for placed in steps.iter().flat_map(|&s| self.comp.step(s)) {
            let pf = &self.program.pipelines[placed.pipeline];
            let env = PipelineEnv {
                state_type: self.state_type,
                state_members: placed.state.iter().map(|m| m.map(|i| i as u32)).collect(),
                uniforms: placed.uniforms.iter().map(|&u| self.access[u]).collect(),
            };
            out.push(b.lower_pipeline_fn(self.program, pf, &placed.name, &env)?);
        }
        Ok(out)
    }
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

pub(super) fn empty_layout() -> StructLayout {
    StructLayout { size: 0, alignment: 1, members: Vec::new() }
}

/// A write-only 2D storage image `name` of `format`.
pub(super) fn add_storage_image(
    b: &mut ModuleBuilder,
    name: &str,
    format: naga::StorageFormat,
    binding: ResourceBinding,
) -> Handle<naga::GlobalVariable> {
    add_image(b, name, (naga::ImageClass::Storage { format, access: naga::StorageAccess::STORE }, false), binding)
}

/// A 2D image `name` of `class` (with no sampler: read with `textureLoad`, or stored to).
fn add_image(
    b: &mut ModuleBuilder,
    name: &str,
    (class, arrayed): (naga::ImageClass, bool),
    binding: ResourceBinding,
) -> Handle<naga::GlobalVariable> {
    let inner = naga::TypeInner::Image { dim: naga::ImageDimension::D2, arrayed, class };
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
pub(super) fn add_region(b: &mut ModuleBuilder, binding: ResourceBinding) -> Handle<naga::GlobalVariable> {
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
pub(super) fn lower_defaults(
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
