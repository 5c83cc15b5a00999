//! The history of a progressive view (one whose shader keeps `history` fields: the path
//! tracer): per pixel of a target, the mean of the frames rendered since the picture last
//! changed and their number, which the shader reads and writes (`BindingKind::History`).
//!
//! The history is cleared whenever what the picture is rendered from changes: the view's
//! uniforms (camera, slice plane, every value), or the scene's content (transfer functions,
//! volumes, bricks that arrived, meshes), as `Resources::content` counts it. One history is
//! kept per target size in use (a preview and the whole image), like the mesh layers.

use crate::error::RuntimeError;
use crate::gpu::Gpu;

/// Bytes one pixel takes: two `vec4f`.
const PIXEL_BYTES: u64 = 32;
/// Histories kept per view: one for previews and one for the whole image.
const SIZES: usize = 2;

/// The histories of one progressive view.
#[derive(Default)]
pub(crate) struct History {
    /// The last used first.
    targets: Vec<Target>,
}

/// The history of one target size.
struct Target {
    size: [u32; 2],
    buffer: wgpu::Buffer,
    /// What the picture was rendered from when the history was last added to.
    key: Option<u64>,
    /// Pixels rendered into the history since it was cleared.
    covered: u64,
}

impl History {
    /// The buffer of `size`'s history for a dispatch of `pixels` (of the target) rendered from
    /// `key`: cleared (into `encoder`, before the dispatch) when `key` differs from the last
    /// one; the pixels are counted towards its frames.
    pub(crate) fn prepare(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        size: [u32; 2],
        key: u64,
        pixels: u64,
    ) -> Result<&wgpu::Buffer, RuntimeError> {
        match self.targets.iter().position(|t| t.size == size) {
            Some(i) => self.targets[..=i].rotate_right(1),
            None => {
                self.targets.insert(0, Target::new(gpu, size)?);
                self.targets.truncate(SIZES);
            }
        }
        let target = &mut self.targets[0];
        if target.key != Some(key) {
            encoder.clear_buffer(&target.buffer, 0, None);
            target.key = Some(key);
            target.covered = 0;
        }
        target.covered += pixels;
        Ok(&target.buffer)
    }

    /// Whole frames in the history of `size` rendered from `key` (0 when it was rendered from
    /// something else since, or never).
    pub(crate) fn frames(&self, size: [u32; 2], key: u64) -> u32 {
        let pixels = u64::from(size[0]) * u64::from(size[1]);
        let target = self.targets.iter().find(|t| t.size == size && t.key == Some(key));
        target.map_or(0, |t| (t.covered / pixels.max(1)).min(u64::from(u32::MAX)) as u32)
    }
}

impl Target {
    fn new(gpu: &Gpu, size: [u32; 2]) -> Result<Target, RuntimeError> {
        let bytes = u64::from(size[0]) * u64::from(size[1]) * PIXEL_BYTES;
        let doing = format!("creating the {}x{} history of a progressive view", size[0], size[1]);
        let buffer = gpu.capture(&doing, || {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("history"),
                size: bytes.max(PIXEL_BYTES),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        Ok(Target { size, buffer, key: None, covered: 0 })
    }
}
