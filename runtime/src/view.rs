//! Rendering one view: its pipeline, its uniform block and buffer, its output image, and the
//! shared volumes and transfer functions it binds by name.

use crate::bindings::{self, DispatchResources};
use crate::bricks::{BrickView, ViewBrickLayouts};
use crate::error::RuntimeError;
use crate::filter_pass::FilterPass;
use crate::gpu::Gpu;
use crate::history::History;
use crate::mesh_layer::{LayerCamera, LayerNode, MeshLayer, MeshResources, PlanePicture, ViewLayers};
use crate::metering::Metering;
use crate::reflection::BindingKind;
pub use crate::region::Region;
use crate::resources::Resources;
use crate::shader::{PipelineCache, ViewPipeline, ViewShader};
use crate::textures::{Image2d, TfTexture, VolumeTexture};
use crate::uniforms::{UniformBlock, Value};
use std::collections::HashMap;
use std::sync::Arc;
use vrsc::compose::uniform_check::LIGHT_VOLUME_PREFIX;

/// One view's GPU state. Changing uniforms only rewrites the uniform buffer.
pub struct ViewRenderer {
    shader: ViewShader,
    pipeline: Arc<ViewPipeline>,
    uniforms: UniformBlock,
    uniform_buffer: wgpu::Buffer,
    output: wgpu::Texture,
    size: [u32; 2],
    /// Automatic exposure's luminance image and reduction, for a view that meters.
    metering: Option<Metering>,
    /// The mesh layer under the volume (for a view whose shader reads it), the overlay over it,
    /// and what they draw.
    layers: ViewLayers,
    /// Its `BrickLayout` uniforms, one per bricked volume it reads.
    brick_layouts: ViewBrickLayouts,
    /// Transfer-function tables of the view's own, bound in place of the scene's of the same
    /// name (a slice view's window/level).
    own_tfs: HashMap<String, TfTexture>,
    /// The pixels' history of a progressive view (the path tracer), and the frames
    /// [`Self::render`] makes it hold.
    history: Option<History>,
    samples: u32,
    /// The view's filter pass, run over its picture (its `filters`).
    filter: Option<FilterPass>,
}

/// Frames a progressive view's picture holds when [`ViewRenderer::render`] returns it, unless
/// [`ViewRenderer::set_samples`] says otherwise.
pub const DEFAULT_SAMPLES: u32 = 16;

/// What a view's layers draw with, of the scene's resources, with the light volumes of the
/// lights its volume casts shadows from.
fn mesh_resources<'a>(
    resources: &'a Resources,
    light_volumes: &'a [(String, Arc<VolumeTexture>)],
) -> MeshResources<'a> {
    MeshResources {
        pipelines: resources.mesh_pipelines.as_ref(),
        meshes: &resources.meshes,
        sampler: &resources.sampler,
        generation: resources.mesh_generation(),
        light_volumes,
    }
}

/// The light volumes a view's shader binds (`shadow_volume_NAME`: its volume casts shadows
/// from light NAME), by light name.
fn light_volumes(shader: &ViewShader, resources: &Resources) -> Vec<(String, Arc<VolumeTexture>)> {
    let bound = shader.reflection.bindings.iter().filter(|b| b.kind == BindingKind::VolumeTexture);
    bound
        .filter_map(|b| {
            let light = b.name.strip_prefix(LIGHT_VOLUME_PREFIX)?;
            Some((light.to_string(), resources.volumes.get(&b.name)?.clone()))
        })
        .collect()
}

/// `std::mesh_shadow`'s uniform of light NAME's shadow clip space is this prefix and NAME.
pub(crate) const MESH_SHADOW_CLIP_PREFIX: &str = "mesh_shadow_clip_";

/// Rows of a texture-to-buffer copy are padded to this many bytes.
const ROW_ALIGNMENT: u32 = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;

impl ViewRenderer {
    /// The view's own transfer-function tables by binding name
    /// ([`crate::SceneRenderer::set_view_tf_curve`]).
    pub(crate) fn own_tfs_mut(&mut self) -> &mut HashMap<String, TfTexture> {
        &mut self.own_tfs
    }

    /// A renderer of `shader` at `size` pixels; the pipeline comes from `cache`.
    pub fn new(
        gpu: &Gpu,
        cache: &mut PipelineCache,
        shader: ViewShader,
        size: [u32; 2],
    ) -> Result<ViewRenderer, RuntimeError> {
        let pipeline = cache.get(gpu, &shader)?;
        let uniforms = UniformBlock::new(&shader.reflection);
        let doing = format!("creating the uniform buffer of view `{}`", shader.reflection.view);
        let uniform_buffer = gpu.capture(&doing, || {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("uniforms"),
                size: uniforms.bytes().len() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        let output = create_output(gpu, size)?;
        let metering = Metering::of(gpu, &shader.reflection).transpose()?;
        let history = shader.reflection.bindings.iter().any(|b| b.kind == BindingKind::History).then(History::default);
        Ok(ViewRenderer {
            shader,
            pipeline,
            uniforms,
            uniform_buffer,
            output,
            size,
            metering,
            layers: ViewLayers::default(),
            brick_layouts: ViewBrickLayouts::default(),
            own_tfs: HashMap::new(),
            history,
            samples: DEFAULT_SAMPLES,
            filter: None,
        })
    }

    /// Whether the view is progressive: its picture is the mean of the frames rendered since it
    /// last changed (the path tracer), so rendering it again refines it.
    pub fn is_progressive(&self) -> bool {
        self.history.is_some()
    }

    /// Sets the frames a progressive view's picture holds when [`Self::render`] returns it (at
    /// least 1).
    pub fn set_samples(&mut self, samples: u32) {
        self.samples = samples.max(1);
    }

    /// The whole frames in the picture of `size` pixels as the view now stands (0 when
    /// anything changed since it was rendered); 1 for a view that is not progressive.
    pub fn frames(&self, size: [u32; 2], resources: &Resources) -> u32 {
        match &self.history {
            Some(history) => history.frames(size, self.history_key(resources)),
            None => 1,
        }
    }

    /// What the picture is rendered from: the uniforms, the shared content, and what the view
    /// draws besides (its planes' pictures).
    fn history_key(&self, resources: &Resources) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        self.uniforms.bytes().hash(&mut hasher);
        (resources.content(), self.layers.planes_generation()).hash(&mut hasher);
        hasher.finish()
    }

    /// The WGSL and reflection the view renders with.
    pub fn shader(&self) -> &ViewShader {
        &self.shader
    }

    /// Width and height of the output image in pixels.
    pub fn size(&self) -> [u32; 2] {
        self.size
    }

    /// Sets a uniform by name, in the view's shader and in its filter pass (either may read
    /// it); the value must have the uniform's type.
    pub fn set_uniform(&mut self, name: &str, value: impl Into<Value>) -> Result<(), RuntimeError> {
        let value = value.into();
        let view = &self.shader.reflection.view;
        if let Some(filter) = self.filter.as_mut().filter(|f| f.has_uniform(name)) {
            filter.set_uniform(name, value.clone())?;
            if !self.uniforms.has(name) {
                return Ok(());
            }
        }
        self.uniforms.set(name, value).map_err(|error| RuntimeError::Uniform { view: view.clone(), error })
    }

    /// Whether the shader or the filter pass reads uniform `name` (unreached uniforms are not in
    /// them).
    pub fn has_uniform(&self, name: &str) -> bool {
        self.uniforms.has(name) || self.filter.as_ref().is_some_and(|f| f.has_uniform(name))
    }

    /// The value a scene's JSON gives uniform `name` of the shader or the filter pass, if it fits
    /// the uniform's type.
    pub fn uniform_value_from_json(&self, name: &str, json: &serde_json::Value) -> Option<Value> {
        self.uniforms
            .value_from_json(name, json)
            .or_else(|| self.filter.as_ref().and_then(|f| f.uniforms().value_from_json(name, json)))
    }

    /// The current value of uniform `name`, of the shader or else of the filter pass.
    pub fn uniform(&self, name: &str) -> Option<Value> {
        self.uniforms.get(name).or_else(|| self.filter.as_ref().and_then(|f| f.uniforms().get(name)))
    }

    /// What the reflection says of uniform `name`, of the shader or else of the filter pass.
    pub fn uniform_info(&self, name: &str) -> Option<&crate::reflection::UniformInfo> {
        let filter = || self.filter.as_ref().and_then(|f| f.shader().reflection.uniform(name));
        self.shader.reflection.uniform(name).or_else(filter)
    }

    /// Gives the view a filter pass (`None`: none), run after its picture.
    pub(crate) fn set_filter(
        &mut self,
        gpu: &Gpu,
        cache: &mut PipelineCache,
        shader: Option<ViewShader>,
    ) -> Result<(), RuntimeError> {
        self.filter = shader.map(|shader| FilterPass::new(gpu, cache, shader)).transpose()?;
        Ok(())
    }

    /// The reflections of the view's shaders: its own, then its filter pass's (what a panel
    /// lists the uniforms and functions of).
    pub fn reflections(&self) -> impl Iterator<Item = &crate::reflection::Reflection> {
        let filter = self.filter.as_ref().map(|f| &*f.shader().reflection);
        std::iter::once(&*self.shader.reflection).chain(filter)
    }

    /// The compiled filter pass, when the view has one.
    pub fn filter_shader(&self) -> Option<&ViewShader> {
        self.filter.as_ref().map(FilterPass::shader)
    }

    /// The filter pass's uniform values, when the view has one.
    pub fn filter_uniforms(&self) -> Option<&UniformBlock> {
        self.filter.as_ref().map(FilterPass::uniforms)
    }

    /// The uniform values as they are now (what the next frame uploads).
    pub fn uniforms(&self) -> &UniformBlock {
        &self.uniforms
    }

    /// Whether the shader reads a mesh layer (`geometry_depth`, `geometry_color` or the
    /// translucent layers).
    pub fn reads_mesh_layer(&self) -> bool {
        self.shader.reflection.bindings.iter().any(|b| {
            matches!(
                b.kind,
                BindingKind::GeometryDepth
                    | BindingKind::GeometryColor
                    | BindingKind::TranslucentDepth
                    | BindingKind::TranslucentColor
            )
        })
    }

    /// Whether the shader blends the mesh layer's translucent surfaces in depth order (it reads
    /// the translucent layers): its mesh layer peels them.
    pub fn reads_translucent_layers(&self) -> bool {
        self.shader
            .reflection
            .bindings
            .iter()
            .any(|b| matches!(b.kind, BindingKind::TranslucentDepth | BindingKind::TranslucentColor))
    }

    /// How the mesh layer and the overlay look at the meshes, the tree the layer draws and the
    /// meshes the overlay draws (indices into `Resources::meshes`); without it the layer is
    /// empty (depth 1, no colour) and nothing is drawn over the picture.
    pub(crate) fn set_mesh_layer(&mut self, camera: LayerCamera, tree: Vec<LayerNode>, overlay: Vec<usize>) {
        self.layers.set(camera, tree, overlay);
    }

    /// Where the primary volume lies for the mesh layer: patient space to its normalized
    /// coordinates.
    pub(crate) fn set_world_to_volume(&mut self, world_to_volume: glam::Mat4) {
        self.layers.set_world_to_volume(world_to_volume);
    }

    /// The slice pictures the mesh layer shows on their planes, just rendered (their views
    /// render first): the layer is drawn again with them.
    pub(crate) fn set_planes(&mut self, planes: Vec<Option<PlanePicture>>) {
        self.layers.set_planes(planes);
    }

    /// How the view looks at its bricked volumes (set with its camera or plane every frame).
    pub(crate) fn set_brick_view(&mut self, view: BrickView) {
        self.brick_layouts.set_view(view);
    }

    /// Writes the `BrickLayout` of every bricked volume the view reads, for a target `height`
    /// pixels high.
    fn write_brick_layouts(&mut self, gpu: &Gpu, resources: &Resources, height: u32) -> Result<(), RuntimeError> {
        let reflection = &self.shader.reflection;
        let names: Vec<String> =
            reflection.bindings.iter().filter(|b| b.kind == BindingKind::BrickLayout).map(|b| b.name.clone()).collect();
        self.brick_layouts.write(gpu, &resources.bricked, (&names, &reflection.view), height)
    }

    /// The slice pictures the mesh layer shows on their planes.
    pub(crate) fn planes(&self) -> &[Option<PlanePicture>] {
        self.layers.planes()
    }

    /// The mesh layer as last drawn, at the size of the last target (for probes and tests).
    pub fn mesh_layer(&self) -> Option<&MeshLayer> {
        self.layers.mesh_layer()
    }

    /// Swaps in another shader of the same view (a structural change), keeping the size. Uniform
    /// values start again from the new reflection.
    pub(crate) fn set_shader(
        &mut self,
        gpu: &Gpu,
        cache: &mut PipelineCache,
        shader: ViewShader,
    ) -> Result<(), RuntimeError> {
        let samples = self.samples;
        *self = ViewRenderer::new(gpu, cache, shader, self.size)?;
        self.samples = samples;
        Ok(())
    }

    /// The texture every `ViewRenderer::encode` renders into: `Rgba8Unorm` with premultiplied
    /// alpha, usable as a sampled texture, so an application can draw it without reading it back.
    pub fn output(&self) -> &wgpu::Texture {
        &self.output
    }

    /// Changes the output size (a new, uninitialised output texture); uniforms stay. A size
    /// the device cannot hold is an error, and the renderer keeps its size and image.
    pub fn resize(&mut self, gpu: &Gpu, size: [u32; 2]) -> Result<(), RuntimeError> {
        if size != self.size {
            self.output = create_output(gpu, size)?;
            self.size = size;
        }
        Ok(())
    }

    /// Records the view's compute pass into `encoder`: the whole image, into [`Self::output`].
    pub(crate) fn encode(
        &mut self,
        gpu: &Gpu,
        resources: &Resources,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<(), RuntimeError> {
        let target = self.output.create_view(&Default::default());
        let [w, h] = self.size;
        self.encode_into(gpu, resources, encoder, &target, Region::whole([w, h]))
    }

    /// Records a compute pass that renders `region` of the image into `target`, a texture made
    /// by [`create_output`] (of any size: the pixel positions the pipeline sees are relative to
    /// the target's size). Several regions may be recorded into one encoder: render a large view
    /// in tiles, or at a lower resolution into a smaller target, with the same uniforms.
    pub(crate) fn encode_into(
        &mut self,
        gpu: &Gpu,
        resources: &Resources,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        region: Region,
    ) -> Result<(), RuntimeError> {
        self.write_brick_layouts(gpu, resources, target.texture().size().height)?;
        let reads_layer = self.reads_mesh_layer();
        if reads_layer {
            let size = target.texture().size();
            let peeled = self.reads_translucent_layers();
            let light_volumes = light_volumes(&self.shader, resources);
            let layer_resources = mesh_resources(resources, &light_volumes);
            self.layers.encode_under(gpu, layer_resources, encoder, ([size.width, size.height], peeled))?;
            self.follow_mesh_shadows()?;
        }
        if let Some(bytes) = self.uniforms.take_changes() {
            gpu.queue.write_buffer(&self.uniform_buffer, 0, bytes);
        }
        let reflection = &self.shader.reflection;
        let doing = format!("binding the resources of view `{}`", reflection.view);
        let region_buffer = gpu.capture(&doing, || {
            wgpu::util::DeviceExt::create_buffer_init(
                &gpu.device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("region"),
                    contents: bytemuck::cast_slice(&[region.x0, region.y0, region.x1, region.y1]),
                    usage: wgpu::BufferUsages::UNIFORM,
                },
            )
        })?;
        let target_size = target.texture().size();
        // Only a progressive view hashes its uniforms: every other dispatch skips it.
        let key = self.history.as_ref().map(|_| self.history_key(resources));
        let luminance = match &mut self.metering {
            Some(metering) => {
                metering.before_pass(encoder, &self.uniform_buffer);
                Some(metering.image(gpu, [target_size.width, target_size.height])?)
            }
            None => None,
        };
        let history = match (&mut self.history, key) {
            (Some(history), Some(key)) => {
                let size = [target_size.width, target_size.height];
                Some(history.prepare(gpu, encoder, size, key, region.within(size).pixels())?)
            }
            _ => None,
        };
        let mesh_layer = self.layers.views().filter(|_| reads_layer);
        let own = DispatchResources {
            history,
            uniforms: &self.uniform_buffer,
            region: &region_buffer,
            output: target,
            luminance,
            mesh_layer,
            brick_layouts: self.brick_layouts.buffers(),
            tfs: &self.own_tfs,
            picture: None,
        };
        let mut groups = Vec::with_capacity(self.pipeline.groups.len());
        for (group, layout) in (0u32..).zip(&self.pipeline.groups) {
            let entries = bindings::group_entries(reflection, group, resources, &own)?;
            let made = gpu.capture(&doing, || {
                gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(&reflection.view),
                    layout,
                    entries: &entries,
                })
            });
            groups.push(made?);
        }
        let [wx, wy, _] = reflection.workgroup_size;
        let (w, h) = (region.x1.saturating_sub(region.x0), region.y1.saturating_sub(region.y0));
        let doing = format!("recording the pass of view `{}`", reflection.view);
        gpu.capture(&doing, || {
            let mut pass = encoder
                .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("raycast"), timestamp_writes: None });
            pass.set_pipeline(&self.pipeline.pipeline);
            for (group, bind_group) in (0u32..).zip(&groups) {
                pass.set_bind_group(group, bind_group, &[]);
            }
            pass.dispatch_workgroups(w.div_ceil(wx.max(1)), h.div_ceil(wy.max(1)), 1);
        })?;
        if let Some(metering) = &self.metering {
            metering.after_pass(gpu, encoder)?;
        }
        self.layers.encode_over(gpu, mesh_resources(resources, &[]), encoder, target)?;
        if let Some(filter) = &mut self.filter {
            let mesh_layer = self.layers.views().filter(|_| reads_layer);
            filter.encode(gpu, (resources, mesh_layer), encoder, target, region)?;
        }
        Ok(())
    }

    /// Sets `mesh_shadow_clip_NAME` (`std::mesh_shadow`) to the clip space of the shadow map
    /// the mesh layer drew last for light NAME.
    fn follow_mesh_shadows(&mut self) -> Result<(), RuntimeError> {
        let Some(views) = self.layers.views() else { return Ok(()) };
        let mut seen: Vec<&str> = Vec::new();
        for followed in views.followed() {
            let name = format!("{MESH_SHADOW_CLIP_PREFIX}{}", followed.light);
            if seen.contains(&followed.light.as_str()) || !self.uniforms.has(&name) {
                continue;
            }
            seen.push(&followed.light);
            let view = &self.shader.reflection.view;
            self.uniforms
                .set(&name, followed.light_to_clip)
                .map_err(|error| RuntimeError::Uniform { view: view.clone(), error })?;
        }
        Ok(())
    }

    /// Renders and reads the image back (straight alpha RGBA8).
    /// A view that meters its exposure renders twice: the first pass meters the picture the
    /// second one is exposed for. A progressive view first renders the frames its picture
    /// lacks of [`Self::samples`] (one submission each, so that no submission runs long), and
    /// then one more.
    pub fn render(&mut self, gpu: &Gpu, resources: &Resources) -> Result<image::RgbaImage, RuntimeError> {
        if self.is_progressive() {
            let have = self.frames(self.size, resources);
            let doing = format!("rendering the frames of view `{}`", self.shader.reflection.view);
            for _ in have.saturating_add(1)..self.samples {
                let mut encoder = gpu.device.create_command_encoder(&Default::default());
                self.encode(gpu, resources, &mut encoder)?;
                gpu.capture(&doing, || gpu.queue.submit([encoder.finish()]))?;
            }
        }
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        if self.metering.is_some() {
            self.encode(gpu, resources, &mut encoder)?;
        }
        self.encode(gpu, resources, &mut encoder)?;
        let [w, h] = self.size;
        let padded_row = (w * 4).div_ceil(ROW_ALIGNMENT) * ROW_ALIGNMENT;
        let doing = format!("rendering view `{}`", self.shader.reflection.view);
        let readback = gpu.capture(&doing, || {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size: u64::from(padded_row) * u64::from(h),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        encoder.copy_texture_to_buffer(
            self.output.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_row),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        gpu.capture(&doing, || gpu.queue.submit([encoder.finish()]))?;
        let slice = readback.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        gpu.wait();
        // Whatever escaped the captures (nothing should) fails the render rather than a panic.
        if let Some(fault) = gpu.take_fault() {
            return Err(fault.into());
        }
        let mapped =
            slice.get_mapped_range().map_err(|e| RuntimeError::Invalid(format!("cannot read the image back: {e}")))?;
        let mut pixels = Vec::with_capacity((w * h * 4) as usize);
        for row in mapped.chunks(padded_row as usize) {
            pixels.extend_from_slice(&row[..(w * 4) as usize]);
        }
        drop(mapped);
        readback.unmap();
        unpremultiply(&mut pixels);
        image::RgbaImage::from_raw(w, h, pixels).ok_or_else(|| RuntimeError::Invalid("image size mismatch".into()))
    }
}

/// A texture a view can render into (see `ViewRenderer::encode_into`): `Rgba8Unorm`, written
/// as storage (and as a render attachment by the overlay), sampled by an application, copied
/// out for read-back. A size beyond the device's
/// limits (or its memory) is an error.
pub fn create_output(gpu: &Gpu, [w, h]: [u32; 2]) -> Result<wgpu::Texture, RuntimeError> {
    let usage = wgpu::TextureUsages::STORAGE_BINDING
        | wgpu::TextureUsages::TEXTURE_BINDING
        | wgpu::TextureUsages::RENDER_ATTACHMENT
        | wgpu::TextureUsages::COPY_SRC
        | wgpu::TextureUsages::COPY_DST;
    let image = Image2d { label: "view output", size: [w, h], format: wgpu::TextureFormat::Rgba8Unorm, usage };
    image.create(gpu, &format!("creating a {w}x{h} image"))
}

/// The shader writes premultiplied colour; PNG wants straight alpha.
fn unpremultiply(pixels: &mut [u8]) {
    for px in pixels.chunks_exact_mut(4) {
        let a = px[3];
        if a != 0 && a != 255 {
            for c in &mut px[..3] {
                *c = ((u32::from(*c) * 255 + u32::from(a) / 2) / u32::from(a)).min(255) as u8;
            }
        }
    }
}
