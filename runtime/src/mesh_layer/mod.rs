//! The layers of a view around its volume layer (the composed compute pipeline): the mesh
//! layer under it, the view's meshes and slice views' pictures on their planes rasterized at
//! its camera into a depth image and a premultiplied colour image, which the volume layer reads
//! into `geometry_depth` and `geometry_color` (`BindingKind::GeometryDepth`, `GeometryColor`);
//! and the `Overlay` over the finished picture.
//!
//! Rules the mesh layer keeps (the reference's "Meshes and layers"): colour is premultiplied;
//! depth is the WebGPU window depth of the view's own projection (0 near, 1 far, cleared to 1),
//! so `std::meshes` turns it into a ray parameter with the same matrix (`geometry_inv_proj`);
//! opaque meshes write depth, translucent ones are blended over them (back faces, then front
//! faces, in scene order) without writing it, unless the volume layer blends them into its rays
//! in depth order: then they are peeled into layers (`peel`) and left out of the colour. A
//! slice view draws where each mesh crosses its plane, as opaque outlines on the plane
//! (`outline`).

mod draws;
pub(crate) mod outline;
mod overlay;
mod peel;
pub(crate) mod pipelines;

use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::mesh::Mesh;
use crate::textures::Image2d;
pub(crate) use draws::PlanePicture;
use draws::{DrawBuffer, Pipelines, Target};
use glam::Mat4;
use outline::SliceFrame;
pub(crate) use overlay::Overlay;
use peel::PeeledLayers;
use pipelines::{COLOR_FORMAT, DEPTH_FORMAT, DEPTH_IMAGE_FORMAT, MeshPipelines};
use std::sync::Arc;

/// A mesh on the GPU: interleaved positions and normals, and triangle indices.
pub(crate) struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
}

impl GpuMesh {
    pub(crate) fn upload(gpu: &Gpu, name: &str, mesh: &Mesh) -> Result<GpuMesh, RuntimeError> {
        let interleaved: Vec<f32> =
            mesh.positions.iter().zip(&mesh.normals).flat_map(|(p, n)| [p[0], p[1], p[2], n[0], n[1], n[2]]).collect();
        let doing = format!("uploading mesh `{name}`");
        let buffer = |contents: &[u8], usage| draws::buffer(gpu, &doing, contents, usage);
        Ok(GpuMesh {
            vertices: buffer(bytemuck::cast_slice(&interleaved), wgpu::BufferUsages::VERTEX)?,
            indices: buffer(bytemuck::cast_slice(&mesh.indices), wgpu::BufferUsages::INDEX)?,
            index_count: mesh.indices.len() as u32,
        })
    }
}

/// A mesh as a scene shows it: its surface (kept on the CPU too, for slice outlines), its
/// colour, opacity and placement.
pub struct MeshInstance {
    /// The mesh's name in the scene.
    pub name: String,
    /// The surface, in the mesh's own coordinates (`model` places it).
    pub mesh: Arc<Mesh>,
    pub(crate) gpu: Arc<GpuMesh>,
    /// sRGB display colour.
    pub color: [f32; 3],
    /// 0 (invisible) to 1 (opaque).
    pub opacity: f32,
    /// The mesh's vertices to patient space (RAS mm).
    pub model: Mat4,
    /// The surface is closed and wound outward ([`Mesh::is_closed_outward`]): opaque, its back
    /// faces are culled.
    pub(crate) closed: bool,
}

/// What a mesh layer draws: meshes and slice views' pictures on their planes, seen by a camera.
pub(crate) struct LayerContent<'a> {
    pub camera: &'a LayerCamera,
    pub meshes: &'a [&'a MeshInstance],
    pub planes: &'a [PlanePicture],
    /// Counts changes of the meshes' surfaces and, apart, renders of the planes' pictures.
    pub generation: u64,
    pub planes_generation: u64,
}

/// How a view's mesh layer looks at the meshes.
#[derive(Clone, Copy, Debug)]
pub(crate) enum LayerCamera {
    /// A raycast view: its projection of patient space (RAS mm) to clip space.
    Projection { world_to_clip: Mat4 },
    /// A slice view: its plane; meshes show as outlines where they cross it.
    Slice(SliceFrame),
}

/// The clip-space depth of the slice plane in a slice view's mesh layer.
pub(crate) const SLICE_PLANE_DEPTH: f32 = 0.5;

/// One view's mesh layer: its two images and what they were drawn from.
pub struct MeshLayer {
    color: wgpu::Texture,
    /// The depth test's buffer.
    depth_buffer: wgpu::TextureView,
    /// The opaque surfaces' depth, as the volume layer reads it.
    depth_view: wgpu::TextureView,
    color_view: wgpu::TextureView,
    /// The translucent surfaces peeled into layers, for a volume layer that reads them.
    peeled: Option<PeeledLayers>,
    /// What the images hold, so tiles and unchanged frames draw nothing again.
    drawn: Option<u64>,
    buffer: DrawBuffer,
}

/// The images of a mesh layer that a volume layer binds.
#[derive(Clone, Copy)]
pub(crate) struct LayerViews<'a> {
    /// The opaque surfaces' depth (`r32float`) and the colour.
    pub depth: &'a wgpu::TextureView,
    pub color: &'a wgpu::TextureView,
    /// The translucent layers' depths and colours (`texture_2d_array`), where peeled.
    pub translucent: Option<(&'a wgpu::TextureView, &'a wgpu::TextureView)>,
}

impl MeshLayer {
    /// An empty layer (depth 1, no colour) of `size` pixels; with `peeled`, its translucent
    /// meshes are peeled into layers rather than blended into its colour.
    pub(crate) fn new(gpu: &Gpu, size: [u32; 2], peeled: bool) -> Result<MeshLayer, RuntimeError> {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let doing = format!("creating a {}x{} mesh layer", size[0], size[1]);
        let image = |label, format| Image2d { label, size, format, usage }.create(gpu, &doing);
        let depth_buffer = image("mesh depth buffer", DEPTH_FORMAT)?;
        let depth = image("mesh depth", DEPTH_IMAGE_FORMAT)?;
        let color = image("mesh colour", COLOR_FORMAT)?;
        Ok(MeshLayer {
            depth_buffer: depth_buffer.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            color_view: color.create_view(&Default::default()),
            color,
            peeled: if peeled { Some(PeeledLayers::new(gpu, size)?) } else { None },
            drawn: None,
            buffer: DrawBuffer::default(),
        })
    }

    /// Width and height of the layer's images in pixels (the view's image size).
    pub fn size(&self) -> [u32; 2] {
        [self.color.width(), self.color.height()]
    }

    /// The images the volume layer binds.
    pub(crate) fn views(&self) -> LayerViews<'_> {
        LayerViews {
            depth: &self.depth_view,
            color: &self.color_view,
            translucent: self.peeled.as_ref().map(PeeledLayers::views),
        }
    }

    /// Records the drawing of `content` into the layer's images, unless they already hold
    /// exactly that picture (the tiles of one frame draw it once). `sampler` reads the pictures.
    pub(crate) fn encode(
        &mut self,
        gpu: &Gpu,
        (pipelines, sampler): (Option<&MeshPipelines>, &wgpu::Sampler),
        encoder: &mut wgpu::CommandEncoder,
        content: &LayerContent,
    ) -> Result<(), RuntimeError> {
        let generations = [content.generation, content.planes_generation];
        let key = layer_key(content.camera, content.meshes, self.size(), generations);
        if self.drawn == Some(key) {
            return Ok(());
        }
        let mut draws = Vec::new();
        // Peeled (a raycast view): the translucent meshes are drawn only by the peeling passes,
        // after the others. A slice view outlines every mesh.
        let peels = self.peeled.is_some() && matches!(content.camera, LayerCamera::Projection { .. });
        let (drawn, peeled): (Vec<&MeshInstance>, Vec<&MeshInstance>) =
            content.meshes.iter().copied().partition(|m| !peels || m.opacity >= 1.0);
        let mut layer_draws = 0;
        if let Some(pipelines) = pipelines {
            if let LayerCamera::Projection { world_to_clip } = content.camera {
                draws = draws::plane_draws(gpu, pipelines, sampler, *world_to_clip, content.planes)?;
            }
            draws.extend(draws::frame_draws(gpu, content.camera, &drawn, self.size(), Target::Layer)?);
            layer_draws = draws.len();
            if let (LayerCamera::Projection { world_to_clip }, Some(_)) = (content.camera, &self.peeled) {
                draws.extend(draws::peel_draws(*world_to_clip, &peeled));
            }
        }
        let bind_group = self.buffer.bind(gpu, pipelines, &draws)?;
        let doing = "drawing a mesh layer";
        gpu.capture(doing, || {
            let targets = [
                Some(attachment(&self.color_view, wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT))),
                Some(attachment(&self.depth_view, wgpu::LoadOp::Clear(wgpu::Color::WHITE))),
            ];
            let depth = Some(depth_attachment(&self.depth_buffer));
            let mut pass = encoder.begin_render_pass(&pass_descriptor("mesh layer", &targets, depth));
            if let (Some(pipelines), Some(bind_group)) = (pipelines, &bind_group) {
                let by_pass = Pipelines::ByPass(&pipelines.layer, &pipelines.plane);
                draws::record(&mut pass, by_pass, bind_group, (&draws[..layer_draws], 0));
            }
        })?;
        if let (Some(peeled), Some(pipelines), Some(bind_group)) = (&mut self.peeled, pipelines, &bind_group) {
            let translucent = (bind_group, &draws[layer_draws..], layer_draws);
            peeled.encode(gpu, pipelines, encoder, &self.depth_view, translucent)?;
        }
        self.drawn = Some(key);
        Ok(())
    }
}

/// A colour attachment loaded as `load` says and kept.
fn attachment(view: &wgpu::TextureView, load: wgpu::LoadOp<wgpu::Color>) -> wgpu::RenderPassColorAttachment<'_> {
    wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
    }
}

/// A render pass `label` into `color_attachments` and `depth_stencil_attachment`.
fn pass_descriptor<'a>(
    label: &'a str,
    color_attachments: &'a [Option<wgpu::RenderPassColorAttachment<'a>>],
    depth_stencil_attachment: Option<wgpu::RenderPassDepthStencilAttachment<'a>>,
) -> wgpu::RenderPassDescriptor<'a> {
    wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments,
        depth_stencil_attachment,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    }
}

/// A depth buffer cleared to 1 (the far plane).
fn depth_attachment(view: &wgpu::TextureView) -> wgpu::RenderPassDepthStencilAttachment<'_> {
    wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
        stencil_ops: None,
    }
}

/// What a frame is drawn from: the camera, each mesh's placement and look, the image's size,
/// and `generations` (changes of the meshes' surfaces, renders of the planes' pictures). Equal
/// keys, equal pictures.
fn layer_key(camera: &LayerCamera, meshes: &[&MeshInstance], size: [u32; 2], generations: [u64; 2]) -> u64 {
    let mut floats: Vec<f32> = match camera {
        LayerCamera::Projection { world_to_clip } => world_to_clip.to_cols_array().to_vec(),
        LayerCamera::Slice(frame) => frame.image_to_world.to_cols_array().to_vec(),
    };
    for m in meshes {
        floats.extend(m.model.to_cols_array());
        floats.extend(m.color);
        floats.push(m.opacity);
    }
    let mut bytes: Vec<u8> = bytemuck::cast_slice(&floats).to_vec();
    bytes.extend(generations.iter().flat_map(|g| g.to_le_bytes()));
    bytes.extend(bytemuck::cast_slice(&size));
    bytes.push(matches!(camera, LayerCamera::Slice(_)) as u8);
    bytes.extend(meshes.iter().flat_map(|m| Arc::as_ptr(&m.gpu).addr().to_le_bytes()));
    xxhash_rust::xxh3::xxh3_64(&bytes)
}
