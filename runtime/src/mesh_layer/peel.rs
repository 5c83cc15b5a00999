//! Translucent surfaces in depth order, for a volume layer that blends them into its rays
//! (std::translucent): depth peeling. Pass N draws every translucent mesh (both faces) and keeps,
//! at each pixel, the nearest surface behind layer N - 1 and in front of the first opaque one,
//! into colour layer N and depth layer N + 1; a last pass blends the surfaces behind the last
//! layer under it, in drawing order. Exact up to [`TRANSLUCENT_LAYERS`] surfaces at a pixel;
//! past that, the surfaces behind the last layer are blended together in the order they are
//! drawn, and surfaces at exactly the depth of one peeled before are left out.

use vrsc::compose::TRANSLUCENT_LAYERS;

use super::draws::{self, Draw, Pipelines};
use super::pipelines::{COLOR_FORMAT, DEPTH_FORMAT, DEPTH_IMAGE_FORMAT, MeshPipelines};
use super::{attachment, depth_attachment, pass_descriptor};
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::textures::Image2d;

/// A layer's peeled translucent surfaces: the images the volume layer reads and the passes'
/// targets.
pub(crate) struct PeeledLayers {
    /// [`TRANSLUCENT_LAYERS`] layers of premultiplied colour (nothing: transparent): each, as
    /// drawn into, and all, as the volume layer reads them.
    color_layers: Vec<wgpu::TextureView>,
    colors: wgpu::TextureView,
    /// `TRANSLUCENT_LAYERS + 1` layers of depth: layer 0 cleared to 0 (before the first
    /// surface), layer N + 1 that of colour layer N (1 where it holds nothing); each, and layers
    /// 1 to `TRANSLUCENT_LAYERS`, as the volume layer reads them.
    depth_layers: Vec<wgpu::TextureView>,
    depths: wgpu::TextureView,
    /// The depth test of a peeling pass (the nearest surface wins).
    depth_buffer: wgpu::TextureView,
    /// The layers hold nothing (cleared, no surface drawn since): a frame without translucent
    /// meshes then records no pass at all.
    empty: bool,
}

impl PeeledLayers {
    /// Empty layers of `size` pixels.
    pub(crate) fn new(gpu: &Gpu, size: [u32; 2]) -> Result<PeeledLayers, RuntimeError> {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let doing = format!("creating {}x{} translucent layers", size[0], size[1]);
        let image = |label, format| Image2d { label, size, format, usage };
        let layers = TRANSLUCENT_LAYERS as u32;
        let colors = image("translucent colours", COLOR_FORMAT).create_layers(gpu, &doing, layers)?;
        let depths = image("translucent depths", DEPTH_IMAGE_FORMAT).create_layers(gpu, &doing, layers + 1)?;
        let depth_buffer = image("translucent depth buffer", DEPTH_FORMAT).create(gpu, &doing)?;
        let view = |texture: &wgpu::Texture, first: u32, count: u32, dimension| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(dimension),
                base_array_layer: first,
                array_layer_count: Some(count),
                ..Default::default()
            })
        };
        use wgpu::TextureViewDimension::{D2, D2Array};
        Ok(PeeledLayers {
            color_layers: (0..layers).map(|i| view(&colors, i, 1, D2)).collect(),
            colors: view(&colors, 0, layers, D2Array),
            depth_layers: (0..=layers).map(|i| view(&depths, i, 1, D2)).collect(),
            depths: view(&depths, 1, layers, D2Array),
            depth_buffer: depth_buffer.create_view(&Default::default()),
            empty: false,
        })
    }

    /// The depths and the colours, as the volume layer binds them (`texture_2d_array<f32>`).
    pub(crate) fn views(&self) -> (&wgpu::TextureView, &wgpu::TextureView) {
        (&self.depths, &self.colors)
    }

    /// Records the peeling of `draws` (each a translucent mesh; their uniforms are
    /// `bind_group`'s slots from `first_slot` on) in front of `opaque`, the layer's opaque depth.
    pub(crate) fn encode(
        &mut self,
        gpu: &Gpu,
        pipelines: &MeshPipelines,
        encoder: &mut wgpu::CommandEncoder,
        opaque: &wgpu::TextureView,
        (bind_group, draws, first_slot): (&wgpu::BindGroup, &[Draw], usize),
    ) -> Result<(), RuntimeError> {
        if draws.is_empty() && self.empty {
            return Ok(());
        }
        self.empty = draws.is_empty();
        let doing = "peeling translucent meshes";
        let behind = |layer: usize| {
            gpu.capture(doing, || {
                let resources = [
                    wgpu::BindingResource::TextureView(opaque),
                    wgpu::BindingResource::TextureView(&self.depth_layers[layer]),
                ];
                pipelines.bindings.bind_group(gpu, 2, &resources)
            })
        };
        let clear = wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT);
        let far = wgpu::LoadOp::Clear(wgpu::Color::WHITE);
        // Depth layer 0: in front of everything.
        gpu.capture(doing, || {
            encoder.begin_render_pass(&pass_descriptor(
                "translucent layer",
                &[Some(attachment(&self.depth_layers[0], clear))],
                None,
            ));
        })?;
        for layer in 0..TRANSLUCENT_LAYERS {
            let group = behind(layer)?;
            gpu.capture(doing, || {
                let targets = [
                    Some(attachment(&self.color_layers[layer], clear)),
                    Some(attachment(&self.depth_layers[layer + 1], far)),
                ];
                let mut pass = encoder.begin_render_pass(&pass_descriptor(
                    "translucent layer",
                    &targets,
                    Some(depth_attachment(&self.depth_buffer)),
                ));
                pass.set_bind_group(2, &group, &[]);
                draws::record(&mut pass, Pipelines::One(&pipelines.peel), bind_group, (draws, first_slot));
            })?;
        }
        let group = behind(TRANSLUCENT_LAYERS)?;
        gpu.capture(doing, || {
            let last = [Some(attachment(&self.color_layers[TRANSLUCENT_LAYERS - 1], wgpu::LoadOp::Load))];
            let mut pass = encoder.begin_render_pass(&pass_descriptor("translucent layer", &last, None));
            pass.set_bind_group(2, &group, &[]);
            draws::record(&mut pass, Pipelines::One(&pipelines.peel_rest), bind_group, (draws, first_slot));
        })?;
        Ok(())
    }
}
