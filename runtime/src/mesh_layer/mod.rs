//! The mesh layer of a view: the view's meshes rasterized at its camera into a depth image and
//! a premultiplied colour image, which the volume layer (the composed compute pipeline) reads
//! into `geometry_depth` and `geometry_color` (`BindingKind::GeometryDepth`, `GeometryColor`).
//!
//! Rules the layer keeps (checked by the reference's "Layers"): colour is premultiplied; depth
//! is the WebGPU window depth of the view's own projection (0 near, 1 far, cleared to 1), so
//! `std::meshes` turns it into a ray parameter with the same matrix (`geometry_inv_proj`);
//! opaque meshes write depth, translucent ones are blended over them (back faces, then front
//! faces, in scene order) without writing it. A slice view draws where each mesh crosses its
//! plane, as opaque outlines on the plane ([`outline`]).

pub mod outline;
pub mod pipelines;

use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::mesh::Mesh;
use crate::textures::Image2d;
use glam::Mat4;
use outline::SliceFrame;
use pipelines::{COLOR_FORMAT, DEPTH_FORMAT, DEPTH_IMAGE_FORMAT, DRAW_SLOT, DrawUniforms, MeshPipelines};
use std::sync::Arc;

/// A mesh on the GPU: interleaved positions and normals, and triangle indices.
pub struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
}

impl GpuMesh {
    pub fn upload(gpu: &Gpu, name: &str, mesh: &Mesh) -> Result<GpuMesh, RuntimeError> {
        let interleaved: Vec<f32> =
            mesh.positions.iter().zip(&mesh.normals).flat_map(|(p, n)| [p[0], p[1], p[2], n[0], n[1], n[2]]).collect();
        let doing = format!("uploading mesh `{name}`");
        let buffer = |contents: &[u8], usage| {
            gpu.capture(&doing, || {
                wgpu::util::DeviceExt::create_buffer_init(
                    &gpu.device,
                    &wgpu::util::BufferInitDescriptor { label: Some(name), contents, usage },
                )
            })
        };
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
    pub name: String,
    pub mesh: Arc<Mesh>,
    pub gpu: Arc<GpuMesh>,
    /// sRGB display colour.
    pub color: [f32; 3],
    pub opacity: f32,
    /// The mesh's vertices to patient space (RAS mm).
    pub model: Mat4,
}

/// How a view's mesh layer looks at the meshes.
#[derive(Clone, Copy, Debug)]
pub enum LayerCamera {
    /// A raycast view: its projection of patient space (RAS mm) to clip space.
    Projection { world_to_clip: Mat4 },
    /// A slice view: its plane; meshes show as outlines where they cross it.
    Slice(SliceFrame),
}

/// Outline width in a slice view, in pixels.
const OUTLINE_PIXELS: f32 = 2.0;
/// The clip-space depth of the slice plane in a slice view's mesh layer.
pub const SLICE_PLANE_DEPTH: f32 = 0.5;

/// One view's mesh layer: its two images and what they were drawn from.
pub struct MeshLayer {
    color: wgpu::Texture,
    /// The depth test's buffer.
    depth_buffer: wgpu::TextureView,
    /// The opaque surfaces' depth, as the volume layer reads it.
    depth_view: wgpu::TextureView,
    color_view: wgpu::TextureView,
    /// What the images hold, so tiles and unchanged frames draw nothing again.
    drawn: Option<u64>,
    uniforms: Option<wgpu::Buffer>,
}

impl MeshLayer {
    /// An empty layer (depth 1, no colour) of `size` pixels.
    pub fn new(gpu: &Gpu, size: [u32; 2]) -> Result<MeshLayer, RuntimeError> {
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
            drawn: None,
            uniforms: None,
        })
    }

    pub fn size(&self) -> [u32; 2] {
        [self.color.width(), self.color.height()]
    }

    /// The depth image (`texture_depth_2d`) and the colour image the volume layer binds.
    pub fn views(&self) -> (&wgpu::TextureView, &wgpu::TextureView) {
        (&self.depth_view, &self.color_view)
    }

    /// Records the drawing of `meshes` seen by `camera` into the layer's images, unless they
    /// already hold exactly that picture (`generation` counts changes of the meshes' buffers).
    pub fn encode(
        &mut self,
        gpu: &Gpu,
        pipelines: Option<&MeshPipelines>,
        encoder: &mut wgpu::CommandEncoder,
        camera: &LayerCamera,
        meshes: &[&MeshInstance],
        generation: u64,
    ) -> Result<(), RuntimeError> {
        let key = layer_key(camera, meshes, self.size(), generation);
        if self.drawn == Some(key) {
            return Ok(());
        }
        let draws = match pipelines {
            Some(_) => self.draws(gpu, camera, meshes)?,
            None => Vec::new(),
        };
        let doing = "drawing a mesh layer";
        let uniforms = self.uniform_buffer(gpu, draws.len())?;
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
        let bind_group = pipelines
            .map(|pipelines| {
                gpu.capture(doing, || {
                    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("mesh draws"),
                        layout: &pipelines.layout,
                        entries: &[wgpu::BindGroupEntry {
                            binding: 0,
                            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                buffer: uniforms,
                                offset: 0,
                                size: wgpu::BufferSize::new(std::mem::size_of::<DrawUniforms>() as u64),
                            }),
                        }],
                    })
                })
            })
            .transpose()?;
        gpu.capture(doing, || {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("mesh layer"),
                color_attachments: &[
                    Some(attachment(&self.color_view, wgpu::Color::TRANSPARENT)),
                    Some(attachment(&self.depth_view, wgpu::Color::WHITE)),
                ],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth_buffer,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            let (Some(pipelines), Some(bind_group)) = (pipelines, &bind_group) else { return };
            for (slot, draw) in draws.iter().enumerate() {
                let pipeline = match draw.pass {
                    Pass::Opaque => &pipelines.opaque,
                    Pass::Back => &pipelines.translucent_back,
                    Pass::Front => &pipelines.translucent_front,
                };
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, bind_group, &[(slot as u64 * DRAW_SLOT) as u32]);
                pass.set_vertex_buffer(0, draw.vertices.slice(..));
                match &draw.indices {
                    Some((indices, count)) => {
                        pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
                        pass.draw_indexed(0..*count, 0, 0..1);
                    }
                    None => pass.draw(0..draw.vertex_count, 0..1),
                }
            }
        })?;
        self.drawn = Some(key);
        Ok(())
    }

    /// A uniform buffer with room for `draws` slots (kept while it is large enough).
    fn uniform_buffer(&mut self, gpu: &Gpu, draws: usize) -> Result<&wgpu::Buffer, RuntimeError> {
        let needed = DRAW_SLOT * draws.max(1) as u64;
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
        Ok(self.uniforms.as_ref().expect("made above"))
    }

    /// The draws of a frame, in order: opaque meshes, then each translucent mesh's back and
    /// front faces (raycast views); every mesh's outline (slice views).
    fn draws(&self, gpu: &Gpu, camera: &LayerCamera, meshes: &[&MeshInstance]) -> Result<Vec<Draw>, RuntimeError> {
        let mut out = Vec::new();
        match camera {
            LayerCamera::Projection { world_to_clip } => {
                let clip_to_world = world_to_clip.inverse();
                let (opaque, translucent): (Vec<&MeshInstance>, Vec<&MeshInstance>) =
                    meshes.iter().copied().partition(|m| m.opacity >= 1.0);
                let surface = |m: &MeshInstance, pass| Draw {
                    pass,
                    uniforms: DrawUniforms::surface(*world_to_clip, clip_to_world, m),
                    vertices: m.gpu.vertices.clone(),
                    indices: Some((m.gpu.indices.clone(), m.gpu.index_count)),
                    vertex_count: 0,
                };
                out.extend(opaque.iter().map(|m| surface(m, Pass::Opaque)));
                for m in translucent.iter().filter(|m| m.opacity > 0.0) {
                    out.push(surface(m, Pass::Back));
                    out.push(surface(m, Pass::Front));
                }
            }
            LayerCamera::Slice(frame) => {
                for m in meshes.iter().filter(|m| m.opacity > 0.0) {
                    let quads =
                        outline::outline_quads(&m.mesh, m.model, frame, self.size(), OUTLINE_PIXELS, SLICE_PLANE_DEPTH);
                    if quads.is_empty() {
                        continue;
                    }
                    let vertices = gpu.capture("uploading a slice outline", || {
                        wgpu::util::DeviceExt::create_buffer_init(
                            &gpu.device,
                            &wgpu::util::BufferInitDescriptor {
                                label: Some("outline"),
                                contents: bytemuck::cast_slice(&quads),
                                usage: wgpu::BufferUsages::VERTEX,
                            },
                        )
                    })?;
                    out.push(Draw {
                        pass: Pass::Opaque,
                        uniforms: DrawUniforms::outline(m),
                        vertices,
                        indices: None,
                        vertex_count: (quads.len() / 6) as u32,
                    });
                }
            }
        }
        Ok(out)
    }
}

/// A colour attachment cleared to `clear` and kept.
fn attachment(view: &wgpu::TextureView, clear: wgpu::Color) -> wgpu::RenderPassColorAttachment<'_> {
    wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store },
    }
}

/// Which pipeline a draw uses.
#[derive(Clone, Copy)]
enum Pass {
    Opaque,
    Back,
    Front,
}

/// One draw call of a frame.
struct Draw {
    pass: Pass,
    uniforms: DrawUniforms,
    vertices: wgpu::Buffer,
    indices: Option<(wgpu::Buffer, u32)>,
    vertex_count: u32,
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
        }
    }

    /// Outline quads are in clip space already.
    fn outline(m: &MeshInstance) -> DrawUniforms {
        let identity = Mat4::IDENTITY.to_cols_array_2d();
        DrawUniforms {
            world_to_clip: identity,
            clip_to_world: identity,
            model: identity,
            normal_model: identity,
            color: [m.color[0], m.color[1], m.color[2], 1.0],
            flat: [1.0, 0.0, 0.0, 0.0],
        }
    }
}

/// What a frame is drawn from: the camera, each mesh's placement and look, the image's size,
/// and `generation` (changes of the meshes' surfaces). Equal keys, equal pictures.
fn layer_key(camera: &LayerCamera, meshes: &[&MeshInstance], size: [u32; 2], generation: u64) -> u64 {
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
    bytes.extend(generation.to_le_bytes());
    bytes.extend(bytemuck::cast_slice(&size));
    bytes.push(matches!(camera, LayerCamera::Slice(_)) as u8);
    bytes.extend(meshes.iter().flat_map(|m| Arc::as_ptr(&m.gpu).addr().to_le_bytes()));
    xxhash_rust::xxh3::xxh3_64(&bytes)
}
