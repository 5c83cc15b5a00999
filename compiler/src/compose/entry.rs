//! The compute entry point of a composed view: one invocation per pixel runs ray setup, the
//! sample loop and ray finish, and stores the pixel's colour.
//!
//! ```wgsl
//! @compute @workgroup_size(8, 8, 1)
//! fn main(@builtin(global_invocation_id) id: vec3<u32>) {
//!     let size = textureDimensions(output);
//!     let p = id.xy + region.xy;        // the dispatch covers `region` of the image
//!     if p.x >= min(region.z, size.x) || p.y >= min(region.w, size.y) { return; }
//!     var state: State;                 // zero, then `init_state` writes every default
//!     init_state(&state);
//!     state.pixel = (vec2f(p) + 0.5) / vec2f(size);
//!     /* ray.setup functions */
//!     var i = 0u;
//!     loop {
//!         if i >= uniforms.max_samples || state.terminate { break; }
//!         reset_sample(&state);         // sample-lifetime fields back to their defaults
//!         /* start .. end functions */
//!         continuing { i = i + 1u; }
//!     }
//!     /* ray.finish functions */
//!     textureStore(output, p, state.out_color);
//! }
//! ```
//! The defaults are written by two synthetic pipeline functions lowered like any other, so the
//! entry point itself needs no constants.
//!
//! With a writer of `contributes` (`compose::contribution`), the loop body becomes
//! ```wgsl
//!         reset_sample(&state);
//!         /* always */
//!         loop {                        // samples that cannot contribute
//!             if state.contributes { break; }
//!             /* end */
//!             i = i + 1u;
//!             if i >= uniforms.max_samples || state.terminate { break; }
//!             reset_sample(&state);
//!             /* always */
//!         }
//!         if !state.contributes { break; } // the ray ended
//!         /* contributing */
//!         /* end */
//! ```

use crate::lower::emitter::Emitter;
use naga::{Expression as E, Handle, Statement as S};

/// What the entry point calls and touches.
pub struct EntryPlan {
    pub state_type: Handle<naga::Type>,
    /// Member indices in `State`; a missing field is simply not touched.
    pub pixel: Option<u32>,
    pub terminate: Option<u32>,
    pub out_color: Option<u32>,
    /// Writes every field's default.
    pub init_state: Handle<naga::Function>,
    /// Writes the defaults of the sample-lifetime fields.
    pub reset_sample: Handle<naga::Function>,
    pub ray_setup: Vec<Handle<naga::Function>>,
    /// The sample functions run for every sample, before the `contributes` test.
    pub samples: Vec<Handle<naga::Function>>,
    /// The flag `contributing` waits for, when some function writes one (`compose::contribution`).
    pub gate: Option<EntryGate>,
    /// Run after `samples` only as `gate` says.
    pub contributing: Vec<Handle<naga::Function>>,
    /// The `end` step: run for every sample, last.
    pub sample_end: Vec<Handle<naga::Function>>,
    pub ray_finish: Vec<Handle<naga::Function>>,
    /// The uniform block and the member index of `max_samples: u32` in it.
    pub uniforms: Handle<naga::GlobalVariable>,
    pub max_samples: u32,
    /// `texture_storage_2d<rgba8unorm, write>`.
    pub output: Handle<naga::GlobalVariable>,
    /// `var<uniform> region: vec4<u32>`: the pixels the dispatch renders.
    pub region: Handle<naga::GlobalVariable>,
    /// The luminance image and the `State` member stored into it after `ray.finish` (when the
    /// composition meters luminance).
    pub metering: Option<(Handle<naga::GlobalVariable>, u32)>,
    /// The mesh layer's images and the `State` members loaded from them before `ray.setup`
    /// (`geometry_depth`, `geometry_color`), for the fields the composition has, with the
    /// member's number of components (1: the texel's first).
    pub geometry: Vec<(Handle<naga::GlobalVariable>, u32, u32)>,
}

/// How the entry point runs the functions that wait for a flag (member indices in `State`).
pub enum EntryGate {
    /// For the samples whose `flag` is true, after `samples`: `contributes`, and `selected` when
    /// the loop reads what they write.
    Each { flag: u32 },
    /// Once after the loop, on the last sample whose `flag` (`selected`) was true: `saved` is
    /// kept at each such sample and put back before they run, `restored` given back its value
    /// from the end of the loop after they ran.
    Once { flag: u32, saved: Vec<u32>, restored: Vec<u32> },
}

pub const WORKGROUP_SIZE: [u32; 3] = [8, 8, 1];

/// The state field the entry point sets to the pixel's centre in [0, 1]^2 before ray setup.
pub(crate) const PIXEL: &str = "pixel";
/// The state field that ends the sample loop when set.
pub(crate) const TERMINATE: &str = "terminate";
/// The state field the entry point stores as the pixel's colour after ray finish.
pub(crate) const OUT_COLOR: &str = "out_color";
/// The state field whose value the entry point also stores, after ray finish, into the view's
/// luminance image (a binding only views with this field get), for automatic exposure.
pub(crate) const METERED_LUMINANCE: &str = "metered_luminance";
/// The state field the entry point loads, before ray setup, from the depth of the view's mesh
/// layer (a binding only views with this field get).
pub const GEOMETRY_DEPTH: &str = "geometry_depth";
/// The state field the entry point loads, before ray setup, from the colour of the view's mesh
/// layer (a binding only views with this field get).
pub const GEOMETRY_COLOR: &str = "geometry_color";
/// The fields the entry point reads or writes itself: kept whenever a placed function declares
/// them, and without data-flow warnings.
pub(crate) const ENTRY_FIELDS: &[&str] = &[
    PIXEL,
    TERMINATE,
    OUT_COLOR,
    METERED_LUMINANCE,
    GEOMETRY_DEPTH,
    GEOMETRY_COLOR,
    super::contribution::CONTRIBUTES,
    super::contribution::SELECTED,
];

/// The entry point's function as it grows, with the emit discipline lowering uses.
struct Body {
    func: naga::Function,
    emitter: Emitter,
}

impl Body {
    fn expr(&mut self, expr: E) -> Handle<E> {
        self.emitter.append(&mut self.func.expressions, expr, naga::Span::UNDEFINED)
    }

    fn push(&mut self, block: &mut naga::Block, stmt: S) {
        self.emitter.push(&self.func.expressions, block, stmt, naga::Span::UNDEFINED);
    }

    fn call(&mut self, block: &mut naga::Block, function: Handle<naga::Function>, state: Handle<E>) {
        self.push(block, S::Call { function, arguments: vec![state], result: None });
    }

    fn literal(&mut self, literal: naga::Literal) -> Handle<E> {
        self.expr(E::Literal(literal))
    }

    fn binary(&mut self, op: naga::BinaryOperator, left: Handle<E>, right: Handle<E>) -> Handle<E> {
        self.expr(E::Binary { op, left, right })
    }

    fn component(&mut self, base: Handle<E>, index: u32) -> Handle<E> {
        self.expr(E::AccessIndex { base, index })
    }

    /// `v.xy`.
    fn xy(&mut self, vector: Handle<E>) -> Handle<E> {
        use naga::SwizzleComponent::{X, Y};
        self.expr(E::Swizzle { size: naga::VectorSize::Bi, vector, pattern: [X, Y, X, X] })
    }

    /// `if cond { break; }` (or `return`).
    fn exit_if(&mut self, block: &mut naga::Block, cond: Handle<E>, exit: S) {
        let mut accept = naga::Block::new();
        accept.push(exit, naga::Span::UNDEFINED);
        self.push(block, S::If { condition: cond, accept, reject: naga::Block::new() });
    }
}

/// `i >= uniforms.max_samples || state.terminate`: the sample loop is over.
fn sample_loop_done(b: &mut Body, plan: &EntryPlan, state: Handle<E>, counter: Handle<E>) -> Handle<E> {
    let i = b.expr(E::Load { pointer: counter });
    let block = b.expr(E::GlobalVariable(plan.uniforms));
    let max_pointer = b.component(block, plan.max_samples);
    let max = b.expr(E::Load { pointer: max_pointer });
    let done = b.binary(naga::BinaryOperator::GreaterEqual, i, max);
    match plan.terminate {
        Some(member) => {
            let terminate = load_member(b, state, member);
            b.binary(naga::BinaryOperator::LogicalOr, done, terminate)
        }
        None => done,
    }
}

/// `state.MEMBER`.
fn load_member(b: &mut Body, state: Handle<E>, member: u32) -> Handle<E> {
    let pointer = b.component(state, member);
    b.expr(E::Load { pointer })
}

/// `i = i + 1u;`
fn increment(b: &mut Body, block: &mut naga::Block, counter: Handle<E>) {
    let i = b.expr(E::Load { pointer: counter });
    let one = b.literal(naga::Literal::U32(1));
    let next = b.binary(naga::BinaryOperator::Add, i, one);
    b.push(block, S::Store { pointer: counter, value: next });
}

/// Builds the entry point `main`; its types are added to `module`. The steps follow the WGSL in
/// the module's documentation, in order (the order of the expressions is the order of their
/// names in the WGSL).
pub fn build(module: &mut naga::Module, plan: &EntryPlan) -> naga::EntryPoint {
    let (mut b, state_var, counter_var) = Body::entry_function(module, plan);
    let mut body = naga::Block::new();
    let Pixel { p, size, output } = b.pixel_in_region(&mut body, plan);
    let state = b.expr(E::LocalVariable(state_var));
    b.call(&mut body, plan.init_state, state);
    if let Some(member) = plan.pixel {
        b.store_pixel_centre(&mut body, state, member, p, size);
    }
    for &(image, member, components) in &plan.geometry {
        b.load_layer_texel(&mut body, state, (image, member, components), p, size);
    }
    for &f in &plan.ray_setup {
        b.call(&mut body, f, state);
    }

    let counter = b.expr(E::LocalVariable(counter_var));
    let zero = b.literal(naga::Literal::U32(0));
    b.push(&mut body, S::Store { pointer: counter, value: zero });
    let mut loop_body = naga::Block::new();
    let done = sample_loop_done(&mut b, plan, state, counter);
    b.exit_if(&mut loop_body, done, S::Break);
    b.call(&mut loop_body, plan.reset_sample, state);
    for &f in &plan.samples {
        b.call(&mut loop_body, f, state);
    }
    if let Some(EntryGate::Each { flag }) = plan.gate {
        skip_non_contributing(&mut b, &mut loop_body, plan, state, counter, flag);
    }
    let kept = match &plan.gate {
        Some(EntryGate::Once { flag, saved, .. }) => {
            let bool_type = add_type(module, naga::TypeInner::Scalar(naga::Scalar::BOOL));
            let types = (plan.state_type, bool_type);
            Some(b.keep_selected(&mut body, &mut loop_body, state, (*flag, saved), types))
        }
        _ => {
            for &f in &plan.contributing {
                b.call(&mut loop_body, f, state);
            }
            None
        }
    };
    for &f in &plan.sample_end {
        b.call(&mut loop_body, f, state);
    }
    let mut continuing = naga::Block::new();
    increment(&mut b, &mut continuing, counter);
    b.push(&mut body, S::Loop { body: loop_body, continuing, break_if: None });
    if let (Some(kept), Some(EntryGate::Once { saved, restored, .. })) = (kept, &plan.gate) {
        b.replay_selected(&mut body, plan, state, kept, saved, restored);
    }

    for &f in &plan.ray_finish {
        b.call(&mut body, f, state);
    }
    write_outputs(&mut b, module, &mut body, plan, state, p, output);
    b.push(&mut body, S::Return { value: None });

    let mut function = b.func;
    function.body = body;
    compute_entry_point(function)
}

/// The samples of a ray that cannot contribute, skipped ([`EntryGate::Each`] with flag `member`).
///
/// Samples that cannot contribute run only `samples` and `sample_end`, in an inner loop that
/// moves on to the next sample until one contributes (or the ray ends): a group of invocations
/// that runs in lockstep (SIMD lanes, a warp) then does the contributing work together rather
/// than each lane in turn, and where lanes only mask code (as on lavapipe) the work is not done
/// for samples that skip it. Every invocation still runs its samples' functions in the same
/// order as with `if contributes { .. }`.
fn skip_non_contributing(
    b: &mut Body,
    loop_body: &mut naga::Block,
    plan: &EntryPlan,
    state: Handle<E>,
    counter: Handle<E>,
    member: u32,
) {
    let mut skipping = naga::Block::new();
    let contributes = load_member(b, state, member);
    b.exit_if(&mut skipping, contributes, S::Break);
    for &f in &plan.sample_end {
        b.call(&mut skipping, f, state);
    }
    increment(b, &mut skipping, counter);
    let done = sample_loop_done(b, plan, state, counter);
    b.exit_if(&mut skipping, done, S::Break);
    b.call(&mut skipping, plan.reset_sample, state);
    for &f in &plan.samples {
        b.call(&mut skipping, f, state);
    }
    b.push(loop_body, S::Loop { body: skipping, continuing: naga::Block::new(), break_if: None });
    // Left without a contributing sample: the ray ended.
    let contributes = load_member(b, state, member);
    let ended = b.expr(E::Unary { op: naga::UnaryOperator::LogicalNot, expr: contributes });
    b.exit_if(loop_body, ended, S::Break);
}

/// The ray's results: `state.out_color` (or zero) into the output image at pixel `p`, and the
/// metered luminance into its image when the view meters.
fn write_outputs(
    b: &mut Body,
    module: &mut naga::Module,
    body: &mut naga::Block,
    plan: &EntryPlan,
    state: Handle<E>,
    p: Handle<E>,
    output: Handle<E>,
) {
    let color = match plan.out_color {
        Some(member) => {
            let pointer = b.component(state, member);
            b.expr(E::Load { pointer })
        }
        None => {
            let vec4f =
                add_type(module, naga::TypeInner::Vector { size: naga::VectorSize::Quad, scalar: naga::Scalar::F32 });
            b.expr(E::ZeroValue(vec4f))
        }
    };
    b.push(body, S::ImageStore { image: output, coordinate: p, array_index: None, value: color });
    if let Some((image, member)) = plan.metering {
        let pointer = b.component(state, member);
        let luminance = b.expr(E::Load { pointer });
        let value = b.expr(E::Splat { size: naga::VectorSize::Quad, value: luminance });
        let image = b.expr(E::GlobalVariable(image));
        b.push(body, S::ImageStore { image, coordinate: p, array_index: None, value });
    }
}

/// The compute entry point `main` running `function`.
fn compute_entry_point(function: naga::Function) -> naga::EntryPoint {
    naga::EntryPoint {
        name: "main".into(),
        stage: naga::ShaderStage::Compute,
        early_depth_test: None,
        workgroup_size: WORKGROUP_SIZE,
        workgroup_size_overrides: None,
        function,
        mesh_info: None,
        task_payload: None,
        incoming_ray_payload: None,
    }
}

fn add_type(module: &mut naga::Module, inner: naga::TypeInner) -> Handle<naga::Type> {
    module.types.insert(naga::Type { name: None, inner }, naga::Span::UNDEFINED)
}

/// The locals of a ray that keeps its selected sample ([`EntryGate::Once`]).
struct Kept {
    /// `kept: State`: the saved fields of the last selected sample.
    state: Handle<E>,
    /// `kept_any: bool`: whether some sample was selected.
    any: Handle<E>,
}

impl Body {
    fn local(&mut self, name: &str, ty: Handle<naga::Type>) -> Handle<E> {
        let var = self
            .func
            .local_variables
            .append(naga::LocalVariable { name: Some(name.into()), ty, init: None }, naga::Span::UNDEFINED);
        self.expr(E::LocalVariable(var))
    }

    /// `to.MEMBER = from.MEMBER;` for each member.
    fn copy_members(&mut self, block: &mut naga::Block, to: Handle<E>, from: Handle<E>, members: &[u32]) {
        for &m in members {
            let value = load_member(self, from, m);
            let pointer = self.component(to, m);
            self.push(block, S::Store { pointer, value });
        }
    }

    /// `kept_any = false;` before the loop, and in the loop after the functions that always run
    /// (`types`: `State` and `bool`):
    /// `if state.FLAG { kept.F = state.F (saved); kept_any = true; }`.
    fn keep_selected(
        &mut self,
        body: &mut naga::Block,
        loop_body: &mut naga::Block,
        state: Handle<E>,
        (flag, saved): (u32, &[u32]),
        types: (Handle<naga::Type>, Handle<naga::Type>),
    ) -> Kept {
        let kept = Kept { state: self.local("kept", types.0), any: self.local("kept_any", types.1) };
        let no = self.literal(naga::Literal::Bool(false));
        self.push(body, S::Store { pointer: kept.any, value: no });
        let mut accept = naga::Block::new();
        self.copy_members(&mut accept, kept.state, state, saved);
        let yes = self.literal(naga::Literal::Bool(true));
        self.push(&mut accept, S::Store { pointer: kept.any, value: yes });
        let selected = load_member(self, state, flag);
        self.push(loop_body, S::If { condition: selected, accept, reject: naga::Block::new() });
        kept
    }

    /// After the loop: `if kept_any { ended = state; state.F = kept.F (saved); WAITING;
    /// state.R = ended.R (restored); }`.
    fn replay_selected(
        &mut self,
        body: &mut naga::Block,
        plan: &EntryPlan,
        state: Handle<E>,
        kept: Kept,
        saved: &[u32],
        restored: &[u32],
    ) {
        let mut accept = naga::Block::new();
        let ended = (!restored.is_empty()).then(|| {
            let ended = self.local("ended", plan.state_type);
            let value = self.expr(E::Load { pointer: state });
            self.push(&mut accept, S::Store { pointer: ended, value });
            ended
        });
        self.copy_members(&mut accept, state, kept.state, saved);
        for &f in &plan.contributing {
            self.call(&mut accept, f, state);
        }
        if let Some(ended) = ended {
            self.copy_members(&mut accept, state, ended, restored);
        }
        let any = self.expr(E::Load { pointer: kept.any });
        self.push(body, S::If { condition: any, accept, reject: naga::Block::new() });
    }
}

/// The pixel an invocation renders, the image's size and the output image.
struct Pixel {
    p: Handle<E>,
    size: Handle<E>,
    output: Handle<E>,
}

impl Body {
    /// `fn main(@builtin(global_invocation_id) id: vec3<u32>)` with its locals `state` and `i`.
    fn entry_function(
        module: &mut naga::Module,
        plan: &EntryPlan,
    ) -> (Body, Handle<naga::LocalVariable>, Handle<naga::LocalVariable>) {
        let vec3u =
            add_type(module, naga::TypeInner::Vector { size: naga::VectorSize::Tri, scalar: naga::Scalar::U32 });
        let u32_ty = add_type(module, naga::TypeInner::Scalar(naga::Scalar::U32));
        let mut func = naga::Function {
            name: Some("main".into()),
            arguments: vec![naga::FunctionArgument {
                name: Some("id".into()),
                ty: vec3u,
                binding: Some(naga::Binding::BuiltIn(naga::BuiltIn::GlobalInvocationId)),
            }],
            ..Default::default()
        };
        let state_var = func.local_variables.append(
            naga::LocalVariable { name: Some("state".into()), ty: plan.state_type, init: None },
            naga::Span::UNDEFINED,
        );
        let counter_var = func
            .local_variables
            .append(naga::LocalVariable { name: Some("i".into()), ty: u32_ty, init: None }, naga::Span::UNDEFINED);
        (Body { func, emitter: Emitter::default() }, state_var, counter_var)
    }

    /// The dispatch covers `region`; pixels past its end or the image's (the last workgroups
    /// overhang both) return at once.
    fn pixel_in_region(&mut self, body: &mut naga::Block, plan: &EntryPlan) -> Pixel {
        use naga::BinaryOperator as Bo;
        let id = self.expr(E::FunctionArgument(0));
        let output = self.expr(E::GlobalVariable(plan.output));
        let size = self.expr(E::ImageQuery { image: output, query: naga::ImageQuery::Size { level: None } });
        let region_pointer = self.expr(E::GlobalVariable(plan.region));
        let region = self.expr(E::Load { pointer: region_pointer });
        let id_xy = self.xy(id);
        let origin = self.xy(region);
        let p = self.binary(Bo::Add, id_xy, origin);
        let mut outside = None;
        for axis in 0..2 {
            let coordinate = self.component(p, axis);
            let region_end = self.component(region, axis + 2);
            let image_end = self.component(size, axis);
            let end = self.expr(E::Math {
                fun: naga::MathFunction::Min,
                arg: region_end,
                arg1: Some(image_end),
                arg2: None,
                arg3: None,
            });
            let past = self.binary(Bo::GreaterEqual, coordinate, end);
            outside = Some(match outside {
                Some(before) => self.binary(Bo::LogicalOr, before, past),
                None => past,
            });
        }
        if let Some(outside) = outside {
            self.exit_if(body, outside, S::Return { value: None });
        }
        Pixel { p, size, output }
    }

    /// `state.pixel = (vec2f(p) + 0.5) / vec2f(size);`
    fn store_pixel_centre(
        &mut self,
        body: &mut naga::Block,
        state: Handle<E>,
        member: u32,
        p: Handle<E>,
        size: Handle<E>,
    ) {
        use naga::BinaryOperator as Bo;
        let p_f = self.expr(E::As { expr: p, kind: naga::ScalarKind::Float, convert: Some(4) });
        let half = self.literal(naga::Literal::F32(0.5));
        let half = self.expr(E::Splat { size: naga::VectorSize::Bi, value: half });
        let centre = self.binary(Bo::Add, p_f, half);
        let size_f = self.expr(E::As { expr: size, kind: naga::ScalarKind::Float, convert: Some(4) });
        let pixel = self.binary(Bo::Divide, centre, size_f);
        let pointer = self.component(state, member);
        self.push(body, S::Store { pointer, value: pixel });
    }

    /// `state.MEMBER = textureLoad(image, min(p * dims / size, dims - 1), 0);` (`.x` for a
    /// scalar member): the texel of a layer image (of any size) under the pixel, so previews
    /// and tiles read the right one.
    fn load_layer_texel(
        &mut self,
        body: &mut naga::Block,
        state: Handle<E>,
        (image, member, components): (Handle<naga::GlobalVariable>, u32, u32),
        p: Handle<E>,
        size: Handle<E>,
    ) {
        use naga::BinaryOperator as Bo;
        let image = self.expr(E::GlobalVariable(image));
        let dims = self.expr(E::ImageQuery { image, query: naga::ImageQuery::Size { level: None } });
        let scaled = self.binary(Bo::Multiply, p, dims);
        let texel = self.binary(Bo::Divide, scaled, size);
        let one = self.literal(naga::Literal::U32(1));
        let one = self.expr(E::Splat { size: naga::VectorSize::Bi, value: one });
        let last = self.binary(Bo::Subtract, dims, one);
        let texel =
            self.expr(E::Math { fun: naga::MathFunction::Min, arg: texel, arg1: Some(last), arg2: None, arg3: None });
        let level = self.literal(naga::Literal::U32(0));
        let texel =
            self.expr(E::ImageLoad { image, coordinate: texel, array_index: None, sample: None, level: Some(level) });
        let value = if components == 1 { self.component(texel, 0) } else { texel };
        let pointer = self.component(state, member);
        self.push(body, S::Store { pointer, value });
    }
}
