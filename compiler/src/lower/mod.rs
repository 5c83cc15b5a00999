//! Lowering: the checked program ([`hir`]) to naga IR, and naga IR to WGSL.
//!
//! A [`ModuleBuilder`] grows one `naga::Module`: it interns types, lays out structs with naga's
//! [`Layouter`] (so the offsets are WGSL's, which the uniform address space accepts), adds the
//! resource globals, and lowers library functions (memoised, callees first) and pipeline
//! functions. How a pipeline function's declarations map onto the module's globals is the
//! caller's choice, given as a [`PipelineEnv`]: the composer builds one module per view with one
//! shared `State` struct and uniform block; [`lower_standalone`] (`vrsc emit`) gives every
//! pipeline function its own struct and bindings.
//!
//! Conventions of the emitted code:
//!
//! - A pipeline function becomes `fn NAME(state: ptr<function, State>)`; `state.f` is
//!   `(*state).f`. A write to a field the environment omits is dropped (the value is pure).
//! - A `volume` is a `texture_3d<f32>` plus a `sampler`, a `tf` a `texture_2d<f32>` of height 1
//!   plus a `sampler`. A library-function parameter of either type becomes two parameters,
//!   `NAME` (the texture) and `NAME_sampler`. `sample(v, p)` is
//!   `textureSampleLevel(v, v_sampler, p, 0.0).x`, `lookup(t, x)` samples at `vec2f(x, 0.5)`
//!   with level 0, `dims(v)` is `textureDimensions(v)`.
//! - `bool` uniforms are stored as `u32` (and `vecN<bool>` as `vecN<u32>`) because `bool` is not
//!   host-shareable; reads convert back with `bool(...)`. See [`host_type`].
//! - `let` becomes a named expression, `var` and loop variables a function-local variable (set by
//!   a store where it is declared, so a `var` in a loop body starts afresh every iteration).
//! - `for i in a .. b` becomes `loop { if i >= b { break; } BODY continuing { i = i + 1; } }`
//!   with `b` evaluated once, before the loop.
//! - Swizzle assignment `v.xz = e` loads `v`, builds the new vector and stores it whole.
//! - Names go through [`emitted_name`]: `$` becomes `_T_` (and naga's own clean-up applies).
//!   Function names are made unique per module, in lowering order: a clash gets the defining VRS
//!   module's index as a prefix (`m1_f`).
//!
//! Every expression and statement carries the span of the HIR node it came from, so a naga
//! validation error maps back to VRS source ([`validate`]); such an error is a compiler bug and
//! comes back as an `E0901` diagnostic, as does any malformed HIR that lowering itself notices.

mod bricked;
pub(crate) mod emitter;
mod func;
mod lookup_interface;
#[cfg(test)]
mod tests;

use rustc_hash::{FxHashMap, FxHashSet};
use std::error::Error as _;

use naga::proc::{Alignment, Layouter};
use naga::{Handle, ResourceBinding};

use crate::diag::{Code, Diagnostic};
use crate::hir;
use crate::source::{SourceMap, Span};
use crate::types::{Scalar, Type};

pub use bricked::{BrickedFns, LookupSource, SegmentFns};

/// An `E0901` diagnostic: something that the checker or composer should have ruled out.
pub(crate) fn internal(span: Span, message: impl Into<String>) -> Diagnostic {
    Diagnostic::new(Code::Internal, span, format!("internal compiler error: {}", message.into()))
        .with_note("this is a bug in vrsc, not in the program being compiled")
}

/// The name under which a VRS name appears in the IR and the WGSL.
///
/// `$` (the template wildcard, left in names only when a template is emitted on its own) becomes
/// `_T_`. naga's WGSL namer collapses runs of `_` and drops a trailing `_`; this function does the
/// same, so the IR name is exactly the WGSL name: `color_$` → `color_T`, `plane_$_a` →
/// `plane_T_a`, `$` → `_T`. A name that ends up empty becomes `unnamed`.
pub fn emitted_name(name: &str) -> String {
    let plain = !name.is_empty() && !name.contains('$') && !name.contains("__") && !name.ends_with('_');
    if plain {
        return name.to_string();
    }
    let replaced = name.replace('$', "_T_");
    let mut out = String::with_capacity(replaced.len());
    for c in replaced.chars() {
        if c == '_' && out.ends_with('_') {
            continue;
        }
        out.push(c);
    }
    while out.ends_with('_') {
        out.pop();
    }
    if out.is_empty() {
        out.push_str("unnamed");
    }
    out
}

/// The type a value of type `t` has in host-shared memory (a uniform block): `bool` becomes
/// `u32`, `vecN<bool>` becomes `vecN<u32>`; everything else is unchanged.
pub fn host_type(t: Type) -> Type {
    match t.scalar() {
        Some(Scalar::Bool) => t.with_scalar(Scalar::U32),
        _ => t,
    }
}

pub(crate) fn naga_scalar(s: Scalar) -> naga::Scalar {
    match s {
        Scalar::Bool => naga::Scalar::BOOL,
        Scalar::I32 => naga::Scalar::I32,
        Scalar::U32 => naga::Scalar::U32,
        Scalar::F32 => naga::Scalar::F32,
    }
}

pub(crate) fn vector_size(n: u8) -> Option<naga::VectorSize> {
    match n {
        2 => Some(naga::VectorSize::Bi),
        3 => Some(naga::VectorSize::Tri),
        4 => Some(naga::VectorSize::Quad),
        _ => None,
    }
}

/// The naga form of a plain VRS type (`None` for `volume`, `tf`, `()` and the error type).
fn plain_inner(t: Type) -> Option<naga::TypeInner> {
    Some(match t {
        Type::Scalar(s) => naga::TypeInner::Scalar(naga_scalar(s)),
        Type::Vector { size, scalar } => {
            naga::TypeInner::Vector { size: vector_size(size)?, scalar: naga_scalar(scalar) }
        }
        Type::Matrix { cols, rows } => {
            naga::TypeInner::Matrix { columns: vector_size(cols)?, rows: vector_size(rows)?, scalar: naga::Scalar::F32 }
        }
        Type::Volume | Type::Tf | Type::Image | Type::Void | Type::Error => return None,
    })
}

/// How a pipeline function's declarations map onto the module's globals.
#[derive(Clone, Debug)]
pub struct PipelineEnv {
    /// The State struct; the function is `fn NAME(state: ptr<function, State>)`.
    pub state_type: Handle<naga::Type>,
    /// Per state declaration of the function (in `PipelineFn::state` order): its member index in
    /// the State struct, or `None` when the field is omitted (writes are dropped; a read is an
    /// internal error).
    pub state_members: Vec<Option<u32>>,
    /// Per uniform declaration of the function (in `PipelineFn::uniforms` order).
    pub uniforms: Vec<UniformAccess>,
}

/// Where a uniform lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UniformAccess {
    /// Member `index` of the uniform block `block` (see [`ModuleBuilder::add_uniform_block`]);
    /// the member has the [`host_type`] of the uniform's type.
    Member { block: Handle<naga::GlobalVariable>, index: u32 },
    /// A `volume`: see [`ModuleBuilder::add_volume_binding`].
    Volume { texture: Handle<naga::GlobalVariable>, sampler: Handle<naga::GlobalVariable> },
    /// A `tf`: see [`ModuleBuilder::add_tf_binding`].
    Tf { texture: Handle<naga::GlobalVariable>, sampler: Handle<naga::GlobalVariable> },
    /// A bricked `volume`: `sample` and `dims` call its lookup ([`ModuleBuilder::add_bricked_volume`]).
    Bricked(BrickedFns),
    /// An `image`: see [`ModuleBuilder::add_image_binding`].
    Image { texture: Handle<naga::GlobalVariable> },
}

/// How a library function receives each of its `volume` and `tf` parameters, in parameter
/// order: as a texture and a sampler (`None`), or as the bricked volume whose lookup it calls
/// (a variant of the function per bricked volume passed, with no parameter for it).
pub type ResourceVariant = Vec<Option<BrickedFns>>;

/// The layout of a struct, for reflection.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StructLayout {
    /// `SizeOf(S)` in WGSL terms: the end of the last member rounded up to the alignment.
    pub size: u32,
    pub alignment: u32,
    pub members: Vec<MemberLayout>,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MemberLayout {
    pub name: String,
    pub offset: u32,
    pub size: u32,
}

/// Builds one naga module. Use one builder with one [`hir::Program`]: library functions are
/// memoised by their [`hir::LibFnId`].
#[derive(Debug, Default)]
pub struct ModuleBuilder {
    pub module: naga::Module,
    layouter: Layouter,
    /// How many types of the arena `layouter` has laid out.
    laid_out: usize,
    /// How many times `layouter` walked the arena (each walk costs the arena's length).
    layout_passes: usize,
    lib_fns: FxHashMap<(hir::LibFnId, ResourceVariant), Handle<naga::Function>>,
    /// Library functions being lowered (to report recursion instead of overflowing the stack).
    in_progress: FxHashSet<hir::LibFnId>,
    function_names: FxHashSet<String>,
}

impl ModuleBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// The naga type of a plain VRS type (scalar, vector, matrix); an internal error otherwise.
    pub fn ty(&mut self, t: Type, span: Span) -> Result<Handle<naga::Type>, Diagnostic> {
        let inner =
            plain_inner(t).ok_or_else(|| internal(span, format!("the type `{t}` reached lowering as a value")))?;
        Ok(self.module.types.insert(naga::Type { name: None, inner }, naga::Span::UNDEFINED))
    }

    /// `texture_3d<f32>` (for a volume) or `texture_2d<f32>` (for a tf).
    pub fn texture_type(&mut self, dim: naga::ImageDimension) -> Handle<naga::Type> {
        let inner = naga::TypeInner::Image {
            dim,
            arrayed: false,
            class: naga::ImageClass::Sampled { kind: naga::ScalarKind::Float, multi: false },
        };
        self.module.types.insert(naga::Type { name: None, inner }, naga::Span::UNDEFINED)
    }

    /// A filtering (non-comparison) `sampler`.
    pub fn sampler_type(&mut self) -> Handle<naga::Type> {
        let inner = naga::TypeInner::Sampler { comparison: false };
        self.module.types.insert(naga::Type { name: None, inner }, naga::Span::UNDEFINED)
    }

    /// `ptr<function, base>`.
    pub(crate) fn function_pointer_type(&mut self, base: Handle<naga::Type>) -> Handle<naga::Type> {
        let inner = naga::TypeInner::Pointer { base, space: naga::AddressSpace::Function };
        self.module.types.insert(naga::Type { name: None, inner }, naga::Span::UNDEFINED)
    }

    /// A struct of plain members laid out by naga's [`Layouter`] (WGSL's layout rules, which
    /// the uniform address space accepts for these member types). Names go through
    /// [`emitted_name`]. WGSL has no empty structs: with no members the struct gets one
    /// `unused: u32` member.
    pub fn add_struct(
        &mut self,
        name: &str,
        members: &[(String, Type)],
        span: Span,
    ) -> Result<Handle<naga::Type>, Diagnostic> {
        let mut tys = Vec::with_capacity(members.len().max(1));
        for (member, t) in members {
            tys.push((emitted_name(member), self.ty(*t, span)?));
        }
        if tys.is_empty() {
            tys.push(("unused".to_string(), self.ty(Type::U32, span)?));
        }
        self.update_layouts(tys.iter().map(|(_, ty)| *ty), span)?;
        let mut offset = 0u32;
        let mut alignment = Alignment::ONE;
        let mut out = Vec::with_capacity(tys.len());
        for (member, ty) in tys {
            let layout = self.layouter[ty];
            offset = layout.alignment.round_up(offset);
            out.push(naga::StructMember { name: Some(member), ty, binding: None, offset });
            offset += layout.size;
            alignment = alignment.max(layout.alignment);
        }
        let inner = naga::TypeInner::Struct { members: out, span: alignment.round_up(offset) };
        // Laid out when asked for ([`Self::struct_layout`]).
        Ok(self.module.types.insert(naga::Type { name: Some(emitted_name(name)), inner }, span.into()))
    }

    /// Lays out the types added since the last layout, unless every type in `needed` already
    /// is. naga's `Layouter::update` walks the type arena from its start to find the new types,
    /// so laying out after every struct made lowering quadratic in the number of structs (each
    /// pipeline function of `vrsc emit` has one).
    fn update_layouts(
        &mut self,
        needed: impl IntoIterator<Item = Handle<naga::Type>>,
        span: Span,
    ) -> Result<(), Diagnostic> {
        if needed.into_iter().all(|ty| ty.index() < self.laid_out) {
            return Ok(());
        }
        self.layouter
            .update(self.module.to_ctx())
            .map_err(|e| internal(span, format!("cannot lay out a type: {e}")))?;
        self.laid_out = self.module.types.len();
        self.layout_passes += 1;
        Ok(())
    }

    /// Offsets and sizes of a struct made by [`Self::add_struct`]; `None` for other types.
    pub fn struct_layout(&mut self, ty: Handle<naga::Type>) -> Option<StructLayout> {
        self.update_layouts([ty], Span::DUMMY).ok()?;
        let t = self.module.types.get_handle(ty).ok()?;
        let naga::TypeInner::Struct { ref members, span } = t.inner else { return None };
        let layout = self.layouter[ty];
        let members = members
            .iter()
            .map(|m| MemberLayout {
                name: m.name.clone().unwrap_or_default(),
                offset: m.offset,
                size: self.layouter[m.ty].size,
            })
            .collect();
        Some(StructLayout { size: span, alignment: layout.alignment * 1, members })
    }

    /// A uniform block: a struct `type_name` of the members' [`host_type`]s, bound as
    /// `@group(g) @binding(b) var<uniform> var_name: type_name;`. Use it with
    /// [`UniformAccess::Member`], indexing `members`.
    pub fn add_uniform_block(
        &mut self,
        type_name: &str,
        var_name: &str,
        members: &[(String, Type)],
        binding: ResourceBinding,
        span: Span,
    ) -> Result<Handle<naga::GlobalVariable>, Diagnostic> {
        let host: Vec<(String, Type)> = members.iter().map(|(n, t)| (n.clone(), host_type(*t))).collect();
        let ty = self.add_struct(type_name, &host, span)?;
        Ok(self.add_global(var_name, naga::AddressSpace::Uniform, ty, binding, span))
    }

    /// The two globals of a `volume` uniform: `NAME: texture_3d<f32>` and `NAME_sampler`.
    pub fn add_volume_binding(
        &mut self,
        name: &str,
        texture: ResourceBinding,
        sampler: ResourceBinding,
        span: Span,
    ) -> UniformAccess {
        let (texture, sampler) = self.add_texture_sampler(name, naga::ImageDimension::D3, texture, sampler, span);
        UniformAccess::Volume { texture, sampler }
    }

    /// The two globals of a `tf` uniform: `NAME: texture_2d<f32>` (height 1) and `NAME_sampler`.
    pub fn add_tf_binding(
        &mut self,
        name: &str,
        texture: ResourceBinding,
        sampler: ResourceBinding,
        span: Span,
    ) -> UniformAccess {
        let (texture, sampler) = self.add_texture_sampler(name, naga::ImageDimension::D2, texture, sampler, span);
        UniformAccess::Tf { texture, sampler }
    }

    /// The global of an `image` uniform: `NAME: texture_2d<f32>`, read with `textureLoad` (no
    /// sampler).
    pub fn add_image_binding(&mut self, name: &str, texture: ResourceBinding, span: Span) -> UniformAccess {
        let tex_ty = self.texture_type(naga::ImageDimension::D2);
        let texture = self.add_global(&emitted_name(name), naga::AddressSpace::Handle, tex_ty, texture, span);
        UniformAccess::Image { texture }
    }

    fn add_texture_sampler(
        &mut self,
        name: &str,
        dim: naga::ImageDimension,
        texture: ResourceBinding,
        sampler: ResourceBinding,
        span: Span,
    ) -> (Handle<naga::GlobalVariable>, Handle<naga::GlobalVariable>) {
        let name = emitted_name(name);
        let tex_ty = self.texture_type(dim);
        let samp_ty = self.sampler_type();
        let texture = self.add_global(&name, naga::AddressSpace::Handle, tex_ty, texture, span);
        let sampler = self.add_global(&format!("{name}_sampler"), naga::AddressSpace::Handle, samp_ty, sampler, span);
        (texture, sampler)
    }

    fn add_global(
        &mut self,
        name: &str,
        space: naga::AddressSpace,
        ty: Handle<naga::Type>,
        binding: ResourceBinding,
        span: Span,
    ) -> Handle<naga::GlobalVariable> {
        let var = naga::GlobalVariable {
            name: Some(emitted_name(name)),
            space,
            binding: Some(binding),
            ty,
            init: None,
            memory_decorations: naga::MemoryDecorations::empty(),
        };
        self.module.global_variables.append(var, span.into())
    }

    /// A function name not used yet in this module: `base`; on a clash `mM_base` (M the index of
    /// the defining VRS module), then `mM_N_base` for N = 2, 3, ... (never a trailing digit, to
    /// which naga's namer would add a `_`).
    fn claim_function_name(&mut self, base: &str, module: usize) -> String {
        let base = emitted_name(base);
        let mut name = base.clone();
        let mut n = 1;
        while !self.function_names.insert(name.clone()) {
            name = if n == 1 { format!("m{module}_{base}") } else { format!("m{module}_{n}_{base}") };
            n += 1;
        }
        name
    }

    /// Lowers library function `id` of `program` (first the library functions it calls), once:
    /// later calls return the same handle.
    pub fn lower_lib_fn(
        &mut self,
        program: &hir::Program,
        id: hir::LibFnId,
        variant: &ResourceVariant,
    ) -> Result<Handle<naga::Function>, Diagnostic> {
        let key = (id, variant.clone());
        if let Some(&h) = self.lib_fns.get(&key) {
            return Ok(h);
        }
        let Some(lf) = program.lib_fns.get(id) else {
            return Err(internal(Span::DUMMY, format!("library function #{id} does not exist")));
        };
        if !self.in_progress.insert(id) {
            return Err(internal(lf.span, format!("library function `{}` calls itself", lf.name)));
        }
        let result = func::lower_lib_fn(self, program, lf, variant);
        self.in_progress.remove(&id);
        let function = result?;
        let h = self.module.functions.append(function, lf.span.into());
        self.lib_fns.insert(key, h);
        Ok(h)
    }

    /// Lowers a pipeline function as `fn NAME(state: ptr<function, State>)` (with `name` made
    /// unique in the module), after every library function it calls.
    pub fn lower_pipeline_fn(
        &mut self,
        program: &hir::Program,
        pf: &hir::PipelineFn,
        name: &str,
        env: &PipelineEnv,
    ) -> Result<Handle<naga::Function>, Diagnostic> {
        let function = func::lower_pipeline_fn(self, program, pf, name, env)?;
        Ok(self.module.functions.append(function, pf.span.into()))
    }

    pub fn finish(self) -> naga::Module {
        self.module
    }
}

/// Lowers every library function and every pipeline function of `program` on its own, for
/// `vrsc emit`.
///
/// Each pipeline function NAME becomes `fn NAME(state: ptr<function, State_NAME>)` over a struct
/// `State_NAME` of its declared fields (in declaration order), reads its plain uniforms from a
/// block `var<uniform> uniforms_NAME: Uniforms_NAME` and its volumes/tfs from their own texture
/// and sampler globals. Bindings are all in `@group(0)`, numbered from 0 in program order: per
/// pipeline function first its uniform block (if it has plain uniforms), then per resource
/// uniform its texture and its sampler. Template names (with `$`) are emitted through
/// [`emitted_name`] (`$` → `_T_`). The module is validated (see [`validate`]).
pub fn lower_standalone(
    program: &hir::Program,
    sources: &SourceMap,
) -> Result<(naga::Module, naga::valid::ModuleInfo), Diagnostic> {
    let mut builder = ModuleBuilder::new();
    for (id, lf) in program.lib_fns.iter().enumerate() {
        let textures = lf.params.iter().filter(|p| p.ty.is_resource()).map(|_| None).collect();
        builder.lower_lib_fn(program, id, &textures)?;
    }
    let mut next_binding = 0u32;
    let mut binding = || {
        let b = ResourceBinding { group: 0, binding: next_binding };
        next_binding += 1;
        b
    };
    for pf in &program.pipelines {
        let name = emitted_name(&pf.name);
        let fields: Vec<(String, Type)> = pf.state.iter().map(|s| (s.name.clone(), s.ty)).collect();
        let state_type = builder.add_struct(&format!("State_{name}"), &fields, pf.span)?;
        let plain: Vec<(String, Type)> =
            pf.uniforms.iter().filter(|u| !u.ty.is_resource()).map(|u| (u.name.clone(), u.ty)).collect();
        let block = if plain.is_empty() {
            None
        } else {
            let b = binding();
            Some(builder.add_uniform_block(
                &format!("Uniforms_{name}"),
                &format!("uniforms_{name}"),
                &plain,
                b,
                pf.span,
            )?)
        };
        let mut uniforms = Vec::with_capacity(pf.uniforms.len());
        let mut index = 0;
        for u in &pf.uniforms {
            uniforms.push(match (u.ty, block) {
                (Type::Volume, _) => builder.add_volume_binding(&u.name, binding(), binding(), u.span),
                (Type::Tf, _) => builder.add_tf_binding(&u.name, binding(), binding(), u.span),
                (Type::Image, _) => builder.add_image_binding(&u.name, binding(), u.span),
                (_, Some(block)) => {
                    index += 1;
                    UniformAccess::Member { block, index: index - 1 }
                }
                (_, None) => return Err(internal(u.span, "a plain uniform without a uniform block")),
            });
        }
        let env = PipelineEnv { state_type, state_members: (0..pf.state.len() as u32).map(Some).collect(), uniforms };
        builder.lower_pipeline_fn(program, pf, &name, &env)?;
    }
    let fallback = program
        .pipelines
        .first()
        .map(|p| p.span)
        .or_else(|| program.lib_fns.first().map(|f| f.span))
        .unwrap_or_default();
    let module = builder.finish();
    let info = validate(&module, sources, fallback)?;
    Ok((module, info))
}

/// Validates a module with every check naga has and no optional capability. A failure is a
/// compiler bug: it comes back as an `E0901` diagnostic at the most specific naga span that lies
/// in a source file (else at `fallback`), with the other spans as secondary labels.
pub fn validate(
    module: &naga::Module,
    sources: &SourceMap,
    fallback: Span,
) -> Result<naga::valid::ModuleInfo, Diagnostic> {
    let mut validator =
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty());
    validator.validate(module).map_err(|err| validation_diagnostic(&err, sources, fallback))
}

fn validation_diagnostic(
    err: &naga::WithSpan<naga::valid::ValidationError>,
    sources: &SourceMap,
    fallback: Span,
) -> Diagnostic {
    let mut message = err.as_inner().to_string();
    let mut source = err.as_inner().source();
    while let Some(s) = source {
        message.push_str(": ");
        message.push_str(&s.to_string());
        source = s.source();
    }
    let mut spans: Vec<(Span, String)> = err
        .spans()
        .filter_map(|(span, label)| span.to_range().map(|r| (Span::from(r), label.clone())))
        .filter(|(span, _)| sources.file_of(span.start).is_some())
        .collect();
    // naga lists the outer context (the function) first and the culprit last.
    let (primary, label) = spans.pop().unwrap_or((fallback, String::new()));
    let label = if label.is_empty() { String::new() } else { format!("lowered to {label}") };
    let mut diag = internal(primary, format!("the generated IR did not validate: {message}")).with_label(label);
    for (span, label) in spans.into_iter().rev() {
        diag = diag.with_secondary(span, format!("lowered to {label}"));
    }
    diag
}

/// Writes a validated module as WGSL text.
pub fn write_wgsl(module: &naga::Module, info: &naga::valid::ModuleInfo) -> Result<String, Diagnostic> {
    naga::back::wgsl::write_string(module, info, naga::back::wgsl::WriterFlags::empty())
        .map_err(|e| internal(Span::DUMMY, format!("the WGSL writer failed: {e}")))
}
