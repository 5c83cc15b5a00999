//! The nodes of a view's picture (ARCHITECTURE.md, "A view's picture, node by node"): the mesh
//! layer, the volume layer, the overlay and the filter pass share one interface: the buffers of
//! the picture a node reads and writes, and the recording of its passes into a [`Frame`]. A
//! view's [`crate::ViewRenderer`] records its nodes in order; each reads only what an earlier
//! node wrote (what the build checks in the scene: E0608, E0609), which [`unwritten_reads`]
//! states for the runtime.

use crate::bindings::DispatchResources;
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::mesh_layer::LayerViews;
use crate::region::Region;
use crate::resources::Resources;
use crate::shader::ViewPipeline;

/// What one recording of a view's picture draws into: a region of a target, with the scene's
/// shared resources.
pub(crate) struct Frame<'a, 'e> {
    pub gpu: &'a Gpu,
    pub resources: &'a Resources,
    pub encoder: &'e mut wgpu::CommandEncoder,
    pub target: &'a wgpu::TextureView,
    pub region: Region,
}

/// A buffer of a view's picture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Buffer {
    /// The mesh layer's depth and colour.
    MeshLayer,
    /// Its translucent surfaces peeled into layers.
    TranslucentLayers,
    /// Its shadow groups' shadow maps.
    ShadowMaps,
    /// The picture itself (the target).
    Picture,
}

/// What the nodes before a node wrote, that it may read.
#[derive(Clone, Copy, Default)]
pub(crate) struct Written<'a> {
    /// The mesh layer drawn for this target (with its translucent layers and shadow maps).
    pub mesh_layer: Option<LayerViews<'a>>,
    /// Counts renders of the planes' pictures the mesh layer shows.
    pub planes_generation: u64,
}

/// A node of a view's picture.
pub(crate) trait PictureNode {
    /// The buffers it reads, written by nodes before it.
    fn reads(&self) -> Vec<Buffer>;
    /// The buffers it writes (a node that draws over the picture reads and writes it).
    fn writes(&self) -> Vec<Buffer>;
    /// Prepares what it needs (uniforms, images) and records its passes for `frame`.
    fn encode(&mut self, frame: &mut Frame<'_, '_>, written: Written<'_>) -> Result<(), RuntimeError>;
}

/// The reads of `nodes` (name, reads, writes; in drawing order) that no node before them
/// writes: none for a picture made right.
pub(crate) fn unwritten_reads(nodes: &[(&str, Vec<Buffer>, Vec<Buffer>)]) -> Vec<(String, Buffer)> {
    let mut written: Vec<Buffer> = Vec::new();
    let mut out = Vec::new();
    for (name, reads, writes) in nodes {
        out.extend(reads.iter().filter(|b| !written.contains(b)).map(|&b| (name.to_string(), b)));
        written.extend(writes);
    }
    out
}

/// Records one dispatch of a reflected compute shader (`pipeline`, made from `reflection`) over
/// `frame.region`: the bind groups its reflection lists, from `own` and the shared resources,
/// and one workgroup per 8x8 pixels of the region. `label` names the pass.
pub(crate) fn dispatch(
    frame: &mut Frame<'_, '_>,
    (pipeline, reflection): (&ViewPipeline, &crate::reflection::Reflection),
    own: &DispatchResources<'_>,
    label: &str,
) -> Result<(), RuntimeError> {
    let gpu = frame.gpu;
    let doing = format!("binding the {label} of view `{}`", reflection.view);
    let mut groups = Vec::with_capacity(pipeline.groups.len());
    let pools = crate::bindings::brick_pools(reflection, frame.resources);
    for (group, layout) in (0u32..).zip(&pipeline.groups) {
        let entries = crate::bindings::group_entries(reflection, group, (frame.resources, &pools), own)?;
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
    let region = frame.region;
    let (w, h) = (region.x1.saturating_sub(region.x0), region.y1.saturating_sub(region.y0));
    let doing = format!("recording the {label} of view `{}`", reflection.view);
    gpu.capture(&doing, || {
        let mut pass = frame
            .encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
        pass.set_pipeline(&pipeline.pipeline);
        for (group, bind_group) in (0u32..).zip(&groups) {
            pass.set_bind_group(group, bind_group, &[]);
        }
        pass.dispatch_workgroups(w.div_ceil(wx.max(1)), h.div_ceil(wy.max(1)), 1);
    })?;
    Ok(())
}

/// The `vec4<u32>` uniform of `region` (`x0, y0, x1, y1`) a dispatch binds.
pub(crate) fn region_buffer(gpu: &Gpu, region: Region, view: &str) -> Result<wgpu::Buffer, RuntimeError> {
    let made = gpu.capture(&format!("binding the region of view `{view}`"), || {
        wgpu::util::DeviceExt::create_buffer_init(
            &gpu.device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("region"),
                contents: bytemuck::cast_slice(&[region.x0, region.y0, region.x1, region.y1]),
                usage: wgpu::BufferUsages::UNIFORM,
            },
        )
    })?;
    Ok(made)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_read_needs_an_earlier_write() {
        use Buffer::*;
        let picture = [
            ("mesh layer", vec![], vec![MeshLayer, ShadowMaps]),
            ("volume layer", vec![MeshLayer, ShadowMaps], vec![Picture]),
            ("filters", vec![Picture, MeshLayer], vec![Picture]),
        ];
        assert!(unwritten_reads(&picture).is_empty());
        let without_meshes = &picture[1..];
        assert_eq!(
            unwritten_reads(without_meshes),
            [
                ("volume layer".to_string(), MeshLayer),
                ("volume layer".to_string(), ShadowMaps),
                ("filters".to_string(), MeshLayer)
            ]
        );
    }
}
