//! A view's filter pass (its `filters`, composed by the compiler into the `filter.*` steps): a
//! compute pass after the view's picture, which reads a copy of the picture (`picture`) and the
//! depth of the mesh layer (`picture_depth`) and writes the filtered picture over the target.
//!
//! The pass filters the region the view's dispatch rendered: a view drawn in tiles filters each
//! tile after it is drawn, and its filters' neighbourhood reads across a tile's edge see the
//! neighbouring tile as it was last drawn (depth is the mesh layer's, drawn whole before the first
//! tile, so filters of depth alone see no seams).

use crate::bindings::{self, DispatchResources};
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::mesh_layer::LayerViews;
use crate::region::Region;
use crate::resources::Resources;
use crate::shader::{PipelineCache, ViewPipeline, ViewShader};
use crate::textures::Image2d;
use crate::uniforms::{UniformBlock, Value};
use std::collections::HashMap;
use std::sync::Arc;

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

    /// Records the pass over `region` of `target`: copies the target, then filters the copy back
    /// into it. `mesh_layer` is the view's mesh layer, drawn for this target.
    pub(crate) fn encode(
        &mut self,
        gpu: &Gpu,
        (resources, mesh_layer): (&Resources, Option<LayerViews<'_>>),
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        region: Region,
    ) -> Result<(), RuntimeError> {
        if let Some(bytes) = self.uniforms.take_changes() {
            gpu.queue.write_buffer(&self.uniform_buffer, 0, bytes);
        }
        let size = target.texture().size();
        let input = self.input_of(gpu, [size.width, size.height])?;
        encoder.copy_texture_to_texture(target.texture().as_image_copy(), input.as_image_copy(), size);
        let input_view = input.create_view(&Default::default());
        let reflection = &self.shader.reflection;
        let doing = format!("binding the filters of view `{}`", reflection.view);
        let region_buffer = gpu.capture(&doing, || {
            wgpu::util::DeviceExt::create_buffer_init(
                &gpu.device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("filter region"),
                    contents: bytemuck::cast_slice(&[region.x0, region.y0, region.x1, region.y1]),
                    usage: wgpu::BufferUsages::UNIFORM,
                },
            )
        })?;
        let (no_tfs, no_layouts) = (HashMap::new(), HashMap::new());
        let own = DispatchResources {
            uniforms: &self.uniform_buffer,
            region: &region_buffer,
            output: target,
            luminance: None,
            mesh_layer,
            tfs: &no_tfs,
            brick_layouts: &no_layouts,
            history: None,
            picture: Some(&input_view),
        };
        let mut groups = Vec::with_capacity(self.pipeline.groups.len());
        for (group, layout) in (0u32..).zip(&self.pipeline.groups) {
            let entries = bindings::group_entries(reflection, group, resources, &own)?;
            let made = gpu.capture(&doing, || {
                gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("filters"),
                    layout,
                    entries: &entries,
                })
            });
            groups.push(made?);
        }
        let [wx, wy, _] = reflection.workgroup_size;
        let (w, h) = (region.x1.saturating_sub(region.x0), region.y1.saturating_sub(region.y0));
        let doing = format!("recording the filters of view `{}`", reflection.view);
        gpu.capture(&doing, || {
            let mut pass = encoder
                .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("filters"), timestamp_writes: None });
            pass.set_pipeline(&self.pipeline.pipeline);
            for (group, bind_group) in (0u32..).zip(&groups) {
                pass.set_bind_group(group, bind_group, &[]);
            }
            pass.dispatch_workgroups(w.div_ceil(wx.max(1)), h.div_ceil(wy.max(1)), 1);
        })?;
        Ok(())
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
