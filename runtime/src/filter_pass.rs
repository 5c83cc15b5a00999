//! A filter pass (a view's `filters`, or a filter of its tree, composed by the compiler into the
//! `filter.*` steps): a compute pass that reads a copy of its target (`picture`: the view's
//! picture, or a group's part in the mesh layer) and the depth under it (`picture_depth`) and
//! writes the filtered picture over the target.
//!
//! The pass filters the region the view's dispatch rendered: a view drawn in tiles filters each
//! tile after it is drawn, and its filters' neighbourhood reads across a tile's edge see the
//! neighbouring tile as it was last drawn (depth is the mesh layer's, drawn whole before the first
//! tile, so filters of depth alone see no seams).

use crate::bindings::DispatchResources;
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::node::{self, Buffer, Frame, PictureNode, Written};
use crate::reflection::BindingKind;
use crate::shader::{PipelineCache, ViewPipeline, ViewShader};
use crate::textures::Image2d;
use crate::uniforms::{UniformBlock, Value};
use std::collections::HashMap;
use std::sync::Arc;

/// Where a filter pass runs in a view's picture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum FilterAt {
    /// Over the finished picture (the view's `filters`).
    Picture,
    /// In the mesh layer, over the part of a depth group before tree filter N (its index among
    /// the scene's tree filters).
    Tree(usize),
}

/// The compiled filter pass of a view, its uniforms, and the copy of the picture it reads.
pub(crate) struct FilterPass {
    shader: ViewShader,
    pipeline: Arc<ViewPipeline>,
    uniforms: UniformBlock,
    uniform_buffer: wgpu::Buffer,
    /// The picture as the view drew it, copied from the target before the pass (the pass
    /// writes the target): as large as the last target.
    input: Option<wgpu::Texture>,
}

impl FilterPass {
    /// The pass of `shader`; the pipeline comes from `cache`.
    pub(crate) fn new(gpu: &Gpu, cache: &mut PipelineCache, shader: ViewShader) -> Result<FilterPass, RuntimeError> {
        let pipeline = cache.get(gpu, &shader)?;
        let uniforms = UniformBlock::new(&shader.reflection);
        let doing = format!("creating the filter uniforms of view `{}`", shader.reflection.view);
        // A pass without plain uniforms binds no block; the buffer is then never bound.
        let size = (uniforms.bytes().len() as u64).max(16);
        let uniform_buffer = gpu.capture(&doing, || {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("filter uniforms"),
                size,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        Ok(FilterPass { shader, pipeline, uniforms, uniform_buffer, input: None })
    }

    /// The compiled pass.
    pub(crate) fn shader(&self) -> &ViewShader {
        &self.shader
    }

    /// The pass's uniform values.
    pub(crate) fn uniforms(&self) -> &UniformBlock {
        &self.uniforms
    }

    /// Whether the pass reads the plain uniform `name`.
    pub(crate) fn has_uniform(&self, name: &str) -> bool {
        self.uniforms.has(name)
    }

    /// Sets one of the pass's uniforms (see `ViewRenderer::set_uniform`).
    pub(crate) fn set_uniform(&mut self, name: &str, value: impl Into<Value>) -> Result<(), RuntimeError> {
        let view = &self.shader.reflection.view;
        self.uniforms.set(name, value).map_err(|error| RuntimeError::Uniform { view: view.clone(), error })
    }

    /// The copy of the picture for a target of `size` pixels, made again when the size changed.
    fn input_of(&mut self, gpu: &Gpu, size: [u32; 2]) -> Result<&wgpu::Texture, RuntimeError> {
        let fits = self.input.as_ref().is_some_and(|t| [t.width(), t.height()] == size);
        if !fits {
            let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
            let image = Image2d { label: "filter input", size, format: wgpu::TextureFormat::Rgba8Unorm, usage };
            self.input = Some(image.create(gpu, "creating the filters' copy of the picture")?);
        }
        self.input.as_ref().ok_or_else(|| RuntimeError::Invalid("no filter input".into()))
    }
}

impl PictureNode for FilterPass {
    fn reads(&self) -> Vec<Buffer> {
        let depth = self.shader.reflection.bindings.iter().any(|b| b.kind == BindingKind::GeometryDepth);
        if depth { vec![Buffer::Picture, Buffer::MeshLayer] } else { vec![Buffer::Picture] }
    }

    fn writes(&self) -> Vec<Buffer> {
        vec![Buffer::Picture]
    }

    /// Copies the target, then filters the copy back into the region of it.
    fn encode(&mut self, frame: &mut Frame<'_, '_>, written: Written<'_>) -> Result<(), RuntimeError> {
        let gpu = frame.gpu;
        if let Some(bytes) = self.uniforms.take_changes() {
            gpu.queue.write_buffer(&self.uniform_buffer, 0, bytes);
        }
        let size = frame.target.texture().size();
        let input = self.input_of(gpu, [size.width, size.height])?;
        frame.encoder.copy_texture_to_texture(frame.target.texture().as_image_copy(), input.as_image_copy(), size);
        let input_view = input.create_view(&Default::default());
        let region_buffer = node::region_buffer(gpu, frame.region, &self.shader.reflection.view)?;
        let (no_tfs, no_layouts) = (HashMap::new(), HashMap::new());
        let own = DispatchResources {
            uniforms: &self.uniform_buffer,
            region: &region_buffer,
            output: frame.target,
            luminance: None,
            mesh_layer: written.mesh_layer,
            tfs: &no_tfs,
            brick_layouts: &no_layouts,
            history: None,
            picture: Some(&input_view),
        };
        node::dispatch(frame, (&self.pipeline, &self.shader.reflection), &own, "filters")
    }
}
