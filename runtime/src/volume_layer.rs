//! A view's volume layer: its composed ray pipeline and what a dispatch of it binds (its
//! uniforms, its luminance metering, a progressive view's history, its bricked volumes' layouts,
//! its own transfer functions). One node of the view's picture (`crate::node`): it reads the
//! mesh layer and writes the picture.

use crate::bindings::DispatchResources;
use crate::bricks::{BrickView, ViewBrickLayouts};
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::history::History;
use crate::mesh_layer::LayerViews;
use crate::metering::Metering;
use crate::node::{self, Buffer, Frame, PictureNode, Written};
use crate::reflection::BindingKind;
use crate::resources::Resources;
use crate::shader::{PipelineCache, ViewPipeline, ViewShader};
use crate::textures::{TfTexture, VolumeTexture};
use crate::uniforms::{UniformBlock, Value};
use std::collections::HashMap;
use std::sync::Arc;
use vrsc::compose::MESH_SHADOW_MAP_PREFIX;
use vrsc::compose::uniform_check::LIGHT_VOLUME_PREFIX;

/// Frames a progressive view's picture holds when `ViewRenderer::render` returns it, unless
/// `ViewRenderer::set_samples` says otherwise.
pub const DEFAULT_SAMPLES: u32 = 16;

/// `std::mesh_shadow`'s uniform of light NAME's shadow clip space is this prefix and NAME.
pub(crate) const MESH_SHADOW_CLIP_PREFIX: &str = "mesh_shadow_clip_";

/// The lights whose light volume `shader`'s view needs (`VolumeLayer::light_volumes`), each
/// once.
pub(crate) fn shadowed_lights(shader: &ViewShader) -> impl Iterator<Item = &str> {
    let mut seen: Vec<&str> = Vec::new();
    shader.reflection.bindings.iter().filter_map(move |b| {
        let light = match b.kind {
            BindingKind::VolumeTexture => b.name.strip_prefix(LIGHT_VOLUME_PREFIX)?,
            _ => b.name.strip_prefix(MESH_SHADOW_MAP_PREFIX)?,
        };
        (!seen.contains(&light)).then(|| {
            seen.push(light);
            light
        })
    })
}

/// A view's ray pipeline and its state.
pub(crate) struct VolumeLayer {
    shader: ViewShader,
    pipeline: Arc<ViewPipeline>,
    uniforms: UniformBlock,
    uniform_buffer: wgpu::Buffer,
    /// Automatic exposure's luminance image and reduction, for a view that meters.
    metering: Option<Metering>,
    /// Its `BrickLayout` uniforms, one per bricked volume it reads.
    brick_layouts: ViewBrickLayouts,
    /// Transfer-function tables of the view's own, bound in place of the scene's of the same
    /// name (a slice view's window/level).
    own_tfs: HashMap<String, TfTexture>,
    /// The pixels' history of a progressive view (the path tracer), and the frames its picture
    /// holds when rendered.
    history: Option<History>,
    samples: u32,
}

impl VolumeLayer {
    /// The layer of `shader`; the pipeline comes from `cache`.
    pub(crate) fn new(gpu: &Gpu, cache: &mut PipelineCache, shader: ViewShader) -> Result<VolumeLayer, RuntimeError> {
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
        let metering = Metering::of(gpu, &shader.reflection).transpose()?;
        let history = shader.reflection.bindings.iter().any(|b| b.kind == BindingKind::History).then(History::default);
        Ok(VolumeLayer {
            shader,
            pipeline,
            uniforms,
            uniform_buffer,
            metering,
            brick_layouts: ViewBrickLayouts::default(),
            own_tfs: HashMap::new(),
            history,
            samples: DEFAULT_SAMPLES,
        })
    }

    pub(crate) fn shader(&self) -> &ViewShader {
        &self.shader
    }

    pub(crate) fn uniforms(&self) -> &UniformBlock {
        &self.uniforms
    }

    pub(crate) fn set_uniform(&mut self, name: &str, value: impl Into<Value>) -> Result<(), RuntimeError> {
        let view = &self.shader.reflection.view;
        self.uniforms.set(name, value).map_err(|error| RuntimeError::Uniform { view: view.clone(), error })
    }

    pub(crate) fn own_tfs_mut(&mut self) -> &mut HashMap<String, TfTexture> {
        &mut self.own_tfs
    }

    pub(crate) fn set_brick_view(&mut self, view: BrickView) {
        self.brick_layouts.set_view(view);
    }

    /// Whether it meters luminance for automatic exposure (a render takes two passes).
    pub(crate) fn meters(&self) -> bool {
        self.metering.is_some()
    }

    pub(crate) fn is_progressive(&self) -> bool {
        self.history.is_some()
    }

    pub(crate) fn samples(&self) -> u32 {
        self.samples
    }

    pub(crate) fn set_samples(&mut self, samples: u32) {
        self.samples = samples.max(1);
    }

    /// The whole frames in the picture of `size` pixels as the view now stands (see
    /// `ViewRenderer::frames`).
    pub(crate) fn frames(&self, size: [u32; 2], resources: &Resources, planes_generation: u64) -> u32 {
        match &self.history {
            Some(history) => history.frames(size, self.history_key(resources, planes_generation)),
            None => 1,
        }
    }

    /// What the picture is rendered from: the uniforms, the shared content, and what the view
    /// draws besides (its planes' pictures).
    fn history_key(&self, resources: &Resources, planes_generation: u64) -> u64 {
        use std::hash::{Hash, Hasher};
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        self.uniforms.bytes().hash(&mut hasher);
        (resources.content(), planes_generation).hash(&mut hasher);
        hasher.finish()
    }

    /// Whether the shader reads a mesh layer (`geometry_depth`, `geometry_color` or the
    /// translucent layers).
    pub(crate) fn reads_mesh_layer(&self) -> bool {
        self.binds(&[
            BindingKind::GeometryDepth,
            BindingKind::GeometryColor,
            BindingKind::TranslucentDepth,
            BindingKind::TranslucentColor,
        ])
    }

    /// Whether the shader blends the mesh layer's translucent surfaces in depth order: its mesh
    /// layer peels them.
    pub(crate) fn reads_translucent_layers(&self) -> bool {
        self.binds(&[BindingKind::TranslucentDepth, BindingKind::TranslucentColor])
    }

    fn binds(&self, kinds: &[BindingKind]) -> bool {
        self.shader.reflection.bindings.iter().any(|b| kinds.contains(&b.kind))
    }

    /// The light volumes the view needs, by light name: those it binds (`shadow_volume_NAME`:
    /// the volume casts shadows from light NAME) and those of the lights its shadow groups'
    /// meshes shadow the volume from (`mesh_shadow_map_NAME`), so the volume shadows those
    /// meshes back whatever its own `shadows`.
    pub(crate) fn light_volumes(&self, resources: &Resources) -> Vec<(String, Arc<VolumeTexture>)> {
        shadowed_lights(&self.shader)
            .filter_map(|light| {
                let texture = resources.volumes.get(&format!("{LIGHT_VOLUME_PREFIX}{light}"))?;
                Some((light.to_string(), texture.clone()))
            })
            .collect()
    }

    /// Sets `mesh_shadow_clip_NAME` (`std::mesh_shadow`) to the clip space of the shadow map
    /// the mesh layer drew for light NAME (the first group that follows it).
    fn follow_mesh_shadows(&mut self, views: Option<LayerViews<'_>>) -> Result<(), RuntimeError> {
        let Some(views) = views else { return Ok(()) };
        let mut seen: Vec<&str> = Vec::new();
        for followed in views.followed() {
            let name = format!("{MESH_SHADOW_CLIP_PREFIX}{}", followed.light);
            if seen.contains(&followed.light.as_str()) || !self.uniforms.has(&name) {
                continue;
            }
            seen.push(&followed.light);
            self.set_uniform(&name, followed.light_to_clip)?;
        }
        Ok(())
    }

    /// Writes the `BrickLayout` of every bricked volume it reads, for a target `height` pixels
    /// high.
    fn write_brick_layouts(&mut self, gpu: &Gpu, resources: &Resources, height: u32) -> Result<(), RuntimeError> {
        let reflection = &self.shader.reflection;
        let names: Vec<String> =
            reflection.bindings.iter().filter(|b| b.kind == BindingKind::BrickLayout).map(|b| b.name.clone()).collect();
        self.brick_layouts.write(gpu, &resources.bricked, (&names, &reflection.view), height)
    }
}

impl PictureNode for VolumeLayer {
    fn reads(&self) -> Vec<Buffer> {
        let mut reads = Vec::new();
        if self.binds(&[BindingKind::GeometryDepth, BindingKind::GeometryColor]) {
            reads.push(Buffer::MeshLayer);
        }
        if self.reads_translucent_layers() {
            reads.push(Buffer::TranslucentLayers);
        }
        if self.binds(&[BindingKind::MeshShadowMap]) {
            reads.push(Buffer::ShadowMaps);
        }
        reads
    }

    fn writes(&self) -> Vec<Buffer> {
        vec![Buffer::Picture]
    }

    fn encode(&mut self, frame: &mut Frame<'_, '_>, written: Written<'_>) -> Result<(), RuntimeError> {
        let (gpu, resources) = (frame.gpu, frame.resources);
        let target_size = frame.target.texture().size();
        let size = [target_size.width, target_size.height];
        self.write_brick_layouts(gpu, resources, size[1])?;
        self.follow_mesh_shadows(written.mesh_layer)?;
        if let Some(bytes) = self.uniforms.take_changes() {
            gpu.queue.write_buffer(&self.uniform_buffer, 0, bytes);
        }
        let region_buffer = node::region_buffer(gpu, frame.region, &self.shader.reflection.view)?;
        // Only a progressive view hashes its uniforms: every other dispatch skips it.
        let key = self.history.as_ref().map(|_| self.history_key(resources, written.planes_generation));
        let luminance = match &mut self.metering {
            Some(metering) => {
                metering.before_pass(frame.encoder, &self.uniform_buffer);
                Some(metering.image(gpu, size)?)
            }
            None => None,
        };
        let history = match (&mut self.history, key) {
            (Some(history), Some(key)) => {
                Some(history.prepare(gpu, frame.encoder, size, key, frame.region.within(size).pixels())?)
            }
            _ => None,
        };
        let own = DispatchResources {
            history,
            uniforms: &self.uniform_buffer,
            region: &region_buffer,
            output: frame.target,
            luminance,
            mesh_layer: written.mesh_layer,
            brick_layouts: self.brick_layouts.buffers(),
            tfs: &self.own_tfs,
            picture: None,
        };
        node::dispatch(frame, (&self.pipeline, &self.shader.reflection), &own, "raycast")?;
        if let Some(metering) = &self.metering {
            metering.after_pass(gpu, frame.encoder)?;
        }
        Ok(())
    }
}
