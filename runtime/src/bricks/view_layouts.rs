//! A view's `BrickLayout` uniforms: how it looks at each bricked volume it reads (what picks the
//! levels its rays sample), written before each of its passes.

use super::{BrickView, BrickedVolumes};
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use std::collections::HashMap;

/// One view's brick layouts, by the name of the bricked volume's binding.
#[derive(Default)]
pub(crate) struct ViewBrickLayouts {
    /// How the view looks (set with its camera or plane every frame); none yet: straight on.
    view: Option<BrickView>,
    buffers: HashMap<String, wgpu::Buffer>,
}

impl ViewBrickLayouts {
    pub(crate) fn set_view(&mut self, view: BrickView) {
        self.view = Some(view);
    }

    /// The layouts' buffers, by binding name, as the view's pass binds them.
    pub(crate) fn buffers(&self) -> &HashMap<String, wgpu::Buffer> {
        &self.buffers
    }

    /// Writes the layout of each volume of `names` (bindings of view `view_name`) that `bricked`
    /// holds, for a target `height` pixels high.
    pub(crate) fn write(
        &mut self,
        gpu: &Gpu,
        bricked: &BrickedVolumes,
        (names, view_name): (&[String], &str),
        height: u32,
    ) -> Result<(), RuntimeError> {
        let view = self.view.unwrap_or(BrickView::Plane { u: glam::Vec3::X, v: glam::Vec3::Y });
        for name in names {
            let Some(volume) = bricked.get(name) else { continue };
            let bytes = volume.layout_bytes(view, height);
            if !self.buffers.contains_key(name) {
                let doing = format!("creating the brick layout of `{name}` for view `{view_name}`");
                let buffer = gpu.capture(&doing, || {
                    gpu.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("brick layout"),
                        size: bytes.len() as u64,
                        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    })
                })?;
                self.buffers.insert(name.clone(), buffer);
            }
            if let Some(buffer) = self.buffers.get(name) {
                gpu.queue.write_buffer(buffer, 0, &bytes);
            }
        }
        Ok(())
    }
}
