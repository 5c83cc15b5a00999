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
//!     /* the mesh layer's texels; the pixel's history: state.history = history[2i], ... */
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
//!     /* the history stored back (a progressive view: `HistoryPlan`) */
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
//!
//! With bricked volumes whose lookup marches brick by brick (`compose::segment`), the sample
//! loop becomes two: a sample taken with full lookups opens each volume's segment (the brick
//! its first lookup found), and the samples after it read the segments through the functions'
//! variants until one reads outside a segment; that sample is taken back (`state` and `i` as
//! they were before it) and taken again with full lookups:
//! ```wgsl
//!     loop {
//!         if i >= uniforms.max_samples || state.terminate { break; }
//!         reset_sample(&state);
//!         volume_segment_start();       // for each bricked volume
//!         /* start .. end functions, one sample (`if state.contributes { .. }` with a gate) */
//!         i = i + 1u;
//!         loop {
//!             if i >= uniforms.max_samples || state.terminate { break; }
//!             saved.F = state.F; saved_i = i; missed = false; // @ray fields written before
//!             reset_sample(&state);                           // the last check
//!             /* start .. end functions' segment variants; in each group of them, right after
//!                the last that reads a segment: */
//!             missed = volume_segment_missed();
//!             if missed { state.F = saved.F; i = saved_i; break; }
//!             continuing { i = i + 1u; }
//!         }
//!     }
//! ```
//! Software rasterizers that run both sides of a branch for a group of pixels (lavapipe) do
//! leave a loop that no lane continues, so the full lookup runs once per brick a ray crosses.

use super::segment::SegmentVariants;
use crate::lower::emitter::Emitter;
use naga::{Expression as E, Handle, Statement as S};

/// What the entry point calls and touches.
pub struct EntryPlan {
    pub state_type: Handle<naga::Type>,
    /// The segment march of bricked volumes: the variants of the sample functions that read
    /// segments (`compose::segment`), when a view has one.
    pub segment: Option<SegmentVariants>,
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
    /// The `State` members loaded from the mesh layer's images before `ray.setup`
    /// (`geometry_depth`, `geometry_color`, the translucent layers), for the fields the
    /// composition has.
    pub geometry: Vec<LayerLoad>,
    /// The pixel's history across frames, when the composition keeps one (a progressive view).
    pub history: Option<HistoryPlan>,
}

/// The `State` members the entry point loads from the pixel's history before `ray.setup` and
/// stores back after `ray.finish`: [`HISTORY`] from element `2 i` of the buffer and
/// [`HISTORY_SAMPLES`] from the first component of element `2 i + 1`, `i` the pixel's index in
/// the target (row after row).
#[derive(Clone, Copy, Debug)]
pub struct HistoryPlan {
    /// `var<storage, read_write> history: array<vec4f>`.
    pub buffer: Handle<naga::GlobalVariable>,
    pub mean: u32,
    pub samples: Option<u32>,
}

/// A `State` member the entry point loads from a texel of a mesh layer's image.
#[derive(Clone, Copy, Debug)]
pub struct LayerLoad {
    /// A `texture_2d<f32>`, or a `texture_2d_array<f32>` read at `layer`.
    pub image: Handle<naga::GlobalVariable>,
    pub layer: Option<u32>,
    pub member: u32,
    /// The member's number of components (1: the texel's first).
    pub components: u32,
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
/// The state fields the entry point loads, before ray setup, from the depths of the view's
/// translucent layers, nearest first (a binding only views with one of them get).
pub const TRANSLUCENT_DEPTH: [&str; TRANSLUCENT_LAYERS] =
    ["translucent_depth_0", "translucent_depth_1", "translucent_depth_2", "translucent_depth_3"];
/// The state fields the entry point loads, before ray setup, from the colours of the view's
/// translucent layers, nearest first (a binding only views with one of them get).
pub const TRANSLUCENT_COLOR: [&str; TRANSLUCENT_LAYERS] =
    ["translucent_color_0", "translucent_color_1", "translucent_color_2", "translucent_color_3"];
/// The `vec4f` state field the entry point loads from the pixel's history before ray setup and
/// stores back after ray finish (a binding only views with this field get): what a progressive
/// view (the path tracer) averages over frames.
pub const HISTORY: &str = "history";
/// The `f32` state field kept beside [`HISTORY`]: the number of frames in it (0 after the
/// runtime cleared the history).
pub const HISTORY_SAMPLES: &str = "history_samples";
/// How many layers of translucent surfaces the mesh layer peels for the volume layer.
pub const TRANSLUCENT_LAYERS: usize = 4;
/// `texel: vec2i`: a filter pass's pixel, as integer coordinates in its picture (x right, y
/// down), set by the filter entry point.
pub const TEXEL: &str = "texel";

/// The fields the entry point of a filter pass reads or writes itself.
pub(crate) const FILTER_ENTRY_FIELDS: &[&str] = &[PIXEL, TEXEL, OUT_COLOR];

/// The fields the entry point reads or writes itself: kept whenever a placed function declares
/// them, and without data-flow warnings.
pub(crate) const ENTRY_FIELDS: &[&str] = &[
    PIXEL,
    TERMINATE,
    OUT_COLOR,
    METERED_LUMINANCE,
    GEOMETRY_DEPTH,
    GEOMETRY_COLOR,
    TRANSLUCENT_DEPTH[0],
    TRANSLUCENT_DEPTH[1],
    TRANSLUCENT_DEPTH[2],
    TRANSLUCENT_DEPTH[3],
    TRANSLUCENT_COLOR[0],
    TRANSLUCENT_COLOR[1],
    TRANSLUCENT_COLOR[2],
    TRANSLUCENT_COLOR[3],
    HISTORY,
    HISTORY_SAMPLES,
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
    let images = (plan.output, plan.region);
    let (Pixel { p, size, output }, state) = b.begin_pixel(&mut body, images, (state_var, plan.init_state), plan.pixel);
    for load in &plan.geometry {
        b.load_layer_texel(&mut body, state, load, p, size);
    }
    let history = plan.history.map(|h| (h, b.history_index(p, size)));
    if let Some((h, index)) = history {
        b.move_history(&mut body, state, h, index, HistoryMove::Load);
    }
    for &f in &plan.ray_setup {
        b.call(&mut body, f, state);
    }

    let counter = b.expr(E::LocalVariable(counter_var));
    let zero = b.literal(naga::Literal::U32(0));
    b.push(&mut body, S::Store { pointer: counter, value: zero });
    let bool_type = add_type(module, naga::TypeInner::Scalar(naga::Scalar::BOOL));
    let kept = match &plan.gate {
        Some(EntryGate::Once { .. }) => Some(b.kept_locals(&mut body, (plan.state_type, bool_type))),
        _ => None,
    };
    let loops = Loops { plan, state, counter, kept: kept.as_ref() };
    let sample_loop = match &plan.segment {
        None => loops.single(&mut b),
        Some(segment) => {
            let u32_type = add_type(module, naga::TypeInner::Scalar(naga::Scalar::U32));
            let saved = Saved {
                state: b.local("saved", plan.state_type),
                members: segment.saved.clone(),
                counter: b.local("saved_i", u32_type),
                missed: b.local("missed", bool_type),
            };
            loops.segmented(&mut b, segment, &saved)
        }
    };
    b.push(&mut body, sample_loop);
    if let (Some(kept), Some(EntryGate::Once { saved, restored, .. })) = (kept, &plan.gate) {
        b.replay_selected(&mut body, plan, state, kept, saved, restored);
    }

    for &f in &plan.ray_finish {
        b.call(&mut body, f, state);
    }
    write_outputs(&mut b, module, &mut body, plan, state, p, output);
    if let Some((h, index)) = history {
        b.move_history(&mut body, state, h, index, HistoryMove::Store);
    }
    b.push(&mut body, S::Return { value: None });

    let mut function = b.func;
    function.body = body;
    compute_entry_point(function)
}

/// What the entry point of a filter pass runs (`compose::filter`).
pub struct FilterEntryPlan {
    pub state_type: Handle<naga::Type>,
    /// Writes every field's default.
    pub init_state: Handle<naga::Function>,
    /// Member indices in `State` of [`PIXEL`] (the pixel's centre in [0,1]^2), [`TEXEL`] (its
    /// integer position) and [`OUT_COLOR`]; a missing field is simply not touched.
    pub pixel: Option<u32>,
    pub texel: Option<u32>,
    pub out_color: Option<u32>,
    /// The functions of `filter.setup`, `filter.apply` and `filter.finish`, in order.
    pub functions: Vec<Handle<naga::Function>>,
    /// `texture_storage_2d<rgba8unorm, write>`: the filtered picture.
    pub output: Handle<naga::GlobalVariable>,
    /// `var<uniform> region: vec4<u32>`: the pixels the dispatch filters.
    pub region: Handle<naga::GlobalVariable>,
}

/// The entry point of a filter pass: per pixel of the region, the state's defaults, its
/// position, the filter functions in order, and `out_color` into the output image.
pub fn build_filter(module: &mut naga::Module, plan: &FilterEntryPlan) -> naga::EntryPoint {
    let (mut b, state_var, _) = Body::entry_function_of(module, plan.state_type);
    let mut body = naga::Block::new();
    let images = (plan.output, plan.region);
    let (Pixel { p, size: _, output }, state) =
        b.begin_pixel(&mut body, images, (state_var, plan.init_state), plan.pixel);
    if let Some(member) = plan.texel {
        let texel = b.expr(E::As { expr: p, kind: naga::ScalarKind::Sint, convert: Some(4) });
        let pointer = b.component(state, member);
        b.push(&mut body, S::Store { pointer, value: texel });
    }
    for &f in &plan.functions {
        b.call(&mut body, f, state);
    }
    let color = match plan.out_color {
        Some(member) => load_member(&mut b, state, member),
        None => {
            let vec4f =
                add_type(module, naga::TypeInner::Vector { size: naga::VectorSize::Quad, scalar: naga::Scalar::F32 });
            b.expr(E::ZeroValue(vec4f))
        }
    };
    b.push(&mut body, S::ImageStore { image: output, coordinate: p, array_index: None, value: color });
    b.push(&mut body, S::Return { value: None });
    let mut function = b.func;
    function.body = body;
    compute_entry_point(function)
}

/// What the sample loops of the entry point read and write.
struct Loops<'a> {
    plan: &'a EntryPlan,
    state: Handle<E>,
    counter: Handle<E>,
    kept: Option<&'a Kept>,
}

/// The functions one sample runs, and how it stands to the bricked volumes' segments.
struct Iteration<'a> {
    samples: &'a [Handle<naga::Function>],
    contributing: &'a [Handle<naga::Function>],
    sample_end: &'a [Handle<naga::Function>],
    segments: Segments<'a>,
}

/// How a sample uses the segments of the bricked volumes (`compose::segment`).
#[derive(Clone, Copy)]
enum Segments<'a> {
    /// No segment march.
    None,
    /// Full lookups, each sample opening the segments (the volumes' `segment_start`).
    Open(&'a [Handle<naga::Function>]),
    /// Reads of the segments: each sample saved before it runs, and taken back (then left for a
    /// full lookup) where it read outside a segment (the volumes' `segment_missed`, asked in
    /// each group of functions right after the last that reads a segment: [`SegmentVariants::checks`]).
    Read(&'a [Handle<naga::Function>], &'a Saved, [Option<usize>; 3]),
}

/// The groups of a sample's functions, in the order of [`SegmentVariants::checks`].
#[derive(Clone, Copy)]
enum Group {
    Samples = 0,
    Contributing = 1,
    End = 2,
}

/// The locals of the segment march: the state and sample count before the sample, and whether
/// it read outside a segment.
struct Saved {
    state: Handle<E>,
    /// The members of `State` saved: the `@ray` fields the sample loop writes (the rest are
    /// reset when the sample is taken again).
    members: Vec<u32>,
    counter: Handle<E>,
    missed: Handle<E>,
}

impl Loops<'_> {
    /// `loop { SAMPLE continuing { i = i + 1u; } }`.
    fn single(&self, b: &mut Body) -> S {
        let plan = self.plan;
        let every = Iteration {
            samples: &plan.samples,
            contributing: &plan.contributing,
            sample_end: &plan.sample_end,
            segments: Segments::None,
        };
        let mut loop_body = naga::Block::new();
        self.sample(b, &mut loop_body, &every);
        let mut continuing = naga::Block::new();
        increment(b, &mut continuing, self.counter);
        S::Loop { body: loop_body, continuing, break_if: None }
    }

    /// The march brick by brick: a sample with full lookups opens the segments, and the samples
    /// after it read them until one reads outside a segment, which is taken back and taken
    /// again with full lookups:
    /// `loop { SAMPLE(open) i = i + 1u; loop { SAMPLE(read) continuing { i = i + 1u; } } }`.
    fn segmented(&self, b: &mut Body, segment: &SegmentVariants, saved: &Saved) -> S {
        let plan = self.plan;
        let starts: Vec<_> = segment.volumes.iter().map(|v| v.start).collect();
        let missed: Vec<_> = segment.volumes.iter().map(|v| v.missed).collect();
        let opening = Iteration {
            samples: &plan.samples,
            contributing: &plan.contributing,
            sample_end: &plan.sample_end,
            segments: Segments::Open(&starts),
        };
        let reading = Iteration {
            samples: &segment.samples,
            contributing: &segment.contributing,
            sample_end: &segment.sample_end,
            segments: Segments::Read(&missed, saved, segment.checks),
        };
        let mut outer = naga::Block::new();
        self.sample(b, &mut outer, &opening);
        increment(b, &mut outer, self.counter);
        let mut inner = naga::Block::new();
        self.sample(b, &mut inner, &reading);
        let mut continuing = naga::Block::new();
        increment(b, &mut continuing, self.counter);
        b.push(&mut outer, S::Loop { body: inner, continuing, break_if: None });
        S::Loop { body: outer, continuing: naga::Block::new(), break_if: None }
    }

    /// One sample, leaving the loop when the ray is over (or, reading segments, when it read
    /// outside one).
    fn sample(&self, b: &mut Body, block: &mut naga::Block, it: &Iteration<'_>) {
        let plan = self.plan;
        let done = sample_loop_done(b, plan, self.state, self.counter);
        b.exit_if(block, done, S::Break);
        self.start(b, block, it);
        self.run(b, block, it, Group::Samples);
        match (&plan.gate, self.kept) {
            (Some(EntryGate::Once { flag, saved, .. }), Some(kept)) => {
                b.keep_selected(block, self.state, kept, (*flag, saved))
            }
            // The sample that opens segments is one sample: the next ones read them.
            (Some(EntryGate::Each { flag }), _) if matches!(it.segments, Segments::Open(_)) => {
                let mut accept = naga::Block::new();
                self.run(b, &mut accept, it, Group::Contributing);
                let contributes = load_member(b, self.state, *flag);
                b.push(block, S::If { condition: contributes, accept, reject: naga::Block::new() });
            }
            (gate, _) => {
                if let Some(EntryGate::Each { flag }) = gate {
                    self.skip_non_contributing(b, block, it, *flag);
                }
                self.run(b, block, it, Group::Contributing);
            }
        }
        self.run(b, block, it, Group::End);
    }

    /// Calls the functions of `group` on the state; reading segments, asks right after the last
    /// that reads one whether the sample read outside a segment (and takes it back if so).
    fn run(&self, b: &mut Body, block: &mut naga::Block, it: &Iteration<'_>, group: Group) {
        let functions = match group {
            Group::Samples => it.samples,
            Group::Contributing => it.contributing,
            Group::End => it.sample_end,
        };
        let check = match it.segments {
            Segments::Read(_, _, checks) => checks[group as usize],
            _ => None,
        };
        for (k, &f) in functions.iter().enumerate() {
            b.call(block, f, self.state);
            if check == Some(k + 1) {
                self.take_back_if_missed(b, block, it);
            }
        }
    }

    /// The start of a sample: `reset_sample(&state);`, after `saved.F = state.F; saved_i = i;
    /// missed = false;` (the saved members) when it reads segments, and before the volumes' `segment_start()` when it opens them.
    fn start(&self, b: &mut Body, block: &mut naga::Block, it: &Iteration<'_>) {
        if let Segments::Read(_, saved, _) = it.segments {
            b.copy_members(block, saved.state, self.state, &saved.members);
            let i = b.expr(E::Load { pointer: self.counter });
            b.push(block, S::Store { pointer: saved.counter, value: i });
            let no = b.literal(naga::Literal::Bool(false));
            b.push(block, S::Store { pointer: saved.missed, value: no });
        }
        b.call(block, self.plan.reset_sample, self.state);
        if let Segments::Open(starts) = it.segments {
            for &start in starts {
                b.push(block, S::Call { function: start, arguments: Vec::new(), result: None });
            }
        }
    }

    /// Reading segments: `missed = A_segment_missed() | B_segment_missed() ..; if missed {
    /// state.F = saved.F; i = saved_i; break; }` (every volume's flag is read, which clears it).
    fn take_back_if_missed(&self, b: &mut Body, block: &mut naga::Block, it: &Iteration<'_>) {
        let Segments::Read(missed_fns, saved, _) = it.segments else {
            return;
        };
        let mut any = None;
        for &function in missed_fns {
            let result = b.expr(E::CallResult(function));
            b.push(block, S::Call { function, arguments: Vec::new(), result: Some(result) });
            any = Some(match any {
                Some(before) => b.binary(naga::BinaryOperator::LogicalOr, before, result),
                None => result,
            });
        }
        let Some(any) = any else {
            return;
        };
        b.push(block, S::Store { pointer: saved.missed, value: any });
        let mut accept = naga::Block::new();
        b.copy_members(&mut accept, self.state, saved.state, &saved.members);
        let i = b.expr(E::Load { pointer: saved.counter });
        b.push(&mut accept, S::Store { pointer: self.counter, value: i });
        accept.push(S::Break, naga::Span::UNDEFINED);
        b.push(block, S::If { condition: any, accept, reject: naga::Block::new() });
    }

    /// The samples of a ray that cannot contribute, skipped ([`EntryGate::Each`] with flag
    /// `member`).
    ///
    /// Samples that cannot contribute run only `samples` and `sample_end`, in an inner loop that
    /// moves on to the next sample until one contributes (or the ray ends): a group of
    /// invocations that runs in lockstep (SIMD lanes, a warp) then does the contributing work
    /// together rather than each lane in turn, and where lanes only mask code (as on lavapipe)
    /// the work is not done for samples that skip it. Every invocation still runs its samples'
    /// functions in the same order as with `if contributes { .. }`.
    fn skip_non_contributing(&self, b: &mut Body, block: &mut naga::Block, it: &Iteration<'_>, member: u32) {
        let mut skipping = naga::Block::new();
        let contributes = load_member(b, self.state, member);
        b.exit_if(&mut skipping, contributes, S::Break);
        self.run(b, &mut skipping, it, Group::End);
        increment(b, &mut skipping, self.counter);
        let done = sample_loop_done(b, self.plan, self.state, self.counter);
        b.exit_if(&mut skipping, done, S::Break);
        self.start(b, &mut skipping, it);
        self.run(b, &mut skipping, it, Group::Samples);
        b.push(block, S::Loop { body: skipping, continuing: naga::Block::new(), break_if: None });
        // Left for a sample read outside a segment: that sample is taken again.
        if let Segments::Read(_, saved, _) = it.segments {
            let missed = b.expr(E::Load { pointer: saved.missed });
            b.exit_if(block, missed, S::Break);
        }
        // Left without a contributing sample: the ray ended.
        let contributes = load_member(b, self.state, member);
        let ended = b.expr(E::Unary { op: naga::UnaryOperator::LogicalNot, expr: contributes });
        b.exit_if(block, ended, S::Break);
    }
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

/// Which way [`Body::move_history`] moves the pixel's history.
#[derive(Clone, Copy)]
enum HistoryMove {
    Load,
    Store,
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

    /// The locals of a ray that keeps its selected sample, and `kept_any = false;` before the
    /// loop (`types`: `State` and `bool`).
    fn kept_locals(&mut self, body: &mut naga::Block, types: (Handle<naga::Type>, Handle<naga::Type>)) -> Kept {
        let kept = Kept { state: self.local("kept", types.0), any: self.local("kept_any", types.1) };
        let no = self.literal(naga::Literal::Bool(false));
        self.push(body, S::Store { pointer: kept.any, value: no });
        kept
    }

    /// In the loop after the functions that always run:
    /// `if state.FLAG { kept.F = state.F (saved); kept_any = true; }`.
    fn keep_selected(&mut self, block: &mut naga::Block, state: Handle<E>, kept: &Kept, (flag, saved): (u32, &[u32])) {
        let mut accept = naga::Block::new();
        self.copy_members(&mut accept, kept.state, state, saved);
        let yes = self.literal(naga::Literal::Bool(true));
        self.push(&mut accept, S::Store { pointer: kept.any, value: yes });
        let selected = load_member(self, state, flag);
        self.push(block, S::If { condition: selected, accept, reject: naga::Block::new() });
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
        Body::entry_function_of(module, plan.state_type)
    }

    /// `fn main(@builtin(global_invocation_id) id: vec3u)` with the locals `state: State` and
    /// `i: u32`.
    fn entry_function_of(
        module: &mut naga::Module,
        state_type: Handle<naga::Type>,
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
            naga::LocalVariable { name: Some("state".into()), ty: state_type, init: None },
            naga::Span::UNDEFINED,
        );
        let counter_var = func
            .local_variables
            .append(naga::LocalVariable { name: Some("i".into()), ty: u32_ty, init: None }, naga::Span::UNDEFINED);
        (Body { func, emitter: Emitter::default() }, state_var, counter_var)
    }

    /// The start of every entry point: the pixel of the region (returning past it), the state
    /// set to every field's default (`init_state`) and its `pixel` member, if any, to the
    /// pixel's centre. Returns the pixel and the state.
    fn begin_pixel(
        &mut self,
        body: &mut naga::Block,
        images: (Handle<naga::GlobalVariable>, Handle<naga::GlobalVariable>),
        (state_var, init_state): (Handle<naga::LocalVariable>, Handle<naga::Function>),
        pixel: Option<u32>,
    ) -> (Pixel, Handle<E>) {
        let found = self.pixel_in_region(body, images);
        let state = self.expr(E::LocalVariable(state_var));
        self.call(body, init_state, state);
        if let Some(member) = pixel {
            self.store_pixel_centre(body, state, member, found.p, found.size);
        }
        (found, state)
    }

    /// The dispatch covers `region`; pixels past its end or the image's (the last workgroups
    /// overhang both) return at once.
    fn pixel_in_region(
        &mut self,
        body: &mut naga::Block,
        (output, region): (Handle<naga::GlobalVariable>, Handle<naga::GlobalVariable>),
    ) -> Pixel {
        use naga::BinaryOperator as Bo;
        let id = self.expr(E::FunctionArgument(0));
        let output = self.expr(E::GlobalVariable(output));
        let size = self.expr(E::ImageQuery { image: output, query: naga::ImageQuery::Size { level: None } });
        let region_pointer = self.expr(E::GlobalVariable(region));
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

    /// `2u * (p.y * size.x + p.x)`: the first of the pixel's two elements of the history.
    fn history_index(&mut self, p: Handle<E>, size: Handle<E>) -> Handle<E> {
        use naga::BinaryOperator as Bo;
        let (x, y, width) = (self.component(p, 0), self.component(p, 1), self.component(size, 0));
        let row = self.binary(Bo::Multiply, y, width);
        let pixel = self.binary(Bo::Add, row, x);
        let two = self.literal(naga::Literal::U32(2));
        self.binary(Bo::Multiply, two, pixel)
    }

    /// Loads `state.history` and `state.history_samples` from the pixel's elements of the
    /// history, or stores them there.
    fn move_history(
        &mut self,
        body: &mut naga::Block,
        state: Handle<E>,
        h: HistoryPlan,
        index: Handle<E>,
        way: HistoryMove,
    ) {
        let buffer = self.expr(E::GlobalVariable(h.buffer));
        let mean_texel = self.expr(E::Access { base: buffer, index });
        let mut pairs = vec![(self.component(state, h.mean), mean_texel)];
        if let Some(member) = h.samples {
            let one = self.literal(naga::Literal::U32(1));
            let next = self.binary(naga::BinaryOperator::Add, index, one);
            let samples_texel = self.expr(E::Access { base: buffer, index: next });
            let samples_pointer = self.component(samples_texel, 0);
            pairs.push((self.component(state, member), samples_pointer));
        }
        for (field, texel) in pairs {
            let (to, from) = match way {
                HistoryMove::Load => (field, texel),
                HistoryMove::Store => (texel, field),
            };
            let value = self.expr(E::Load { pointer: from });
            self.push(body, S::Store { pointer: to, value });
        }
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
        load: &LayerLoad,
        p: Handle<E>,
        size: Handle<E>,
    ) {
        use naga::BinaryOperator as Bo;
        let image = self.expr(E::GlobalVariable(load.image));
        let dims = self.expr(E::ImageQuery { image, query: naga::ImageQuery::Size { level: None } });
        let scaled = self.binary(Bo::Multiply, p, dims);
        let texel = self.binary(Bo::Divide, scaled, size);
        let one = self.literal(naga::Literal::U32(1));
        let one = self.expr(E::Splat { size: naga::VectorSize::Bi, value: one });
        let last = self.binary(Bo::Subtract, dims, one);
        let texel =
            self.expr(E::Math { fun: naga::MathFunction::Min, arg: texel, arg1: Some(last), arg2: None, arg3: None });
        // A signed level: naga's GLSL out writes it into the bounds check's `textureSize`,
        // which takes an `int` (OpenGL refused the shader with `0u`).
        let level = self.literal(naga::Literal::I32(0));
        let array_index = load.layer.map(|layer| self.literal(naga::Literal::U32(layer)));
        let texel = self.expr(E::ImageLoad { image, coordinate: texel, array_index, sample: None, level: Some(level) });
        let value = if load.components == 1 { self.component(texel, 0) } else { texel };
        let pointer = self.component(state, load.member);
        self.push(body, S::Store { pointer, value });
    }
}
