//! Shadow groups' shadow maps: each group's meshes drawn from its directional light into a depth
//! image, which its meshes' fragments compare their own distance to the light with.

use super::MeshInstance;
use super::pipelines::{DEPTH_FORMAT, MeshPipelines};
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::textures::Image2d;
use glam::{Mat4, Vec3};

/// Texels of a shadow map's side: about a tenth of a millimetre a texel over a 100 mm group.
pub(crate) const SHADOW_MAP_SIZE: u32 = 1024;

/// A shadow map: its depth image.
pub(crate) struct ShadowMap {
    pub(crate) depth: wgpu::TextureView,
}

impl ShadowMap {
    pub(crate) fn new(gpu: &Gpu) -> Result<ShadowMap, RuntimeError> {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let size = [SHADOW_MAP_SIZE; 2];
        let image = Image2d { label: "shadow map", size, format: DEPTH_FORMAT, usage };
        let depth = image.create(gpu, "creating a shadow map")?.create_view(&Default::default());
        Ok(ShadowMap { depth })
    }

    /// The bind group the group's meshes' fragments read the map through, with the light volume
    /// of its light (`None`: the volume casts no shadow, full light) and `sampler` for it.
    pub(crate) fn bind(
        &self,
        gpu: &Gpu,
        pipelines: &MeshPipelines,
        light_volume: Option<&wgpu::TextureView>,
        sampler: &wgpu::Sampler,
    ) -> Result<wgpu::BindGroup, RuntimeError> {
        let light_volume = light_volume.unwrap_or(&pipelines.no_light_volume);
        gpu.capture("binding a shadow map", || {
            let resources = [
                wgpu::BindingResource::TextureView(&self.depth),
                wgpu::BindingResource::Sampler(&pipelines.shadow_sampler),
                wgpu::BindingResource::TextureView(light_volume),
                wgpu::BindingResource::Sampler(sampler),
            ];
            pipelines.shadow_bindings.bind_group(gpu, 1, &resources)
        })
        .map_err(RuntimeError::from)
    }
}

/// The orthographic projection of a directional light from `towards` (patient space, towards the
/// light) that holds every mesh of `meshes` (their bounding sphere, so it holds them from any
/// direction): patient space to the shadow map's clip space, depth 0 nearest the light.
pub(crate) fn light_to_clip(towards: Vec3, meshes: &[&MeshInstance]) -> Mat4 {
    let towards = towards.try_normalize().unwrap_or(Vec3::Z);
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for m in meshes {
        let Some((min, max)) = m.mesh.bounds() else { continue };
        for corner in 0..8 {
            let pick = |bit: usize, a: f32, b: f32| if corner >> bit & 1 == 0 { a } else { b };
            let local = Vec3::new(pick(0, min[0], max[0]), pick(1, min[1], max[1]), pick(2, min[2], max[2]));
            let world = m.model.transform_point3(local);
            (lo, hi) = (lo.min(world), hi.max(world));
        }
    }
    let (centre, radius) =
        if lo.x <= hi.x { ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(1e-3)) } else { (Vec3::ZERO, 1.0) };
    let up = if towards.z.abs() < 0.9 { Vec3::Z } else { Vec3::Y };
    let view = glam::camera::rh::view::look_at_mat4(centre + towards * 2.0 * radius, centre, up);
    // WebGPU's clip space, as the view's own projection (depth 0 to 1, y up).
    glam::camera::rh::proj::directx::orthographic(-radius, radius, -radius, radius, 0.0, 4.0 * radius) * view
}
