//! Volumes and transfer functions on the GPU. Each is uploaded once and shared (by `Arc`) by
//! every view that binds it.

use crate::error::RuntimeError;
use crate::gpu::{Gpu, GpuFault};
use crate::occupancy::{BrickRanges, RangeBuilder};
use crate::tf::{TF_WIDTH, TransferFunction};
use crate::volume::{
    Histogram, LoadError, LoadErrorKind, RangeSink, SampleSink, Samples, Volume, VolumeFeed, VolumeInfo, Window,
};
use glam::Mat4;

/// A volume as a 3D `R16Float` texture of values normalized to [0, 1], uploaded a slab at a time.
pub(crate) struct VolumeTexture {
    /// The texture `view` shows, held with it.
    #[allow(dead_code, reason = "held for its lifetime; the shaders bind `view`")]
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub dims: [u32; 3],
    /// Voxel index to world, from the file's header.
    pub grid_to_world: Mat4,
    /// How many voxels fall in each of [`HISTOGRAM_BINS`] equal parts of the window the
    /// texture is normalized by (voxels outside the window count in the end bins): what the
    /// transfer-function editor draws.
    pub histogram: Vec<u64>,
}

/// Bins of a [`VolumeTexture`]'s histogram.
pub(crate) const HISTOGRAM_BINS: usize = 256;

impl VolumeTexture {
    /// Uploads `volume`, mapping `window` (or its value range) to [0, 1]. Refuses grids beyond
    /// the device's 3D texture limit.
    pub(crate) fn upload(
        gpu: &Gpu,
        name: &str,
        volume: &Volume,
        window: Option<[f32; 2]>,
    ) -> Result<VolumeTexture, RuntimeError> {
        let info = VolumeInfo { dims: volume.dims, grid_to_world: volume.grid_to_world, scaling: volume.scaling };
        let mut writer = TextureWriter::new(gpu, name, &info, window.unwrap_or(volume.range))?;
        volume.samples.for_each(0..volume.samples.len(), |s| writer.push(s));
        writer.finish()
    }

    /// Uploads the volume file `path` without keeping its samples, mapping `window` (data
    /// units) to [0, 1]; without one, the automatic window ([`crate::volume::auto_window`]):
    /// a first pass finds the value range, a second the percentiles. The last pass converts and
    /// writes the texture as the file is read, so loading holds only the texture (and a slab),
    /// never the file's data. `progress(done, total)` covers every pass. Returns the texture
    /// and the window it was normalized by, and with `ranges` the value range of every brick
    /// of empty-space skipping, taken from the texels on the way (so skipping needs no copy of
    /// the volume either).
    pub(crate) fn stream_file(
        gpu: &Gpu,
        name: &str,
        path: &std::path::Path,
        window: Option<[f32; 2]>,
        ranges: bool,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<(VolumeTexture, [f32; 2], Option<BrickRanges>), RuntimeError> {
        let mut source = |report: &mut dyn FnMut(u64, u64), sink: &mut dyn SampleSink| {
            crate::volume::stream(path, report, sink).map_err(RuntimeError::from)
        };
        VolumeTexture::stream_passes(gpu, name, window, ranges, progress, &mut source)
    }

    /// [`VolumeTexture::stream_file`] for a volume the application holds in memory: read where
    /// it lies, a chunk at a time, in as many passes as a file. `path` names it in errors.
    pub(crate) fn stream_feed(
        gpu: &Gpu,
        name: &str,
        path: &std::path::Path,
        feed: &dyn VolumeFeed,
        window: Option<[f32; 2]>,
        ranges: bool,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<(VolumeTexture, [f32; 2], Option<BrickRanges>), RuntimeError> {
        let mut source = |report: &mut dyn FnMut(u64, u64), sink: &mut dyn SampleSink| {
            let info = crate::volume::stream_feed(feed, sink)
                .map_err(|kind| RuntimeError::Volume(LoadError { path: path.to_path_buf(), kind }))?;
            report(1, 1);
            Ok(info)
        };
        VolumeTexture::stream_passes(gpu, name, window, ranges, progress, &mut source)
    }

    /// The passes of [`VolumeTexture::stream_file`] over any `source` that streams a volume
    /// into a sink (reporting its progress), once per pass.
    fn stream_passes(
        gpu: &Gpu,
        name: &str,
        window: Option<[f32; 2]>,
        ranges: bool,
        progress: &mut dyn FnMut(u64, u64),
        source: &mut StreamPass,
    ) -> Result<(VolumeTexture, [f32; 2], Option<BrickRanges>), RuntimeError> {
        let passes = if window.is_some() { 1 } else { 3 };
        let mut pass = 0;
        let mut stream = |sink: &mut dyn SampleSink| {
            let mut report = |done: u64, total: u64| progress(pass * total + done, passes * total);
            let info = source(&mut report, sink);
            pass += 1;
            info
        };
        let window = match window {
            Some(window) => window,
            None => {
                let mut range = RangeSink::default();
                let info = stream(&mut range)?;
                let mut histogram = Histogram::new(range.range(), info.scaling);
                stream(&mut histogram)?;
                histogram.auto_window()
            }
        };
        let mut writer: Option<TextureWriter> = None;
        let mut sink = LazyWriter { gpu, name, window, ranges, writer: &mut writer, error: None };
        let loaded = stream(&mut sink);
        if let Some(error) = sink.error.take() {
            return Err(error);
        }
        loaded?;
        let writer = writer.ok_or_else(|| RuntimeError::Invalid(format!("volume `{name}`: no samples were read")))?;
        let (texture, ranges) = writer.finish_with_ranges()?;
        Ok((texture, window, ranges))
    }
}

/// One pass over a volume's samples into a sink, reporting its progress (done, total): a file
/// read, or an application's feed.
type StreamPass<'a> = dyn FnMut(&mut dyn FnMut(u64, u64), &mut dyn SampleSink) -> Result<VolumeInfo, RuntimeError> + 'a;

/// Creates its [`TextureWriter`] when the loader announces the grid (`begin`), so one pass
/// both reads the header and fills the texture.
struct LazyWriter<'g, 'w> {
    gpu: &'g Gpu,
    name: &'w str,
    window: [f32; 2],
    /// Whether the writer takes the brick ranges of empty-space skipping.
    ranges: bool,
    writer: &'w mut Option<TextureWriter<'g>>,
    /// A GPU-side refusal (a grid beyond the device's limits), reported instead of the load
    /// error that stops the loader.
    error: Option<RuntimeError>,
}

impl SampleSink for LazyWriter<'_, '_> {
    fn begin(&mut self, info: &VolumeInfo) -> Result<(), LoadErrorKind> {
        match TextureWriter::new(self.gpu, self.name, info, self.window) {
            Ok(writer) => {
                *self.writer = Some(if self.ranges { writer.with_ranges() } else { writer });
                Ok(())
            }
            Err(error) => {
                let message = error.to_string();
                self.error = Some(error);
                Err(LoadErrorKind::Header(message))
            }
        }
    }

    fn samples(&mut self, chunk: &Samples) -> Result<(), LoadErrorKind> {
        match self.writer.as_mut() {
            Some(writer) => writer.samples(chunk),
            None => Ok(()),
        }
    }
}

/// Half floats converted and written per `write_texture` call: bounds the upload's extra memory
/// (the converted slab and the queue's staging copy of it) whatever the volume's size.
const SLAB_TEXELS: usize = 1 << 20;

/// Pending uploads are submitted and waited for after this many bytes, so the queue's staging
/// buffers (freed only once the GPU has copied them) never add up to a second copy of the volume.
const FLUSH_BYTES: usize = 8 << 20;

/// Fills a volume texture from stored samples in voxel order, converting and writing whole z
/// slices a slab at a time: the upload never holds more than a slab besides the texture.
pub(crate) struct TextureWriter<'g> {
    gpu: &'g Gpu,
    name: String,
    texture: wgpu::Texture,
    info: VolumeInfo,
    window: Window,
    /// Normalized texels of the slices not yet written.
    slab: Vec<half::f16>,
    /// The first z slice of `slab`.
    z: u32,
    /// Bytes written since the last submit.
    pending: usize,
    histogram: Vec<u64>,
    /// The brick ranges of empty-space skipping, when asked for ([`TextureWriter::with_ranges`]).
    ranges: Option<RangeBuilder>,
}

impl<'g> TextureWriter<'g> {
    /// An empty texture for a volume of `info`'s shape whose values `window` (data units) maps
    /// to [0, 1]. Refuses grids beyond the device's 3D texture limit.
    pub(crate) fn new(
        gpu: &'g Gpu,
        name: &str,
        info: &VolumeInfo,
        window: [f32; 2],
    ) -> Result<TextureWriter<'g>, RuntimeError> {
        let max = gpu.device.limits().max_texture_dimension_3d;
        let [w, h, d] = info.dims;
        if info.dims.iter().any(|&n| n == 0 || n > max) {
            return Err(RuntimeError::Invalid(format!(
                "volume `{name}`: a {w}x{h}x{d} grid exceeds this device's 3D texture limit of {max} per axis"
            )));
        }
        let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
        let image = Image3d { label: name, size: info.dims, format: wgpu::TextureFormat::R16Float, usage };
        let texture = image.create(gpu, &format!("creating the {w}x{h}x{d} texture of volume `{name}`"))?;
        let slice = w as usize * h as usize;
        let capacity = SLAB_TEXELS.max(slice) + slice;
        Ok(TextureWriter {
            gpu,
            name: name.to_string(),
            texture,
            info: *info,
            window: Window::new(window, info.scaling),
            slab: Vec::with_capacity(capacity),
            z: 0,
            pending: 0,
            histogram: vec![0; HISTOGRAM_BINS],
            ranges: None,
        })
    }

    /// Also takes the value range of every brick of empty-space skipping from the normalized
    /// texels as they are written ([`TextureWriter::finish_with_ranges`]).
    pub(crate) fn with_ranges(self) -> TextureWriter<'g> {
        TextureWriter { ranges: Some(RangeBuilder::new(self.info.dims)), ..self }
    }

    /// The next stored sample.
    pub(crate) fn push(&mut self, stored: f32) {
        let normalized = self.window.apply(stored);
        self.histogram[((normalized * HISTOGRAM_BINS as f32) as usize).min(HISTOGRAM_BINS - 1)] += 1;
        if let Some(ranges) = &mut self.ranges {
            ranges.push(normalized);
        }
        self.slab.push(half::f16::from_f32(normalized));
        if self.slab.len() >= SLAB_TEXELS.max(self.slice()) {
            self.write();
        }
    }

    fn slice(&self) -> usize {
        self.info.dims[0] as usize * self.info.dims[1] as usize
    }

    /// Writes the whole slices in `slab`.
    fn write(&mut self) {
        let [w, h, d] = self.info.dims;
        let depth = ((self.slab.len() / self.slice()) as u32).min(d.saturating_sub(self.z));
        if depth == 0 {
            return;
        }
        let texels = depth as usize * self.slice();
        self.gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &self.texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x: 0, y: 0, z: self.z },
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&self.slab[..texels]),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(w * 2), rows_per_image: Some(h) },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: depth },
        );
        self.slab.drain(..texels);
        self.z += depth;
        self.pending += texels * 2;
        if self.pending >= FLUSH_BYTES {
            self.gpu.queue.submit([]);
            self.gpu.wait();
            self.pending = 0;
        }
    }

    /// Writes what is left and returns the texture; an error when fewer samples came than the
    /// grid has (more are ignored: the loaders check the count).
    pub(crate) fn finish(self) -> Result<VolumeTexture, RuntimeError> {
        Ok(self.finish_with_ranges()?.0)
    }

    /// [`TextureWriter::finish`], with the brick ranges when the writer took them.
    pub(crate) fn finish_with_ranges(mut self) -> Result<(VolumeTexture, Option<BrickRanges>), RuntimeError> {
        self.write();
        if self.z < self.info.dims[2] {
            return Err(RuntimeError::Invalid(format!(
                "volume `{}`: {} of {} slices arrived",
                self.name, self.z, self.info.dims[2]
            )));
        }
        // The slab writes ran outside any capture (they are many): what they raised is here.
        if let Some(fault) = self.gpu.take_fault() {
            return Err(GpuFault { doing: format!("uploading volume `{}`", self.name), ..fault }.into());
        }
        let view = self.texture.create_view(&wgpu::TextureViewDescriptor::default());
        let (dims, grid_to_world, histogram) = (self.info.dims, self.info.grid_to_world, self.histogram);
        let ranges = self.ranges.map(RangeBuilder::finish);
        Ok((VolumeTexture { texture: self.texture, view, dims, grid_to_world, histogram }, ranges))
    }
}

/// A [`TextureWriter`] fed by a loader: the second pass of loading a volume that is not kept.
impl SampleSink for TextureWriter<'_> {
    fn begin(&mut self, info: &VolumeInfo) -> Result<(), LoadErrorKind> {
        if info.dims != self.info.dims {
            return Err(LoadErrorKind::Header(format!(
                "the file changed while it was read: its grid is now {:?}, was {:?}",
                info.dims, self.info.dims
            )));
        }
        Ok(())
    }

    fn samples(&mut self, chunk: &Samples) -> Result<(), LoadErrorKind> {
        chunk.for_each(0..chunk.len(), |s| self.push(s));
        Ok(())
    }
}

/// A transfer function as a `TF_WIDTH` x 1 `Rgba16Float` texture (straight alpha; see
/// [`crate::tf::to_rgba16f`] for why 16 bits).
pub(crate) struct TfTexture {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
}

impl TfTexture {
    pub(crate) fn upload(gpu: &Gpu, tf: &TransferFunction) -> Result<TfTexture, RuntimeError> {
        let image =
            Image2d { label: &tf.name, size: [TF_WIDTH, 1], format: wgpu::TextureFormat::Rgba16Float, usage: TABLE };
        let texture = image.create(gpu, &format!("creating the texture of transfer function `{}`", tf.name))?;
        let tf_texture = TfTexture { view: texture.create_view(&Default::default()), texture };
        tf_texture.write(gpu, tf);
        Ok(tf_texture)
    }

    /// Replaces the table (a transfer-function edit: no new texture, no new pipeline).
    pub(crate) fn write(&self, gpu: &Gpu, tf: &TransferFunction) {
        gpu.queue.write_texture(
            self.texture.as_image_copy(),
            &tf.to_rgba16f(),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(TF_WIDTH * 8), rows_per_image: Some(1) },
            wgpu::Extent3d { width: TF_WIDTH, height: 1, depth_or_array_layers: 1 },
        );
    }
}

impl TfTexture {
    /// A 2D table of float RGBA entries (`Rgba16Float`, filterable everywhere) bound like a
    /// transfer function: the pre-integration table of `std::preintegrate`, whose alpha is an
    /// extinction that may exceed 1.
    pub(crate) fn upload_table(
        gpu: &Gpu,
        name: &str,
        size: [u32; 2],
        rgba16f: &[u8],
    ) -> Result<TfTexture, RuntimeError> {
        let [w, h] = size;
        let image = Image2d { label: name, size, format: wgpu::TextureFormat::Rgba16Float, usage: TABLE };
        let texture = image.create(gpu, &format!("creating the {w}x{h} table `{name}`"))?;
        let table = TfTexture { view: texture.create_view(&Default::default()), texture };
        table.write_table(gpu, rgba16f);
        Ok(table)
    }

    /// Replaces the entries of a table made by [`TfTexture::upload_table`] (same size).
    pub(crate) fn write_table(&self, gpu: &Gpu, rgba16f: &[u8]) {
        let size = self.texture.size();
        gpu.queue.write_texture(
            self.texture.as_image_copy(),
            rgba16f,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(size.width * 8),
                rows_per_image: Some(size.height),
            },
            size,
        );
    }
}

/// A table: sampled, written from the CPU.
const TABLE: wgpu::TextureUsages = wgpu::TextureUsages::TEXTURE_BINDING.union(wgpu::TextureUsages::COPY_DST);

/// A 2D texture of one mip level: what every image and table of the runtime is.
pub(crate) struct Image2d<'a> {
    pub label: &'a str,
    pub size: [u32; 2],
    pub format: wgpu::TextureFormat,
    pub usage: wgpu::TextureUsages,
}

impl Image2d<'_> {
    /// Creates it, its errors captured as those of `doing`; a zero side is one texel.
    pub(crate) fn create(&self, gpu: &Gpu, doing: &str) -> Result<wgpu::Texture, RuntimeError> {
        self.create_layers(gpu, doing, 1)
    }

    /// Creates an array of `layers` such images.
    pub(crate) fn create_layers(&self, gpu: &Gpu, doing: &str, layers: u32) -> Result<wgpu::Texture, RuntimeError> {
        let [w, h] = self.size;
        let size = [w, h, layers];
        create_texture(gpu, doing, (self.label, size, wgpu::TextureDimension::D2), (self.format, self.usage))
    }
}

/// A 3D texture of one mip level: a volume, a brick pool, a light volume.
pub(crate) struct Image3d<'a> {
    pub label: &'a str,
    pub size: [u32; 3],
    pub format: wgpu::TextureFormat,
    pub usage: wgpu::TextureUsages,
}

impl Image3d<'_> {
    /// Creates it, its errors captured as those of `doing`; a zero side is one texel.
    pub(crate) fn create(&self, gpu: &Gpu, doing: &str) -> Result<wgpu::Texture, RuntimeError> {
        create_texture(gpu, doing, (self.label, self.size, wgpu::TextureDimension::D3), (self.format, self.usage))
    }
}

/// A texture of one mip level and one sample, `size` texels (a zero side is one texel).
fn create_texture(
    gpu: &Gpu,
    doing: &str,
    (label, size, dimension): (&str, [u32; 3], wgpu::TextureDimension),
    (format, usage): (wgpu::TextureFormat, wgpu::TextureUsages),
) -> Result<wgpu::Texture, RuntimeError> {
    let [width, height, depth_or_array_layers] = size.map(|n| n.max(1));
    let texture = gpu.capture(doing, || {
        gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width, height, depth_or_array_layers },
            mip_level_count: 1,
            sample_count: 1,
            dimension,
            format,
            usage,
            view_formats: &[],
        })
    })?;
    Ok(texture)
}

/// Trilinear filtering, clamped at the edges: how every volume and transfer function is read.
pub(crate) fn linear_sampler(gpu: &Gpu) -> wgpu::Sampler {
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
