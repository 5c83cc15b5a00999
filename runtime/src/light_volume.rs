//! Light volumes of `std::shadow_volume` (`shadows = "volume"`): for a light, the transmittance
//! from the centre of every texel of a coarse grid over the primary volume towards the light,
//! through the primary volume under its transfer function: the march of `std::shadow_ray`, done
//! once per texel in a compute pass instead of once per sample and frame. The grid has at most
//! [`MAX_SIDE`] texels per axis (shadows are smooth); views sample it trilinearly.

use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::pass_bindings::{ComputePass, PassBindings, Slot, ty};
use crate::textures::{Image3d, TfTexture, VolumeTexture};
use glam::{Mat4, Vec3};

/// The largest side of a light volume, in texels.
pub(crate) const MAX_SIDE: u32 = 64;

/// A light march ends once less than this share of the light is left (`std::shadow_ray`'s
/// default `shadow_cutoff`).
const CUTOFF: f32 = 0.005;

pub(crate) const SHADER: &str = r#"
struct Params {
    // xyz: one step towards the light in normalized volume coordinates; w: its length in mm.
    step: vec4<f32>,
    ref_step: f32,
    max_steps: u32,
    cutoff: f32,
    unused: f32,
}
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var volume: texture_3d<f32>;
@group(0) @binding(2) var volume_sampler: sampler;
@group(0) @binding(3) var tf: texture_2d<f32>;
@group(0) @binding(4) var tf_sampler: sampler;
@group(0) @binding(5) var light: texture_storage_3d<rgba16float, write>;

@compute @workgroup_size(4, 4, 4)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(light);
    if any(id >= size) {
        return;
    }
    var p = (vec3<f32>(id) + 0.5) / vec3<f32>(size) + params.step.xyz;
    var transmittance = 1.0;
    for (var i = 0u; i < params.max_steps; i++) {
        if any(p < vec3<f32>(0.0)) || any(p > vec3<f32>(1.0)) || transmittance < params.cutoff {
            break;
        }
        let value = textureSampleLevel(volume, volume_sampler, p, 0.0).x;
        let a = textureSampleLevel(tf, tf_sampler, vec2<f32>(value, 0.5), 0.0).a;
        transmittance *= pow(max(1.0 - clamp(a, 0.0, 1.0), 1e-6), params.step.w / params.ref_step);
        p += params.step.xyz;
    }
    textureStore(light, id, vec4<f32>(transmittance, 0.0, 0.0, 1.0));
}
"#;

/// The bindings of [`SHADER`], in the order [`LightVolumePass::compute`] binds them.
pub(crate) const BINDINGS: PassBindings = PassBindings {
    label: "light volume",
    groups: &[&[
        Slot::compute(0, ty::UNIFORM),
        Slot::compute(1, ty::texture(wgpu::TextureViewDimension::D3, true)),
        Slot::compute(2, ty::SAMPLER),
        Slot::compute(3, ty::texture(wgpu::TextureViewDimension::D2, true)),
        Slot::compute(4, ty::SAMPLER),
        Slot::compute(5, ty::storage_texture(wgpu::TextureFormat::Rgba16Float, wgpu::TextureViewDimension::D3)),
    ]],
};

/// What a light volume was computed from: equal keys, same volume.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LightKey {
    /// Towards the light in patient space (RAS), not normalized; zero for a headlight.
    pub direction: Vec3,
    pub ref_step: f32,
    /// Changes whenever the primary volume or its transfer function does.
    pub generation: u64,
}

/// The compute pipeline of light volumes (made once per renderer).
pub(crate) struct LightVolumePass {
    pass: ComputePass,
}

/// The primary volume a light volume is computed over.
pub(crate) struct Primary<'a> {
    pub texture: &'a VolumeTexture,
    pub tf: &'a TfTexture,
    pub sampler: &'a wgpu::Sampler,
    /// Normalized volume coordinates to patient space (RAS, mm).
    pub volume_to_world: Mat4,
}

impl LightVolumePass {
    pub(crate) fn new(gpu: &Gpu) -> Result<LightVolumePass, RuntimeError> {
        let pass = gpu.capture("making the light-volume pass", || ComputePass::new(gpu, BINDINGS, SHADER))?;
        Ok(LightVolumePass { pass })
    }

    /// The light volume of a light in direction `key.direction` over `primary`, computed and
    /// submitted (the caller's next submission sees it). A headlight (zero direction) gets a
    /// volume of 1: it moves with the camera, so it casts no volume shadows.
    pub(crate) fn compute(&self, gpu: &Gpu, primary: &Primary, key: &LightKey) -> Result<VolumeTexture, RuntimeError> {
        let dims = primary.texture.dims.map(|d| d.clamp(1, MAX_SIDE));
        let doing = "computing a light volume";
        let usage = wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING;
        let image = Image3d { label: "light volume", size: dims, format: wgpu::TextureFormat::Rgba16Float, usage };
        let texture = image.create(gpu, doing)?;
        let view = texture.create_view(&Default::default());
        let params = march(primary.volume_to_world, dims, key);
        gpu.capture(doing, || {
            let buffer = wgpu::util::DeviceExt::create_buffer_init(
                &gpu.device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("light volume"),
                    contents: bytemuck::cast_slice(&params),
                    usage: wgpu::BufferUsages::UNIFORM,
                },
            );
            let bind_group = self.pass.layout.bind_group(
                gpu,
                0,
                &[
                    buffer.as_entire_binding(),
                    wgpu::BindingResource::TextureView(&primary.texture.view),
                    wgpu::BindingResource::Sampler(primary.sampler),
                    wgpu::BindingResource::TextureView(&primary.tf.view),
                    wgpu::BindingResource::Sampler(primary.sampler),
                    wgpu::BindingResource::TextureView(&view),
                ],
            );
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            self.pass.dispatch(&mut encoder, &[&bind_group], dims.map(|d| d.div_ceil(4)));
            gpu.queue.submit([encoder.finish()]);
        })?;
        let grid_to_world = primary.texture.grid_to_world;
        Ok(VolumeTexture { texture, view, dims, grid_to_world, histogram: Vec::new() })
    }
}

/// The pass's parameters (8 floats, as `Params`): the step towards the light in normalized
/// coordinates and mm (half a light-volume texel's smallest extent), `ref_step`, the number of
/// steps that crosses the volume, the cutoff.
fn march(volume_to_world: Mat4, dims: [u32; 3], key: &LightKey) -> [f32; 8] {
    let linear = volume_to_world.transform_vector3(Vec3::ONE).abs();
    let texel_mm = (linear / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32)).min_element();
    let step_mm = (0.5 * texel_mm).max(1e-3);
    let towards = key.direction.normalize_or_zero();
    let to_volume = volume_to_world.inverse();
    let step = to_volume.transform_vector3(towards * step_mm);
    let chord = linear.length();
    // A headlight (no direction) takes no step: zero steps leave its volume at 1.
    let steps = if towards == Vec3::ZERO || !step.is_finite() { 0 } else { (chord / step_mm).ceil() as u32 + 2 };
    let ref_step = if key.ref_step > 0.0 && key.ref_step.is_finite() { key.ref_step } else { 1.0 };
    [step.x, step.y, step.z, step_mm, ref_step, f32::from_bits(steps), CUTOFF, 0.0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_march_steps_half_a_texel_towards_the_light_and_crosses_the_volume() {
        // 64 x 64 x 128 mm, a light volume of 32^3 texels: texels of 2 x 2 x 4 mm.
        let to_world = Mat4::from_scale(Vec3::new(64.0, 64.0, 128.0));
        let key = LightKey { direction: Vec3::new(0.0, 0.0, 2.0), ref_step: 1.0, generation: 0 };
        let p = march(to_world, [32, 32, 32], &key);
        assert_eq!((p[3], p[0], p[1]), (1.0, 0.0, 0.0), "1 mm steps along z only");
        assert!((p[2] - 1.0 / 128.0).abs() < 1e-7, "1 mm of 128 in normalized z: {}", p[2]);
        assert!(p[5].to_bits() as f32 * p[3] >= Vec3::new(64.0, 64.0, 128.0).length(), "enough steps");
        let headlight = LightKey { direction: Vec3::ZERO, ..key };
        assert_eq!(march(to_world, [32, 32, 32], &headlight)[5].to_bits(), 0, "a headlight takes no step");
    }
}
