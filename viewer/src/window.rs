//! The window's GPU side: a surface on the renderer's own device (one wgpu for the views and
//! egui), and painting egui's frame onto it.

use std::path::Path;
use std::sync::Arc;
use vrs_runtime::Gpu;
use winit::window::Window;

/// The surface, the device shared with the scene renderer, and egui's painter.
pub struct Surface {
    pub window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    pub gpu: Gpu,
    pub painter: egui_wgpu::Renderer,
}

impl Surface {
    /// Opens a device compatible with the window (software only when asked) and configures
    /// the surface.
    pub fn new(instance: &wgpu::Instance, window: Arc<Window>, software: bool) -> Result<Surface, String> {
        let surface =
            instance.create_surface(window.clone()).map_err(|e| format!("cannot draw into the window: {e}"))?;
        let adapter =
            vrs_runtime::gpu::request_adapter(instance, Some(&surface), software).map_err(|e| e.to_string())?;
        let gpu = Gpu::from_adapter(&adapter).map_err(|e| e.to_string())?;
        let capabilities = surface.get_capabilities(&adapter);
        let format = egui_wgpu::preferred_framebuffer_format(&capabilities.formats).map_err(|e| e.to_string())?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width: size.width.max(1),
            height: size.height.max(1),
            // Never block the event loop on the display: the newest frame wins.
            present_mode: if capabilities.present_modes.contains(&wgpu::PresentMode::Mailbox) {
                wgpu::PresentMode::Mailbox
            } else {
                wgpu::PresentMode::AutoVsync
            },
            alpha_mode: capabilities.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
            desired_maximum_frame_latency: 1,
        };
        surface.configure(&gpu.device, &config);
        let painter = egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        Ok(Surface { window, surface, config, gpu, painter })
    }

    pub fn resize(&mut self, width: u32, height: u32) {
        if width > 0 && height > 0 && (width, height) != (self.config.width, self.config.height) {
            self.config.width = width;
            self.config.height = height;
            self.surface.configure(&self.gpu.device, &self.config);
        }
    }

    /// Paints egui's output and presents it. With `capture`, the same frame is also painted
    /// into a texture of its own and written there as a PNG (the window export): its size, or
    /// why it could not be written.
    pub fn paint(
        &mut self,
        ctx: &egui::Context,
        output: egui::FullOutput,
        capture: Option<&Path>,
    ) -> Option<Result<[u32; 2], String>> {
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(frame) | wgpu::CurrentSurfaceTexture::Suboptimal(frame) => frame,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.gpu.device, &self.config);
                return capture.map(|_| Err("the window was being resized; press again".to_string()));
            }
            _ => return capture.map(|_| Err("the window has no frame to capture".to_string())),
        };
        let (device, queue) = (&self.gpu.device, &self.gpu.queue);
        for (id, deltas) in &output.textures_delta.set {
            for delta in deltas {
                self.painter.update_texture(device, queue, *id, delta);
            }
        }
        let jobs = ctx.tessellate(output.shapes, output.pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [self.config.width, self.config.height],
            pixels_per_point: output.pixels_per_point,
        };
        let mut encoder = device.create_command_encoder(&Default::default());
        let extra = self.painter.update_buffers(device, queue, &mut encoder, &jobs, &screen);
        self.render_jobs(&mut encoder, &frame.texture, &jobs, &screen);
        queue.submit(extra.into_iter().chain([encoder.finish()]));
        let captured = capture.map(|path| self.capture(&jobs, &screen, path));
        self.window.pre_present_notify();
        queue.present(frame);
        for id in &output.textures_delta.free {
            self.painter.free_texture(id);
        }
        captured
    }

    /// Paints `jobs` over a black `target`.
    fn render_jobs(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::Texture,
        jobs: &[egui::ClippedPrimitive],
        screen: &egui_wgpu::ScreenDescriptor,
    ) {
        let view = target.create_view(&Default::default());
        let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("egui"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        self.painter.render(&mut pass.forget_lifetime(), jobs, screen);
    }

    /// Paints the frame's `jobs` into a texture of the surface's format and size, reads it back
    /// (waiting: the user asked for it) and writes it to `path` as an opaque PNG.
    fn capture(
        &self,
        jobs: &[egui::ClippedPrimitive],
        screen: &egui_wgpu::ScreenDescriptor,
        path: &Path,
    ) -> Result<[u32; 2], String> {
        let [w, h] = screen.size_in_pixels;
        let bgra = match self.config.format {
            wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb => true,
            wgpu::TextureFormat::Rgba8Unorm | wgpu::TextureFormat::Rgba8UnormSrgb => false,
            other => return Err(format!("the window's pixels ({other:?}) cannot be written as an 8-bit PNG")),
        };
        let (device, queue) = (&self.gpu.device, &self.gpu.queue);
        let target = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("window capture"),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: self.config.format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let row = (w * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("window capture readback"),
            size: u64::from(row) * u64::from(h),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        self.render_jobs(&mut encoder, &target, jobs, screen);
        encoder.copy_texture_to_buffer(
            target.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &readback,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(row), rows_per_image: Some(h) },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        queue.submit([encoder.finish()]);
        let slice = readback.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        self.gpu.wait();
        let mapped = slice.get_mapped_range().map_err(|e| format!("cannot read the window back: {e}"))?;
        let mut pixels = Vec::with_capacity((w * h * 4) as usize);
        for line in mapped.chunks(row as usize) {
            for p in line[..(w * 4) as usize].chunks_exact(4) {
                let (r, b) = if bgra { (p[2], p[0]) } else { (p[0], p[2]) };
                pixels.extend_from_slice(&[r, p[1], b, 255]);
            }
        }
        drop(mapped);
        readback.unmap();
        let image = image::RgbaImage::from_raw(w, h, pixels).ok_or("the window's image has the wrong size")?;
        image.save(path).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        Ok([w, h])
    }
}
