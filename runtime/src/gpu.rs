//! The device the runtime renders with: created headless, or an application's own.

use std::fmt;

/// A wgpu device and queue, and what adapter they came from.
#[derive(Clone)]
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// The adapter's name and backend, for logs and benchmark reports.
    pub adapter: String,
    /// Whether it is a CPU (software) adapter such as lavapipe.
    pub software: bool,
}

/// Which adapters [`Gpu::headless`] may pick.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AdapterChoice {
    /// A hardware adapter when there is one, else a software one.
    #[default]
    PreferHardware,
    /// Only a CPU adapter (lavapipe): the same images on every machine, for golden tests.
    Software,
}

/// No usable adapter or device.
#[derive(Debug)]
pub struct GpuError(pub String);

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for GpuError {}

impl Gpu {
    /// Creates a device without a window. `VRS_ADAPTER=software` in the environment forces the
    /// software adapter; `WGPU_BACKEND` limits the backends as usual in wgpu.
    pub fn headless(choice: AdapterChoice) -> Result<Gpu, GpuError> {
        let choice = match std::env::var("VRS_ADAPTER").as_deref() {
            Ok("software") => AdapterChoice::Software,
            _ => choice,
        };
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = request_adapter(&instance, None, choice == AdapterChoice::Software)?;
        Gpu::from_adapter(&adapter)
    }

    /// Opens a device on `adapter` with the limits volumes need (an application that picked
    /// the adapter itself, for example one compatible with its window's surface).
    pub fn from_adapter(adapter: &wgpu::Adapter) -> Result<Gpu, GpuError> {
        let info = adapter.get_info();
        let limits = adapter.limits();
        let descriptor = wgpu::DeviceDescriptor {
            label: Some("vrs-runtime"),
            required_features: wgpu::Features::empty(),
            // Volumes need the adapter's largest 3D textures, not WebGPU's default 2048.
            required_limits: wgpu::Limits {
                max_texture_dimension_3d: limits.max_texture_dimension_3d,
                max_buffer_size: limits.max_buffer_size,
                ..wgpu::Limits::default()
            },
            ..Default::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&descriptor))
            .map_err(|e| GpuError(format!("cannot open a device on {}: {e}", info.name)))?;
        Ok(Gpu {
            device,
            queue,
            adapter: format!("{} ({:?})", info.name, info.backend),
            software: info.device_type == wgpu::DeviceType::Cpu,
        })
    }

    /// Wraps an application's own device and queue.
    pub fn from_device(device: wgpu::Device, queue: wgpu::Queue) -> Gpu {
        Gpu { device, queue, adapter: "application device".into(), software: false }
    }

    /// Waits until the GPU finished all submitted work.
    pub fn wait(&self) {
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }
}

/// The adapter to render with: a high-performance one (only a CPU one when `software`), able to
/// present to `surface` when there is one; a software adapter when nothing else is found.
pub fn request_adapter(
    instance: &wgpu::Instance,
    surface: Option<&wgpu::Surface<'_>>,
    software: bool,
) -> Result<wgpu::Adapter, GpuError> {
    let options = wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter: software,
        compatible_surface: surface,
        ..Default::default()
    };
    pollster::block_on(instance.request_adapter(&options))
        .or_else(|_| {
            let fallback = wgpu::RequestAdapterOptions { force_fallback_adapter: true, ..options };
            pollster::block_on(instance.request_adapter(&fallback))
        })
        .map_err(|e| {
            GpuError(format!(
                "no graphics adapter ({e}). On Debian or Ubuntu without a GPU, install the software \
                 Vulkan driver: apt-get install mesa-vulkan-drivers libvulkan1"
            ))
        })
}
