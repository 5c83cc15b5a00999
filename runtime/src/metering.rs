//! Automatic exposure on the GPU (`std::auto_exposure`): a view that meters writes each pixel's
//! `metered_luminance` into its luminance image (`BindingKind::LuminanceImage`); after the
//! view's pass a reduction pass takes the log-average over the pixels with content into a small
//! buffer, and before the next pass that value is copied into the view's uniform block at
//! `scene_luminance`. Nothing is read back: the exposure follows the picture one frame late
//! (a one-off render meters with a first pass).

use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::pass_bindings::{ComputePass, PassBindings, Slot, ty};
use crate::reflection::{BindingKind, Reflection};
use crate::textures::Image2d;

/// The uniform the reduction's result is copied into.
pub(crate) const SCENE_LUMINANCE: &str = "scene_luminance";

/// `scene_luminance` before anything was metered: middle grey, so exposure starts neutral.
const START: f32 = 0.18;

pub(crate) const SHADER: &str = r#"
struct Metered {
    value: f32,
}
@group(0) @binding(0) var luminance: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> result: Metered;

var<workgroup> sums: array<vec2<f32>, 256>;

@compute @workgroup_size(256)
fn main(@builtin(local_invocation_index) i: u32) {
    let size = textureDimensions(luminance);
    let n = size.x * size.y;
    var sum = vec2<f32>(0.0);
    for (var k = i; k < n; k += 256u) {
        let l = textureLoad(luminance, vec2<u32>(k % size.x, k / size.x), 0).x;
        // Pixels that show nothing (the background) do not count; 1e-4 keeps log finite.
        if l > 0.0 && l < 1e30 {
            sum += vec2<f32>(log(l + 1e-4), 1.0);
        }
    }
    sums[i] = sum;
    workgroupBarrier();
    for (var half = 128u; half > 0u; half >>= 1u) {
        if i < half {
            sums[i] += sums[i + half];
        }
        workgroupBarrier();
    }
    if i == 0u && sums[0].y > 0.0 {
        result.value = exp(sums[0].x / sums[0].y);
    }
}
"#;

/// The bindings of [`SHADER`]: the luminance image, the result.
pub(crate) const BINDINGS: PassBindings = PassBindings {
    label: "metering",
    groups: &[&[
        Slot::compute(0, ty::texture(wgpu::TextureViewDimension::D2, false)),
        Slot::compute(1, ty::STORAGE_READ_WRITE),
    ]],
};

/// A metering view's luminance images, its reduction and its result.
pub(crate) struct Metering {
    pass: ComputePass,
    /// 4 bytes: the last log-average luminance.
    result: wgpu::Buffer,
    /// Byte offset of `scene_luminance` in the uniform block.
    offset: u64,
    /// The luminance image of the last target size.
    image: Option<([u32; 2], wgpu::TextureView)>,
}

impl Metering {
    /// The metering of a view whose reflection has a luminance image and `scene_luminance`;
    /// `None` for every other view.
    pub(crate) fn of(gpu: &Gpu, reflection: &Reflection) -> Option<Result<Metering, RuntimeError>> {
        reflection.bindings.iter().find(|b| b.kind == BindingKind::LuminanceImage)?;
        let offset = reflection.uniforms.iter().find(|u| u.name == SCENE_LUMINANCE)?.offset?;
        Some(
            gpu.capture("making the luminance reduction", || Metering::new(gpu, u64::from(offset))).map_err(Into::into),
        )
    }

    fn new(gpu: &Gpu, offset: u64) -> Metering {
        let pass = ComputePass::new(gpu, BINDINGS, SHADER);
        let result = wgpu::util::DeviceExt::create_buffer_init(
            &gpu.device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("scene luminance"),
                contents: bytemuck::cast_slice(&[START]),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            },
        );
        Metering { pass, result, offset, image: None }
    }

    /// The luminance image for a target of `size` pixels (made anew when the size changes).
    pub(crate) fn image(&mut self, gpu: &Gpu, size: [u32; 2]) -> Result<&wgpu::TextureView, RuntimeError> {
        if self.image.as_ref().is_none_or(|(made, _)| *made != size) {
            let [w, h] = size;
            let usage = wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING;
            let image = Image2d { label: "luminance", size, format: wgpu::TextureFormat::R32Float, usage };
            let texture = image.create(gpu, &format!("creating a {w}x{h} luminance image"))?;
            self.image = Some((size, texture.create_view(&Default::default())));
        }
        let (_, view) = self.image.as_ref().ok_or_else(|| RuntimeError::Invalid("no luminance image".into()))?;
        Ok(view)
    }

    /// Before the view's pass: the last metered value into the uniform block (after the
    /// block's own write, which queue writes come before).
    pub(crate) fn before_pass(&self, encoder: &mut wgpu::CommandEncoder, uniforms: &wgpu::Buffer) {
        encoder.copy_buffer_to_buffer(&self.result, 0, uniforms, self.offset, 4);
    }

    /// After the view's pass: the reduction of the luminance image into the result.
    pub(crate) fn after_pass(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder) -> Result<(), RuntimeError> {
        let Some((_, image)) = &self.image else { return Ok(()) };
        let bind_group = gpu.capture("binding the luminance reduction", || {
            let resources = [wgpu::BindingResource::TextureView(image), self.result.as_entire_binding()];
            self.pass.layout.bind_group(gpu, 0, &resources)
        })?;
        self.pass.dispatch(encoder, &[&bind_group], [1, 1, 1]);
        Ok(())
    }
}
