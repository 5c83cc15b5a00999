//! Volumes and transfer functions on the GPU. Each is uploaded once and shared (by `Arc`) by
//! every view that binds it.

use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::tf::{TF_WIDTH, TransferFunction};
use crate::volume::Volume;
use glam::Mat4;

/// A volume as a 3D `R16Float` texture of values normalized to [0, 1].
pub struct VolumeTexture {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub dims: [u32; 3],
    /// Voxel index to world, from the file's header.
    pub grid_to_world: Mat4,
}

impl VolumeTexture {
    /// Uploads `volume`, mapping `window` (or its value range) to [0, 1]. Refuses grids beyond
    /// the device's 3D texture limit.
    pub fn upload(
        gpu: &Gpu,
        name: &str,
        volume: &Volume,
        window: Option<[f32; 2]>,
    ) -> Result<VolumeTexture, RuntimeError> {
        let max = gpu.device.limits().max_texture_dimension_3d;
        if volume.dims.iter().any(|&d| d == 0 || d > max) {
            return Err(RuntimeError::Invalid(format!(
                "volume `{name}`: a {}x{}x{} grid exceeds this device's 3D texture limit of {max} per axis",
                volume.dims[0], volume.dims[1], volume.dims[2]
            )));
        }
        let size =
            wgpu::Extent3d { width: volume.dims[0], height: volume.dims[1], depth_or_array_layers: volume.dims[2] };
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(name),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: wgpu::TextureFormat::R16Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let texels = volume.normalized_f16(window);
        gpu.queue.write_texture(
            texture.as_image_copy(),
            bytemuck::cast_slice(&texels),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(volume.dims[0] * 2),
                rows_per_image: Some(volume.dims[1]),
            },
            size,
        );
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        Ok(VolumeTexture { texture, view, dims: volume.dims, grid_to_world: volume.grid_to_world })
    }
}

/// A transfer function as a `TF_WIDTH` x 1 `Rgba8Unorm` texture (straight alpha).
pub struct TfTexture {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
}

impl TfTexture {
    pub fn upload(gpu: &Gpu, tf: &TransferFunction) -> TfTexture {
        let size = wgpu::Extent3d { width: TF_WIDTH, height: 1, depth_or_array_layers: 1 };
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(&tf.name),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let tf_texture = TfTexture { view: texture.create_view(&Default::default()), texture };
        tf_texture.write(gpu, tf);
        tf_texture
    }

    /// Replaces the table (a transfer-function edit: no new texture, no new pipeline).
    pub fn write(&self, gpu: &Gpu, tf: &TransferFunction) {
        gpu.queue.write_texture(
            self.texture.as_image_copy(),
            &tf.to_rgba8(),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(TF_WIDTH * 4), rows_per_image: Some(1) },
            wgpu::Extent3d { width: TF_WIDTH, height: 1, depth_or_array_layers: 1 },
        );
    }
}

/// Trilinear filtering, clamped at the edges: how every volume and transfer function is read.
pub fn linear_sampler(gpu: &Gpu) -> wgpu::Sampler {
    gpu.device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("linear clamp"),
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        address_mode_w: wgpu::AddressMode::ClampToEdge,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    })
}
