//! A view's overlay: meshes drawn over its finished picture (premultiplied "over", a depth test
//! among themselves only), so an instrument stays visible inside opaque tissue. A raycast view
//! draws them at its camera; a slice view draws them as seen along its normal (their whole
//! shape, not only the plane's crossing).

use super::draws::{self, DrawBuffer, Pipelines, Target};
use super::pipelines::{DEPTH_FORMAT, MeshPipelines};
use super::{LayerCamera, MeshInstance, attachment, depth_attachment, pass_descriptor};
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::textures::Image2d;

/// The overlay's depth buffer (one per target size) and its draws' uniforms.
pub(crate) struct Overlay {
    depth_buffer: wgpu::TextureView,
    size: [u32; 2],
    buffer: DrawBuffer,
}

impl Overlay {
    pub(crate) fn new(gpu: &Gpu, size: [u32; 2]) -> Result<Overlay, RuntimeError> {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let doing = format!("creating a {}x{} overlay", size[0], size[1]);
        let depth = Image2d { label: "overlay depth", size, format: DEPTH_FORMAT, usage }.create(gpu, &doing)?;
        Ok(Overlay { depth_buffer: depth.create_view(&Default::default()), size, buffer: DrawBuffer::default() })
    }

    pub(crate) fn size(&self) -> [u32; 2] {
        self.size
    }

    /// Records `meshes` seen by `camera` over `target` (a view's picture of this size).
    pub(crate) fn encode(
        &mut self,
        gpu: &Gpu,
        pipelines: &MeshPipelines,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        camera: &LayerCamera,
        meshes: &[&MeshInstance],
    ) -> Result<(), RuntimeError> {
        let draws = draws::frame_draws(gpu, camera, meshes, self.size, Target::Overlay)?;
        let Some(bind_group) = self.buffer.bind(gpu, Some(pipelines), &draws)? else { return Ok(()) };
        gpu.capture("drawing an overlay", || {
            let targets = [Some(attachment(target, wgpu::LoadOp::Load))];
            let depth = Some(depth_attachment(&self.depth_buffer));
            let mut pass = encoder.begin_render_pass(&pass_descriptor("overlay", &targets, depth));
            draws::record(&mut pass, Pipelines::ByPass(&pipelines.overlay, pipelines), &bind_group, (&draws, 0));
        })?;
        Ok(())
    }
}
