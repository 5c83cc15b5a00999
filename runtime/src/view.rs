//! Rendering one view: its picture's nodes (the mesh layer, the volume layer, the overlay, the
//! filter pass; `crate::node`) recorded in order into its output image or any target.

use crate::bricks::BrickView;
use crate::error::RuntimeError;
use crate::filter_pass::{FilterAt, FilterPass};
use crate::gpu::Gpu;
use crate::mesh_layer::{LayerCamera, LayerNode, MeshLayer, OverNode, PlanePicture, UnderNode, ViewLayers};
use crate::node::{Buffer, Frame, PictureNode, Written};
pub use crate::region::Region;
use crate::resources::Resources;
use crate::shader::{PipelineCache, ViewShader};
use crate::textures::{Image2d, TfTexture};
use crate::uniforms::{UniformBlock, Value};
pub use crate::volume_layer::DEFAULT_SAMPLES;
use crate::volume_layer::VolumeLayer;
use std::collections::HashMap;

/// One view's GPU state: its output image and the nodes of its picture. Changing uniforms only
/// rewrites the uniform buffers.
pub struct ViewRenderer {
    output: wgpu::Texture,
    size: [u32; 2],
    /// Its composed ray pipeline.
    volume: VolumeLayer,
    /// The mesh layer under the volume (for a view whose shader reads it), the overlay over it,
    /// and what they draw.
    layers: ViewLayers,
    /// Its filter passes and where each runs: over its picture (its `filters`), or in its
    /// mesh layer (the filters of its tree).
    filters: Vec<(FilterAt, FilterPass)>,
}

/// What the mesh layer wrote for the nodes after it (nothing where the view reads no layer).
fn written(layers: &ViewLayers, reads_layer: bool) -> Written<'_> {
    Written { mesh_layer: layers.views().filter(|_| reads_layer), planes_generation: layers.planes_generation() }
}

/// Rows of a texture-to-buffer copy are padded to this many bytes.
const ROW_ALIGNMENT: u32 = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;

impl ViewRenderer {
    /// The view's own transfer-function tables by binding name
    /// ([`crate::SceneRenderer::set_view_tf_curve`]).
    pub(crate) fn own_tfs_mut(&mut self) -> &mut HashMap<String, TfTexture> {
        self.volume.own_tfs_mut()
    }

    /// A renderer of `shader` at `size` pixels; the pipeline comes from `cache`.
    pub fn new(
        gpu: &Gpu,
        cache: &mut PipelineCache,
        shader: ViewShader,
        size: [u32; 2],
    ) -> Result<ViewRenderer, RuntimeError> {
        let volume = VolumeLayer::new(gpu, cache, shader)?;
        let output = create_output(gpu, size)?;
        Ok(ViewRenderer { output, size, volume, layers: ViewLayers::default(), filters: Vec::new() })
    }

    /// Whether the view is progressive: its picture is the mean of the frames rendered since it
    /// last changed (the path tracer), so rendering it again refines it.
    pub fn is_progressive(&self) -> bool {
        self.volume.is_progressive()
    }

    /// Sets the frames a progressive view's picture holds when [`Self::render`] returns it (at
    /// least 1).
    pub fn set_samples(&mut self, samples: u32) {
        self.volume.set_samples(samples);
    }

    /// The whole frames in the picture of `size` pixels as the view now stands (0 when
    /// anything changed since it was rendered); 1 for a view that is not progressive.
    pub fn frames(&self, size: [u32; 2], resources: &Resources) -> u32 {
        self.volume.frames(size, resources, self.layers.planes_generation())
    }

    /// The WGSL and reflection the view renders with.
    pub fn shader(&self) -> &ViewShader {
        self.volume.shader()
    }

    /// Width and height of the output image in pixels.
    pub fn size(&self) -> [u32; 2] {
        self.size
    }

    /// Its filter passes.
    fn filter_passes(&self) -> impl Iterator<Item = &FilterPass> {
        self.filters.iter().map(|(_, f)| f)
    }

    /// Sets a uniform by name, in the view's shader and in its filter passes (any may read it:
    /// a name means one value); the value must have the uniform's type.
    pub fn set_uniform(&mut self, name: &str, value: impl Into<Value>) -> Result<(), RuntimeError> {
        let value = value.into();
        let passes = self.filters.iter_mut().map(|(_, f)| f);
        let mut set = false;
        for pass in passes.filter(|f| f.has_uniform(name)) {
            pass.set_uniform(name, value.clone())?;
            set = true;
        }
        if set && !self.volume.uniforms().has(name) {
            return Ok(());
        }
        self.volume.set_uniform(name, value)
    }

    /// Whether the shader or a filter pass reads uniform `name` (unreached uniforms are not in
    /// them).
    pub fn has_uniform(&self, name: &str) -> bool {
        self.volume.uniforms().has(name) || self.filter_passes().any(|f| f.has_uniform(name))
    }

    /// The value a scene's JSON gives uniform `name` of the shader or a filter pass, if it fits
    /// the uniform's type.
    pub fn uniform_value_from_json(&self, name: &str, json: &serde_json::Value) -> Option<Value> {
        let filters = || self.filter_passes().find_map(|f| f.uniforms().value_from_json(name, json));
        self.volume.uniforms().value_from_json(name, json).or_else(filters)
    }

    /// The current value of uniform `name`, of the shader or else of a filter pass.
    pub fn uniform(&self, name: &str) -> Option<Value> {
        self.volume.uniforms().get(name).or_else(|| self.filter_passes().find_map(|f| f.uniforms().get(name)))
    }

    /// What the reflection says of uniform `name`, of the shader or else of a filter pass.
    pub fn uniform_info(&self, name: &str) -> Option<&crate::reflection::UniformInfo> {
        let filters = || self.filter_passes().find_map(|f| f.shader().reflection.uniform(name));
        self.volume.shader().reflection.uniform(name).or_else(filters)
    }

    /// Gives the view its filter passes (none: none), each run where it says.
    pub(crate) fn set_filters(
        &mut self,
        gpu: &Gpu,
        cache: &mut PipelineCache,
        shaders: Vec<(FilterAt, ViewShader)>,
    ) -> Result<(), RuntimeError> {
        let passes = shaders.into_iter().map(|(at, shader)| Ok((at, FilterPass::new(gpu, cache, shader)?)));
        self.filters = passes.collect::<Result<_, RuntimeError>>()?;
        Ok(())
    }

    /// The shaders of its filter passes, with where each runs (what [`Self::set_filters`] took).
    pub(crate) fn filter_shaders(&self) -> Vec<(FilterAt, ViewShader)> {
        self.filters.iter().map(|(at, pass)| (*at, pass.shader().clone())).collect()
    }

    /// The reflections of the view's shaders: its own, then its filter passes' (what a panel
    /// lists the uniforms and functions of).
    pub fn reflections(&self) -> impl Iterator<Item = &crate::reflection::Reflection> {
        let filters = self.filter_passes().map(|f| &*f.shader().reflection);
        std::iter::once(&*self.volume.shader().reflection).chain(filters)
    }

    /// The uniform values as they are now (what the next frame uploads).
    pub fn uniforms(&self) -> &UniformBlock {
        self.volume.uniforms()
    }

    /// Whether the shader reads a mesh layer (`geometry_depth`, `geometry_color` or the
    /// translucent layers).
    pub fn reads_mesh_layer(&self) -> bool {
        self.volume.reads_mesh_layer()
    }

    /// Whether the shader blends the mesh layer's translucent surfaces in depth order (it reads
    /// the translucent layers): its mesh layer peels them.
    pub fn reads_translucent_layers(&self) -> bool {
        self.volume.reads_translucent_layers()
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
        self.volume.set_brick_view(view);
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
        let samples = self.volume.samples();
        *self = ViewRenderer::new(gpu, cache, shader, self.size)?;
        self.volume.set_samples(samples);
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
        let frame = &mut Frame { gpu, resources, encoder, target, region };
        let reads_layer = self.volume.reads_mesh_layer();
        let light_volumes = if reads_layer { self.volume.light_volumes(resources) } else { Vec::new() };
        let peeled = self.volume.reads_translucent_layers();
        let filters = &mut self.filters;
        let mut under = UnderNode { layers: &mut self.layers, peeled, light_volumes: &light_volumes, filters };
        let under_access = (under.reads(), under.writes());
        if reads_layer {
            under.encode(frame, Written::default())?;
        }
        debug_assert!(
            self.nodes_read_what_earlier_ones_write(under_access),
            "a node reads what no earlier node writes"
        );
        self.volume.encode(frame, written(&self.layers, reads_layer))?;
        OverNode(&mut self.layers).encode(frame, Written::default())?;
        if let Some(filter) = self.filters.iter_mut().find(|(at, _)| *at == FilterAt::Picture).map(|(_, f)| f) {
            filter.encode(frame, written(&self.layers, reads_layer))?;
        }
        Ok(())
    }

    /// Whether every node of the picture reads only what an earlier one writes (the build's
    /// rules, E0608 and E0609, seen from the runtime).
    fn nodes_read_what_earlier_ones_write(&self, (reads, writes): (Vec<Buffer>, Vec<Buffer>)) -> bool {
        let mut nodes = Vec::new();
        if self.volume.reads_mesh_layer() {
            nodes.push(("mesh layer", reads, writes));
        }
        nodes.push(("volume layer", self.volume.reads(), self.volume.writes()));
        for (_, filter) in self.filters.iter().filter(|(at, _)| *at == FilterAt::Picture) {
            nodes.push(("filters", filter.reads(), filter.writes()));
        }
        crate::node::unwritten_reads(&nodes).is_empty()
    }

    /// Renders and reads the image back (straight alpha RGBA8).
    /// A view that meters its exposure renders twice: the first pass meters the picture the
    /// second one is exposed for. A progressive view first renders the frames its picture
    /// lacks of its samples ([`Self::set_samples`]; one submission each, so that no submission
    /// runs long), and then one more.
    pub fn render(&mut self, gpu: &Gpu, resources: &Resources) -> Result<image::RgbaImage, RuntimeError> {
        if self.is_progressive() {
            let have = self.frames(self.size, resources);
            let doing = format!("rendering the frames of view `{}`", self.volume.shader().reflection.view);
            for _ in have.saturating_add(1)..self.volume.samples() {
                let mut encoder = gpu.device.create_command_encoder(&Default::default());
                self.encode(gpu, resources, &mut encoder)?;
                gpu.capture(&doing, || gpu.queue.submit([encoder.finish()]))?;
            }
        }
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        if self.volume.meters() {
            self.encode(gpu, resources, &mut encoder)?;
        }
        self.encode(gpu, resources, &mut encoder)?;
        let doing = format!("rendering view `{}`", self.volume.shader().reflection.view);
        read_back(gpu, encoder, &self.output, &doing)
    }

    /// Renders the picture and reads back the colour of the part that filter `filter` of the
    /// view's tree (its index among the scene's tree filters) filtered, as that filter left it
    /// (straight alpha RGBA8): what a probe of the filter's fields reads. An error where the
    /// frame ran no such filter (a slice view, whose tree has no groups).
    pub(crate) fn render_filtered_part(
        &mut self,
        gpu: &Gpu,
        resources: &Resources,
        filter: usize,
    ) -> Result<image::RgbaImage, RuntimeError> {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        self.encode(gpu, resources, &mut encoder)?;
        let view = &self.volume.shader().reflection.view;
        let part = self.layers.mesh_layer().and_then(|layer| layer.filtered_part(filter)).ok_or_else(|| {
            RuntimeError::Invalid(format!(
                "view `{view}` runs no filter of its tree (a slice view's tree has no groups): nothing to probe"
            ))
        })?;
        read_back(gpu, encoder, part, &format!("rendering a filtered part of view `{view}`"))
    }
}

/// Submits `encoder` with a copy of `texture` (RGBA8, premultiplied) to a buffer, and reads the
/// copy back as straight alpha; `doing` names the work in errors.
fn read_back(
    gpu: &Gpu,
    mut encoder: wgpu::CommandEncoder,
    texture: &wgpu::Texture,
    doing: &str,
) -> Result<image::RgbaImage, RuntimeError> {
    let [w, h] = [texture.width(), texture.height()];
    let padded_row = (w * 4).div_ceil(ROW_ALIGNMENT) * ROW_ALIGNMENT;
    let readback = gpu.capture(doing, || {
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: u64::from(padded_row) * u64::from(h),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    })?;
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded_row), rows_per_image: Some(h) },
        },
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
    );
    gpu.capture(doing, || gpu.queue.submit([encoder.finish()]))?;
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
