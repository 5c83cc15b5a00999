//! The draw calls of a mesh layer or an overlay: which meshes, with which uniforms, in which
//! order, and their recording into a render pass.

use super::outline::{self, SliceFrame};
use super::pipelines::{DRAW_SLOT, DrawUniforms, MeshPipelines, PipelineSet};
use super::{LayerCamera, MeshInstance, SLICE_PLANE_DEPTH};
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use glam::{Mat4, Vec4};

/// Outline width in a slice view, in pixels.
const OUTLINE_PIXELS: f32 = 2.0;
/// How far from a slice plane (mm) an overlay's depth range reaches on either side.
const SLICE_OVERLAY_REACH: f32 = 1000.0;

/// What the draws are for.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Target {
    /// A mesh layer under the volume: a slice view draws its plane's crossings.
    Layer,
    /// An overlay over the picture: a slice view draws the meshes seen along its normal.
    Overlay,
}

/// Which pipeline a draw uses.
#[derive(Clone, Copy)]
pub(super) enum Pass {
    /// A slice view's picture on its plane (its bind group in `Draw::images`).
    Plane,
    /// An occlusion group's parts combined (their images in `Draw::images`).
    Combine,
    Opaque,
    OpaqueClosed,
    Back,
    Front,
}

/// One draw call of a frame.
pub(super) struct Draw {
    pass: Pass,
    uniforms: DrawUniforms,
    /// None: the vertex shader makes its vertices (a full-screen triangle).
    vertices: Option<wgpu::Buffer>,
    indices: Option<(wgpu::Buffer, u32)>,
    vertex_count: u32,
    /// The images it reads and their bind group's number: a plane's picture and sampler, an
    /// occlusion group's parts, a shadow group's shadow map.
    images: Option<(u32, wgpu::BindGroup)>,
    /// Lit by a shadow group's light (`MeshPipelines::shadowed`).
    shadowed: bool,
}

impl DrawUniforms {
    fn surface(world_to_clip: Mat4, clip_to_world: Mat4, m: &MeshInstance) -> DrawUniforms {
        DrawUniforms {
            world_to_clip: world_to_clip.to_cols_array_2d(),
            clip_to_world: clip_to_world.to_cols_array_2d(),
            model: m.model.to_cols_array_2d(),
            normal_model: m.model.inverse().transpose().to_cols_array_2d(),
            color: [m.color[0], m.color[1], m.color[2], m.opacity.clamp(0.0, 1.0)],
            flat: [0.0; 4],
            light_to_clip: Mat4::IDENTITY.to_cols_array_2d(),
            light: [0.0; 4],
            world_to_volume: Mat4::IDENTITY.to_cols_array_2d(),
        }
    }

    /// Flat `color`, seen through `world_to_clip` (outline quads are in clip space already).
    fn flat(world_to_clip: Mat4, color: [f32; 4]) -> DrawUniforms {
        let identity = Mat4::IDENTITY.to_cols_array_2d();
        DrawUniforms {
            world_to_clip: world_to_clip.to_cols_array_2d(),
            clip_to_world: identity,
            model: identity,
            normal_model: identity,
            color,
            flat: [1.0, 0.0, 0.0, 0.0],
            light_to_clip: identity,
            light: [0.0; 4],
            world_to_volume: identity,
        }
    }
}

/// The draws of a frame, in order: opaque meshes, then each translucent mesh's back and front
/// faces; in a slice view's layer, every mesh's outline on the plane.
pub(crate) fn frame_draws(
    gpu: &Gpu,
    camera: &LayerCamera,
    meshes: &[&MeshInstance],
    size: [u32; 2],
    target: Target,
) -> Result<Vec<Draw>, RuntimeError> {
    match (camera, target) {
        (LayerCamera::Projection { world_to_clip }, _) => Ok(surfaces(*world_to_clip, meshes)),
        (LayerCamera::Slice(frame), Target::Overlay) => Ok(surfaces(seen_along_normal(frame), meshes)),
        (LayerCamera::Slice(frame), Target::Layer) => outlines(gpu, frame, meshes, size),
    }
}

/// Lit surfaces: opaque ones first, then each translucent one's back and front faces.
fn surfaces(world_to_clip: Mat4, meshes: &[&MeshInstance]) -> Vec<Draw> {
    let (opaque, translucent): (Vec<&MeshInstance>, Vec<&MeshInstance>) =
        meshes.iter().copied().partition(|m| m.opacity >= 1.0);
    let mut out: Vec<Draw> = opaque
        .iter()
        .map(|m| surface(world_to_clip, m, if m.closed { Pass::OpaqueClosed } else { Pass::Opaque }))
        .collect();
    for m in translucent.iter().filter(|m| m.opacity > 0.0) {
        out.push(surface(world_to_clip, m, Pass::Back));
        out.push(surface(world_to_clip, m, Pass::Front));
    }
    out
}

/// Each translucent mesh of `meshes` once (both faces), for the peeling passes of a raycast
/// view's layer (recorded with [`Pipelines::One`]).
pub(crate) fn peel_draws(world_to_clip: Mat4, meshes: &[&MeshInstance]) -> Vec<Draw> {
    meshes
        .iter()
        .filter(|m| m.opacity > 0.0 && m.opacity < 1.0)
        .map(|m| surface(world_to_clip, m, Pass::Front))
        .collect()
}

/// The draw of mesh `m` seen through `world_to_clip`.
fn surface(world_to_clip: Mat4, m: &MeshInstance, pass: Pass) -> Draw {
    Draw {
        pass,
        uniforms: DrawUniforms::surface(world_to_clip, world_to_clip.inverse(), m),
        vertices: Some(m.gpu.vertices.clone()),
        indices: Some((m.gpu.indices.clone(), m.gpu.index_count)),
        vertex_count: 0,
        images: None,
        shadowed: false,
    }
}

/// A shadow group's light as its meshes' draws see it: patient space to its shadow map's clip
/// space, the unit direction towards it, patient space to the volume's coordinates (where its
/// light volume is read), and the bind group of its shadow map and light volume.
pub(crate) struct LitBy {
    pub light_to_clip: Mat4,
    pub towards: glam::Vec3,
    pub world_to_volume: Mat4,
    pub map: wgpu::BindGroup,
}

/// `draws` (lit surfaces) lit by `light` and shadowed by its map.
pub(crate) fn shadowed(mut draws: Vec<Draw>, light: &LitBy) -> Vec<Draw> {
    for draw in &mut draws {
        draw.shadowed = true;
        draw.uniforms.light_to_clip = light.light_to_clip.to_cols_array_2d();
        draw.uniforms.light = light.towards.extend(0.0).to_array();
        draw.uniforms.world_to_volume = light.world_to_volume.to_cols_array_2d();
        draw.images = Some((1, light.map.clone()));
    }
    draws
}

/// Each visible mesh of `meshes` once, seen from a light (`light_to_clip`), for its shadow map
/// (recorded with [`Pipelines::One`]).
pub(crate) fn caster_draws(light_to_clip: Mat4, meshes: &[&MeshInstance]) -> Vec<Draw> {
    meshes.iter().filter(|m| m.opacity > 0.0).map(|m| surface(light_to_clip, m, Pass::Opaque)).collect()
}

/// A slice image's projection along its normal: patient space to clip space, depth 0.5 on the
/// plane and [`SLICE_OVERLAY_REACH`] mm to either side at 0 and 1.
fn seen_along_normal(frame: &SliceFrame) -> Mat4 {
    let image_to_clip = Mat4::from_cols(
        Vec4::new(2.0, 0.0, 0.0, 0.0),
        Vec4::new(0.0, -2.0, 0.0, 0.0),
        Vec4::new(0.0, 0.0, 0.5 / SLICE_OVERLAY_REACH, 0.0),
        Vec4::new(-1.0, 1.0, 0.5, 1.0),
    );
    image_to_clip * frame.world_to_image
}

/// Each mesh's crossing of the slice plane, as opaque lines.
fn outlines(
    gpu: &Gpu,
    frame: &SliceFrame,
    meshes: &[&MeshInstance],
    size: [u32; 2],
) -> Result<Vec<Draw>, RuntimeError> {
    let mut out = Vec::new();
    for m in meshes.iter().filter(|m| m.opacity > 0.0) {
        let quads = outline::outline_quads(&m.mesh, m.model, frame, size, OUTLINE_PIXELS, SLICE_PLANE_DEPTH);
        if quads.is_empty() {
            continue;
        }
        let vertices = vertex_buffer(gpu, "uploading a slice outline", bytemuck::cast_slice(&quads))?;
        out.push(Draw {
            pass: Pass::Opaque,
            uniforms: DrawUniforms::flat(Mat4::IDENTITY, [m.color[0], m.color[1], m.color[2], 1.0]),
            vertices: Some(vertices),
            indices: None,
            vertex_count: (quads.len() / 6) as u32,
            images: None,
            shadowed: false,
        });
    }
    Ok(out)
}

/// The uniform buffer of a layer's draws, kept while it is large enough.
#[derive(Default)]
pub(crate) struct DrawBuffer {
    uniforms: Option<wgpu::Buffer>,
}

impl DrawBuffer {
    /// Writes the draws' uniforms and binds them (`None` without pipelines: nothing to draw).
    pub(crate) fn bind(
        &mut self,
        gpu: &Gpu,
        pipelines: Option<&MeshPipelines>,
        draws: &[Draw],
    ) -> Result<Option<wgpu::BindGroup>, RuntimeError> {
        let Some(pipelines) = pipelines else { return Ok(None) };
        let needed = DRAW_SLOT * draws.len().max(1) as u64;
        if self.uniforms.as_ref().is_none_or(|b| b.size() < needed) {
            let made = gpu.capture("creating a mesh layer's uniforms", || {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("mesh draws"),
                    size: needed,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })?;
            self.uniforms = Some(made);
        }
        let uniforms = self.uniforms.as_ref().expect("made above");
        let bytes: Vec<u8> = draws
            .iter()
            .flat_map(|d| {
                let mut slot = bytemuck::bytes_of(&d.uniforms).to_vec();
                slot.resize(DRAW_SLOT as usize, 0);
                slot
            })
            .collect();
        if !bytes.is_empty() {
            gpu.queue.write_buffer(uniforms, 0, &bytes);
        }
        let group = gpu.capture("binding a mesh layer", || {
            let slot = wgpu::BufferBinding {
                buffer: uniforms,
                offset: 0,
                size: wgpu::BufferSize::new(std::mem::size_of::<DrawUniforms>() as u64),
            };
            pipelines.bindings.bind_group(gpu, 0, &[wgpu::BindingResource::Buffer(slot)])
        })?;
        Ok(Some(group))
    }
}

/// The pipelines draws are recorded with.
#[derive(Clone, Copy)]
pub(crate) enum Pipelines<'a> {
    /// Each draw's pass picks one of `set`'s, or the planes' or the combination's of the
    /// mesh pipelines.
    ByPass(&'a PipelineSet, &'a MeshPipelines),
    /// Every draw with one pipeline (the peeling passes).
    One(&'a wgpu::RenderPipeline),
}

/// Records `draws` into `pass` with `pipelines`; their uniforms are the bound buffer's slots
/// from `first_slot` on.
pub(crate) fn record(
    pass: &mut wgpu::RenderPass<'_>,
    pipelines: Pipelines,
    bind_group: &wgpu::BindGroup,
    (draws, first_slot): (&[Draw], usize),
) {
    for (slot, draw) in (first_slot..).zip(draws) {
        if let Some((group, images)) = &draw.images {
            pass.set_bind_group(*group, images, &[]);
        }
        let pipelines = match pipelines {
            Pipelines::ByPass(_, all) if draw.shadowed => Pipelines::ByPass(&all.shadowed, all),
            other => other,
        };
        let pipeline = match (pipelines, draw.pass) {
            (Pipelines::One(pipeline), _) => pipeline,
            (Pipelines::ByPass(_, all), Pass::Plane) => &all.plane,
            (Pipelines::ByPass(_, all), Pass::Combine) => &all.combine,
            (Pipelines::ByPass(set, _), Pass::Opaque) => &set.opaque,
            (Pipelines::ByPass(set, _), Pass::OpaqueClosed) => &set.opaque_closed,
            (Pipelines::ByPass(set, _), Pass::Back) => &set.translucent_back,
            (Pipelines::ByPass(set, _), Pass::Front) => &set.translucent_front,
        };
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[(slot as u64 * DRAW_SLOT) as u32]);
        if let Some(vertices) = &draw.vertices {
            pass.set_vertex_buffer(0, vertices.slice(..));
        }
        match &draw.indices {
            Some((indices, count)) => {
                pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..*count, 0, 0..1);
            }
            None => pass.draw(0..draw.vertex_count, 0..1),
        }
    }
}

/// A slice view's picture and where it lies: the plane's corners in patient space (mm) and each
/// corner's coordinates in the picture.
#[derive(Clone, Debug)]
pub(crate) struct PlanePicture {
    pub picture: wgpu::TextureView,
    pub corners: [glam::Vec3; 4],
    pub uv: [glam::Vec2; 4],
}

/// The draws of slice pictures on their planes, seen through `world_to_clip`.
pub(crate) fn plane_draws(
    gpu: &Gpu,
    pipelines: &MeshPipelines,
    sampler: &wgpu::Sampler,
    world_to_clip: Mat4,
    planes: &[PlanePicture],
) -> Result<Vec<Draw>, RuntimeError> {
    let mut out = Vec::with_capacity(planes.len());
    for plane in planes {
        let vertices: Vec<f32> = [0, 1, 2, 0, 2, 3]
            .iter()
            .flat_map(|&i| {
                let (p, uv) = (plane.corners[i], plane.uv[i]);
                [p.x, p.y, p.z, uv.x, uv.y]
            })
            .collect();
        let doing = "drawing a slice view on its plane";
        let buffer = vertex_buffer(gpu, doing, bytemuck::cast_slice(&vertices))?;
        let picture = gpu.capture(doing, || {
            let resources =
                [wgpu::BindingResource::TextureView(&plane.picture), wgpu::BindingResource::Sampler(sampler)];
            pipelines.bindings.bind_group(gpu, 1, &resources)
        })?;
        out.push(Draw {
            pass: Pass::Plane,
            uniforms: DrawUniforms::flat(world_to_clip, [1.0; 4]),
            vertices: Some(buffer),
            indices: None,
            vertex_count: 6,
            images: Some((1, picture)),
            shadowed: false,
        });
    }
    Ok(out)
}

/// The draw that combines an occlusion group's `context` and `focus` images (each its colour and
/// depth) into its parent's, the focus showing through the context with `hidden_opacity`.
pub(crate) fn combine_draw(
    gpu: &Gpu,
    pipelines: &MeshPipelines,
    hidden_opacity: f32,
    [context, focus]: [(&wgpu::TextureView, &wgpu::TextureView); 2],
) -> Result<Draw, RuntimeError> {
    let images = gpu.capture("combining an occlusion group", || {
        let resources = [context.0, context.1, focus.0, focus.1].map(wgpu::BindingResource::TextureView);
        pipelines.bindings.bind_group(gpu, 3, &resources)
    })?;
    Ok(Draw {
        pass: Pass::Combine,
        uniforms: DrawUniforms::flat(Mat4::IDENTITY, [0.0, 0.0, 0.0, hidden_opacity.clamp(0.0, 1.0)]),
        vertices: None,
        indices: None,
        vertex_count: 3,
        images: Some((3, images)),
        shadowed: false,
    })
}

/// A buffer of `contents` for `usage`, its errors those of `doing`.
pub(super) fn buffer(
    gpu: &Gpu,
    doing: &str,
    contents: &[u8],
    usage: wgpu::BufferUsages,
) -> Result<wgpu::Buffer, RuntimeError> {
    let made = gpu.capture(doing, || {
        wgpu::util::DeviceExt::create_buffer_init(
            &gpu.device,
            &wgpu::util::BufferInitDescriptor { label: Some(doing), contents, usage },
        )
    })?;
    Ok(made)
}

fn vertex_buffer(gpu: &Gpu, doing: &str, contents: &[u8]) -> Result<wgpu::Buffer, RuntimeError> {
    buffer(gpu, doing, contents, wgpu::BufferUsages::VERTEX)
}
