//! The render pipelines of mesh layers and overlays, made once per renderer: opaque surfaces
//! (depth written), translucent ones (back faces, then front faces, blended over what is drawn,
//! depth tested but not written); slice outlines draw as opaque surfaces of flat colour. A
//! layer draws into its colour and depth images, an overlay into the view's picture. A layer
//! whose volume layer blends translucent surfaces in depth order peels them instead (`peel`:
//! the nearest surface behind the last layer peeled and in front of the first opaque one;
//! `peel_rest`: the surfaces behind the last layer, blended under it).

use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::pass_bindings::{PassBindings, PassLayout, Slot, ty};

/// The depth buffer's format (the depth test).
pub(crate) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The depth image's format: the opaque surfaces' depth as colour, which every back end's
/// compute shaders can load (a depth texture is not loadable in GLSL compute shaders).
pub(crate) const DEPTH_IMAGE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
/// The colour image's format (premultiplied alpha).
pub(crate) const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Bytes of one draw's uniforms, a multiple of every device's uniform offset alignment.
pub(crate) const DRAW_SLOT: u64 = 512;

/// One draw's uniforms, as the shader's `Draw` lays them out.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct DrawUniforms {
    /// Patient space (RAS mm) to clip space.
    pub world_to_clip: [[f32; 4]; 4],
    /// Clip space to patient space: the view direction of each vertex.
    pub clip_to_world: [[f32; 4]; 4],
    /// The mesh's placement (its vertices to patient space).
    pub model: [[f32; 4]; 4],
    /// The inverse transpose of `model` (normals).
    pub normal_model: [[f32; 4]; 4],
    /// sRGB colour and opacity.
    pub color: [f32; 4],
    /// x: 1 for flat colour (outlines), 0 for a lit surface.
    pub flat: [f32; 4],
    /// A shadow group's light: patient space to its shadow map's clip space, and the unit
    /// direction towards it (`fs_shadowed`).
    pub light_to_clip: [[f32; 4]; 4],
    pub light: [f32; 4],
    /// Patient space to the primary volume's normalized coordinates, where the light volume of
    /// a shadow group's light is read (`fs_shadowed`).
    pub world_to_volume: [[f32; 4]; 4],
}

pub(crate) const SHADER: &str = r#"
struct Draw {
    world_to_clip: mat4x4<f32>,
    clip_to_world: mat4x4<f32>,
    model: mat4x4<f32>,
    normal_model: mat4x4<f32>,
    color: vec4<f32>,
    flat_colour: vec4<f32>,
    light_to_clip: mat4x4<f32>,
    light: vec4<f32>,
    world_to_volume: mat4x4<f32>,
}
@group(0) @binding(0) var<uniform> draw: Draw;

struct Varyings {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) to_eye: vec3<f32>,
    @location(2) world: vec3<f32>,
}

fn unproject(ndc: vec3<f32>) -> vec3<f32> {
    let p = draw.clip_to_world * vec4<f32>(ndc, 1.0);
    return p.xyz / p.w;
}

@vertex
fn vs(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>) -> Varyings {
    var out: Varyings;
    let world = draw.model * vec4<f32>(position, 1.0);
    out.clip = draw.world_to_clip * world;
    out.world = world.xyz / world.w;
    out.normal = (draw.normal_model * vec4<f32>(normal, 0.0)).xyz;
    // Towards the viewer along the pixel's ray (perspective and orthographic alike).
    let ndc = out.clip.xy / out.clip.w;
    out.to_eye = unproject(vec3<f32>(ndc, 0.0)) - unproject(vec3<f32>(ndc, 1.0));
    return out;
}

struct Fragment {
    @location(0) color: vec4<f32>,
    @location(1) depth: f32,
}

fn shade(in: Varyings) -> vec4<f32> {
    var rgb = draw.color.rgb;
    if draw.flat_colour.x < 0.5 {
        // A headlight, two-sided Lambert with an ambient floor, so shapes read as surfaces.
        let n = normalize(in.normal);
        let v = normalize(in.to_eye);
        rgb = rgb * (0.3 + 0.7 * abs(dot(n, v)));
    }
    let a = draw.color.a;
    return vec4<f32>(rgb * a, a);
}

@fragment
fn fs(in: Varyings) -> Fragment {
    return Fragment(shade(in), in.clip.z);
}

@fragment
fn fs_overlay(in: Varyings) -> @location(0) vec4<f32> {
    return shade(in);
}

// A shadow group's meshes: lit by its light (two-sided Lambert over the same ambient floor),
// where its shadow map sees them (a 2x2 comparison filter softens the shadow's edge).
// (Group 1 as the planes' pictures, at other bindings: a device binds at most four groups.)
@group(1) @binding(2) var shadow_map: texture_depth_2d;
@group(1) @binding(3) var shadow_sampler: sampler_comparison;
// The volume's shadow: the light volume of the group's light (the share of the light reaching
// each texel through the volume), or one texel of 1 where the view's volume casts none.
@group(1) @binding(4) var light_volume: texture_3d<f32>;
@group(1) @binding(5) var light_volume_sampler: sampler;

// The share of the group's light that reaches `world` through the volume (1 outside it).
fn through_volume(world: vec3<f32>) -> f32 {
    let h = draw.world_to_volume * vec4<f32>(world, 1.0);
    let p = h.xyz / h.w;
    if any(p < vec3<f32>(0.0)) || any(p > vec3<f32>(1.0)) {
        return 1.0;
    }
    return textureSampleLevel(light_volume, light_volume_sampler, p, 0.0).x;
}

// The shadow map's depth is biased towards the light when drawn; this keeps a surface's own
// depth from shadowing it where the map's texels are coarser than the view's pixels.
const SHADOW_BIAS: f32 = 0.002;

@fragment
fn fs_shadowed(in: Varyings) -> Fragment {
    let seen = draw.light_to_clip * vec4<f32>(in.world, 1.0);
    let uv = vec2<f32>(seen.x * 0.5 + 0.5, 0.5 - seen.y * 0.5);
    let lit = textureSampleCompareLevel(shadow_map, shadow_sampler, uv, seen.z - SHADOW_BIAS) * through_volume(in.world);
    var n = normalize(in.normal);
    if dot(n, in.to_eye) < 0.0 {
        n = -n;
    }
    let rgb = draw.color.rgb * (0.3 + 0.7 * max(dot(n, draw.light.xyz), 0.0) * lit);
    let a = draw.color.a;
    return Fragment(vec4<f32>(rgb * a, a), in.clip.z);
}

// Peeling: the depth of the first opaque surface and of the translucent layer peeled last (0
// before the first), at each pixel.
@group(2) @binding(0) var opaque_depth: texture_2d<f32>;
@group(2) @binding(1) var peeled_depth: texture_2d<f32>;

// Whether a fragment lies behind the layer peeled last and in front of the first opaque surface.
fn beyond_peeled(clip: vec4<f32>) -> bool {
    let pixel = vec2<i32>(clip.xy);
    return clip.z > textureLoad(peeled_depth, pixel, 0).x && clip.z < textureLoad(opaque_depth, pixel, 0).x;
}

@fragment
fn fs_peel(in: Varyings) -> Fragment {
    if !beyond_peeled(in.clip) {
        discard;
    }
    return Fragment(shade(in), in.clip.z);
}

@fragment
fn fs_peel_rest(in: Varyings) -> @location(0) vec4<f32> {
    if !beyond_peeled(in.clip) {
        discard;
    }
    return shade(in);
}

// A slice view's picture on its plane, opaque where it is at least half covered (its colour
// unpremultiplied), left out elsewhere: a slice with a transparent background leaves the rest of
// its plane empty, and a ray that ends at the plane never loses what lies behind a half-covered
// texel at its edge.
@group(1) @binding(0) var plane_image: texture_2d<f32>;
@group(1) @binding(1) var plane_sampler: sampler;

struct PlaneVaryings {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
}

@vertex
fn vs_plane(@location(0) position: vec3<f32>, @location(1) uv: vec2<f32>) -> PlaneVaryings {
    var out: PlaneVaryings;
    out.clip = draw.world_to_clip * vec4<f32>(position, 1.0);
    out.uv = uv;
    return out;
}

@fragment
fn fs_plane(in: PlaneVaryings) -> Fragment {
    let color = textureSampleLevel(plane_image, plane_sampler, in.uv, 0.0);
    if color.a < 0.5 {
        discard;
    }
    return Fragment(vec4<f32>(color.rgb / color.a, 1.0), in.clip.z);
}

// An occlusion group's two parts, as their passes drew them: the context (the first child) and
// the focus (the others), each its premultiplied colour and its opaque surfaces' depth.
@group(3) @binding(0) var context_color: texture_2d<f32>;
@group(3) @binding(1) var context_depth: texture_2d<f32>;
@group(3) @binding(2) var focus_color: texture_2d<f32>;
@group(3) @binding(3) var focus_depth: texture_2d<f32>;

@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let corner = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(corner * 2.0 - 1.0, 0.0, 1.0);
}

struct Combined {
    @location(0) color: vec4<f32>,
    @location(1) depth: f32,
    @builtin(frag_depth) frag_depth: f32,
}

// Where the context's opaque surface lies in front of the focus, the focus shows through it
// with the group's hidden opacity (`draw.color.a`); elsewhere the focus lies over the context.
// Either way the nearer opaque surface is the group's depth. A part's depth counts only where
// it has colour: a filter that cleared a surface's colour clears its depth with it (depth is
// written only where colour is).
@fragment
fn fs_combine(@builtin(position) clip: vec4<f32>) -> Combined {
    let pixel = vec2<i32>(clip.xy);
    let context = textureLoad(context_color, pixel, 0);
    let focus = textureLoad(focus_color, pixel, 0);
    let near = select(1.0, textureLoad(context_depth, pixel, 0).x, context.a > 0.0);
    let far = select(1.0, textureLoad(focus_depth, pixel, 0).x, focus.a > 0.0);
    let k = select(1.0, draw.color.a, near < far);
    let color = k * focus + (1.0 - k * focus.a) * context;
    let depth = min(near, far);
    if color.a <= 0.0 && depth >= 1.0 {
        discard;
    }
    return Combined(color, depth, depth);
}
"#;

/// The bindings of [`SHADER`]: group 0, a draw's uniforms (at a dynamic offset, one
/// [`DRAW_SLOT`] per draw); group 1, a plane's picture and its sampler (`vs_plane`/`fs_plane`);
/// group 2, the opaque and the last peeled depth (`fs_peel`, `fs_peel_rest`); group 3, an
/// occlusion group's context and focus images (`fs_combine`).
pub(crate) const BINDINGS: PassBindings = PassBindings {
    label: "mesh layer",
    groups: &[
        DRAW_GROUP,
        &[
            Slot {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: ty::texture(wgpu::TextureViewDimension::D2, true),
            },
            Slot { binding: 1, visibility: wgpu::ShaderStages::FRAGMENT, ty: ty::SAMPLER },
        ],
        &[loaded_image(0), loaded_image(1)],
        &[loaded_image(0), loaded_image(1), loaded_image(2), loaded_image(3)],
    ],
};

/// The bindings of the shadowed pipelines (`fs_shadowed`): group 0 as in [`BINDINGS`]; group 1,
/// a shadow group's shadow map and its comparison sampler, then the light volume of its light
/// and a filtering sampler.
pub(crate) const SHADOW_BINDINGS: PassBindings = PassBindings {
    label: "shadowed meshes",
    groups: &[
        DRAW_GROUP,
        &[
            Slot {
                binding: 2,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Depth,
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
            },
            Slot {
                binding: 3,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
            },
            Slot {
                binding: 4,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: ty::texture(wgpu::TextureViewDimension::D3, true),
            },
            Slot { binding: 5, visibility: wgpu::ShaderStages::FRAGMENT, ty: ty::SAMPLER },
        ],
    ],
};

/// Group 0 of every mesh pipeline: a draw's uniforms, at a dynamic offset.
const DRAW_GROUP: &[Slot] = &[Slot {
    binding: 0,
    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
    ty: wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Uniform,
        has_dynamic_offset: true,
        min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<DrawUniforms>() as u64),
    },
}];

/// A fragment shader's `texture_2d<f32>` at `binding`, read with `textureLoad` only.
const fn loaded_image(binding: u32) -> Slot {
    Slot { binding, visibility: wgpu::ShaderStages::FRAGMENT, ty: ty::texture(wgpu::TextureViewDimension::D2, false) }
}

/// How a pipeline treats faces and depth.
#[derive(Clone, Copy)]
enum Kind {
    Opaque,
    /// An opaque closed surface wound outward: its back faces are hidden, so they are culled
    /// (half the triangles a software rasterizer sets up).
    OpaqueClosed,
    TranslucentBack,
    TranslucentFront,
}

/// The pipelines of one kind of target, a draw's pass picking one.
pub(crate) struct PipelineSet {
    pub opaque: wgpu::RenderPipeline,
    pub opaque_closed: wgpu::RenderPipeline,
    pub translucent_back: wgpu::RenderPipeline,
    pub translucent_front: wgpu::RenderPipeline,
}

/// The mesh pipelines and their bind-group layouts.
pub(crate) struct MeshPipelines {
    /// The layouts of [`BINDINGS`]: a draw's uniforms (group 0 of every pipeline), a plane's
    /// picture and its sampler (group 1 of `plane`).
    pub(crate) bindings: PassLayout,
    /// Slice views' pictures on their planes, into a mesh layer.
    pub plane: wgpu::RenderPipeline,
    /// Into a mesh layer's colour and depth images.
    pub layer: PipelineSet,
    /// Over a view's picture (`rgba8unorm`).
    pub overlay: PipelineSet,
    /// A translucent layer: the nearest translucent surface behind the layer peeled last, into
    /// the layer's colour and depth (both faces).
    pub peel: wgpu::RenderPipeline,
    /// The translucent surfaces behind the last layer, blended under it in drawing order.
    pub peel_rest: wgpu::RenderPipeline,
    /// An occlusion group's context and focus combined into its parent's colour and depth.
    pub combine: wgpu::RenderPipeline,
    /// Into a mesh layer, lit by a shadow group's light and shadowed by its shadow map.
    pub shadowed: PipelineSet,
    /// A shadow group's meshes into its shadow map (depth only, biased away from the light).
    pub shadow_caster: wgpu::RenderPipeline,
    /// The shadow maps' comparison sampler (linear: a 2x2 filter).
    pub shadow_sampler: wgpu::Sampler,
    /// The layouts of [`SHADOW_BINDINGS`].
    pub(crate) shadow_bindings: PassLayout,
    /// One texel of 1: the light volume of a shadow group whose view's volume casts no shadow.
    pub(crate) no_light_volume: wgpu::TextureView,
}

impl MeshPipelines {
    pub(crate) fn new(gpu: &Gpu) -> Result<MeshPipelines, RuntimeError> {
        let made = gpu.capture("making the mesh pipelines", || {
            let module = gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("mesh layer"),
                source: wgpu::ShaderSource::Wgsl(SHADER.into()),
            });
            let bindings = PassLayout::new(gpu, BINDINGS);
            // The mesh pipelines read group 0; the plane pipeline reads both.
            let pipeline_layout = bindings.pipeline_layout(gpu, 1);
            let shadow_bindings = PassLayout::new(gpu, SHADOW_BINDINGS);
            let shadowing = shadow_bindings.pipeline_layout(gpu, 2);
            let set = |target| {
                let layout = if target == SetTarget::Shadowed { &shadowing } else { &pipeline_layout };
                let make = |kind| pipeline(gpu, &module, layout, kind, target);
                PipelineSet {
                    opaque: make(Kind::Opaque),
                    opaque_closed: make(Kind::OpaqueClosed),
                    translucent_back: make(Kind::TranslucentBack),
                    translucent_front: make(Kind::TranslucentFront),
                }
            };
            let plane = plane_pipeline(gpu, &module, &bindings.pipeline_layout(gpu, 2));
            let peeling = bindings.pipeline_layout_of(gpu, &[0, 2]);
            let peel = peel_pipeline(gpu, &module, &peeling, false);
            let peel_rest = peel_pipeline(gpu, &module, &peeling, true);
            let combine = combine_pipeline(gpu, &module, &bindings.pipeline_layout_of(gpu, &[0, 3]));
            MeshPipelines {
                layer: set(SetTarget::Layer),
                overlay: set(SetTarget::Overlay),
                shadowed: set(SetTarget::Shadowed),
                shadow_caster: shadow_caster_pipeline(gpu, &module, &pipeline_layout),
                shadow_sampler: gpu.device.create_sampler(&wgpu::SamplerDescriptor {
                    label: Some("shadow map"),
                    mag_filter: wgpu::FilterMode::Linear,
                    min_filter: wgpu::FilterMode::Linear,
                    compare: Some(wgpu::CompareFunction::LessEqual),
                    ..Default::default()
                }),
                plane,
                peel,
                peel_rest,
                combine,
                bindings,
                shadow_bindings,
                no_light_volume: full_light(gpu),
            }
        })?;
        Ok(made)
    }
}

/// A 1x1x1 texture of 1 (full light), sampled where no light volume is.
fn full_light(gpu: &Gpu) -> wgpu::TextureView {
    let texture = wgpu::util::DeviceExt::create_texture_with_data(
        &gpu.device,
        &gpu.queue,
        &wgpu::TextureDescriptor {
            label: Some("no light volume"),
            size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: wgpu::TextureFormat::R8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        &[255],
    );
    texture.create_view(&Default::default())
}

/// Position and normal.
const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 2] = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];

/// What a [`PipelineSet`] draws into, and how it lights.
#[derive(Clone, Copy, PartialEq, Eq)]
enum SetTarget {
    /// A mesh layer's two images, headlight.
    Layer,
    /// Over a picture, headlight.
    Overlay,
    /// A mesh layer's two images, a shadow group's light and shadow map.
    Shadowed,
}

/// A pipeline of `kind` for `target`.
fn pipeline(
    gpu: &Gpu,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    kind: Kind,
    target: SetTarget,
) -> wgpu::RenderPipeline {
    let (cull_mode, depth_write_enabled) = match kind {
        Kind::Opaque => (None, true),
        Kind::OpaqueClosed => (Some(wgpu::Face::Back), true),
        Kind::TranslucentBack => (Some(wgpu::Face::Front), false),
        Kind::TranslucentFront => (Some(wgpu::Face::Back), false),
    };
    let color = Some(wgpu::ColorTargetState {
        format: COLOR_FORMAT,
        blend: Some(wgpu::BlendState { color: OVER, alpha: OVER }),
        write_mask: wgpu::ColorWrites::ALL,
    });
    // Only opaque surfaces stop rays: translucent ones leave the depth image as it is.
    let depth_image = Some(wgpu::ColorTargetState {
        format: DEPTH_IMAGE_FORMAT,
        blend: None,
        write_mask: if depth_write_enabled { wgpu::ColorWrites::RED } else { wgpu::ColorWrites::empty() },
    });
    let (entry_point, targets) = match target {
        SetTarget::Overlay => ("fs_overlay", vec![color]),
        SetTarget::Layer => ("fs", vec![color, depth_image]),
        SetTarget::Shadowed => ("fs_shadowed", vec![color, depth_image]),
    };
    let stages = Stages {
        depth: Some(depth_test(depth_write_enabled)),
        cull_mode,
        ..Stages::surface(Some(entry_point), &targets)
    };
    render_pipeline(gpu, module, layout, stages)
}

/// Premultiplied "over": what is drawn later lies in front.
const OVER: wgpu::BlendComponent = wgpu::BlendComponent {
    src_factor: wgpu::BlendFactor::One,
    dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
    operation: wgpu::BlendOperation::Add,
};

/// Premultiplied "under": what is drawn later lies behind.
const UNDER: wgpu::BlendComponent = wgpu::BlendComponent {
    src_factor: wgpu::BlendFactor::OneMinusDstAlpha,
    dst_factor: wgpu::BlendFactor::One,
    operation: wgpu::BlendOperation::Add,
};

/// What differs between the mesh layer's pipelines: the vertex shader and its vertices' layout
/// (none: it makes its own), the fragment shader (none: depth only) and its targets, the depth
/// test and the faces culled.
struct Stages<'a> {
    label: &'a str,
    vertex: &'a str,
    buffer: Option<wgpu::VertexBufferLayout<'a>>,
    fragment: Option<&'a str>,
    targets: &'a [Option<wgpu::ColorTargetState>],
    depth: Option<wgpu::DepthStencilState>,
    cull_mode: Option<wgpu::Face>,
}

impl<'a> Stages<'a> {
    /// A lit surface's stages: `vs` over [`SURFACE_VERTICES`], both faces drawn, no depth test.
    fn surface(fragment: Option<&'a str>, targets: &'a [Option<wgpu::ColorTargetState>]) -> Stages<'a> {
        Stages {
            label: "mesh layer",
            vertex: "vs",
            buffer: Some(SURFACE_VERTICES),
            fragment,
            targets,
            depth: None,
            cull_mode: None,
        }
    }
}

/// A surface's vertices: position and normal, 24 bytes a vertex.
const SURFACE_VERTICES: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
    array_stride: 24,
    step_mode: wgpu::VertexStepMode::Vertex,
    attributes: &VERTEX_ATTRIBUTES,
};

fn render_pipeline(
    gpu: &Gpu,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    stages: Stages,
) -> wgpu::RenderPipeline {
    gpu.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(stages.label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(stages.vertex),
            compilation_options: Default::default(),
            buffers: &[stages.buffer],
        },
        primitive: wgpu::PrimitiveState {
            cull_mode: stages.cull_mode,
            front_face: wgpu::FrontFace::Ccw,
            ..Default::default()
        },
        depth_stencil: stages.depth,
        multisample: Default::default(),
        fragment: stages.fragment.map(|entry_point| wgpu::FragmentState {
            module,
            entry_point: Some(entry_point),
            compilation_options: Default::default(),
            targets: stages.targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A peeling pipeline (both faces): a layer's nearest surface into its colour and depth (the
/// depth test keeps the nearest), or (`rest`) every surface behind the last layer blended under
/// its colour.
fn peel_pipeline(
    gpu: &Gpu,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    rest: bool,
) -> wgpu::RenderPipeline {
    let target = |format, blend| Some(wgpu::ColorTargetState { format, blend, write_mask: wgpu::ColorWrites::ALL });
    let under = Some(wgpu::BlendState { color: UNDER, alpha: UNDER });
    let targets = if rest {
        vec![target(COLOR_FORMAT, under)]
    } else {
        vec![target(COLOR_FORMAT, None), target(DEPTH_IMAGE_FORMAT, None)]
    };
    let fragment = Some(if rest { "fs_peel_rest" } else { "fs_peel" });
    let stages = Stages { depth: (!rest).then(|| depth_test(true)), ..Stages::surface(fragment, &targets) };
    render_pipeline(gpu, module, layout, stages)
}

/// Position and picture coordinates, 20 bytes a vertex.
const PLANE_ATTRIBUTES: [wgpu::VertexAttribute; 2] = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x2];

/// The pipeline of slice pictures on their planes: opaque, depth written, both sides.
fn plane_pipeline(gpu: &Gpu, module: &wgpu::ShaderModule, layout: &wgpu::PipelineLayout) -> wgpu::RenderPipeline {
    let target = |format| Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL });
    let targets = [target(COLOR_FORMAT), target(DEPTH_IMAGE_FORMAT)];
    let buffer = wgpu::VertexBufferLayout {
        array_stride: 20,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &PLANE_ATTRIBUTES,
    };
    let stages = Stages {
        label: "plane picture",
        vertex: "vs_plane",
        buffer: Some(buffer),
        fragment: Some("fs_plane"),
        targets: &targets,
        depth: Some(depth_test(true)),
        cull_mode: None,
    };
    render_pipeline(gpu, module, layout, stages)
}

/// The pipeline of occlusion groups' combinations: one full-screen triangle into a layer's
/// colour (over what is drawn) and depth, depth-tested with what the parent draws after it.
fn combine_pipeline(gpu: &Gpu, module: &wgpu::ShaderModule, layout: &wgpu::PipelineLayout) -> wgpu::RenderPipeline {
    let over = Some(wgpu::BlendState { color: OVER, alpha: OVER });
    let targets = [
        Some(wgpu::ColorTargetState { format: COLOR_FORMAT, blend: over, write_mask: wgpu::ColorWrites::ALL }),
        Some(wgpu::ColorTargetState { format: DEPTH_IMAGE_FORMAT, blend: None, write_mask: wgpu::ColorWrites::RED }),
    ];
    // Equal passes: a pixel with nothing opaque (depth 1) still shows the group's colour.
    let depth = wgpu::DepthStencilState { depth_compare: Some(wgpu::CompareFunction::LessEqual), ..depth_test(true) };
    let stages = Stages {
        label: "occlusion group",
        vertex: "vs_full",
        buffer: None,
        fragment: Some("fs_combine"),
        targets: &targets,
        depth: Some(depth),
        cull_mode: None,
    };
    render_pipeline(gpu, module, layout, stages)
}

/// The pipeline of shadow maps: every face of a shadow group's meshes, depth only, the nearest
/// kept, pushed away from the light by a slope-scaled bias (no surface shadows itself).
fn shadow_caster_pipeline(
    gpu: &Gpu,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
) -> wgpu::RenderPipeline {
    let depth = wgpu::DepthStencilState {
        bias: wgpu::DepthBiasState { constant: 2, slope_scale: 2.0, clamp: 0.0 },
        ..depth_test(true)
    };
    render_pipeline(gpu, module, layout, Stages { depth: Some(depth), ..Stages::surface(None, &[]) })
}

/// The nearest surface wins; `write`: the surface hides what is drawn after it.
fn depth_test(write: bool) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(write),
        depth_compare: Some(wgpu::CompareFunction::Less),
        stencil: Default::default(),
        bias: Default::default(),
    }
}
