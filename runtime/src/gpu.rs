//! The device the runtime renders with: created headless, or an application's own.

use std::fmt;
use std::sync::{Arc, Mutex};

/// A wgpu device and queue, and what adapter they came from.
///
/// wgpu's default answer to an error nobody captured is a panic. Every `Gpu` replaces it: the
/// runtime captures the errors of what it creates and submits ([`Gpu::capture`]), and anything
/// that escapes is kept as a [`GpuFault`] for the next [`Gpu::take_fault`], so a wgpu error
/// always reaches the user as a value.
#[derive(Clone)]
pub struct Gpu {
    /// The wgpu device everything is made on.
    pub device: wgpu::Device,
    /// The device's queue, where every submission goes.
    pub queue: wgpu::Queue,
    /// The adapter's name and backend, for logs and benchmark reports.
    pub adapter: String,
    /// Whether it is a CPU (software) adapter such as lavapipe.
    pub(crate) software: bool,
    /// Errors no error scope captured, oldest first.
    uncaptured: Arc<Mutex<Vec<GpuFault>>>,
}

/// A wgpu error: validation (what the runtime asked for does not fit the device or its rules),
/// out of memory, or internal; with what the runtime was doing.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GpuFault {
    /// What the runtime was doing: "creating the output image of view `3d`".
    pub(crate) doing: String,
    /// Which kind of wgpu error it was.
    pub kind: GpuFaultKind,
    /// wgpu's own report, its causes included.
    pub message: String,
}

/// The kinds of wgpu error (wgpu's error filters).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuFaultKind {
    /// What was asked does not fit the device's limits or wgpu's rules.
    Validation,
    /// The device (or host) ran out of memory.
    OutOfMemory,
    /// The driver or wgpu failed on its own.
    Internal,
}

impl GpuFault {
    fn new(doing: &str, error: &wgpu::Error) -> GpuFault {
        let kind = match error {
            wgpu::Error::OutOfMemory { .. } => GpuFaultKind::OutOfMemory,
            wgpu::Error::Validation { .. } => GpuFaultKind::Validation,
            wgpu::Error::Internal { .. } => GpuFaultKind::Internal,
        };
        GpuFault { doing: doing.to_string(), kind, message: full_message(error) }
    }
}

impl fmt::Display for GpuFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = match self.kind {
            GpuFaultKind::Validation => "refused",
            GpuFaultKind::OutOfMemory => "ran out of memory",
            GpuFaultKind::Internal => "failed",
        };
        write!(f, "the GPU {what} {}: {}", self.doing, self.message)
    }
}

impl std::error::Error for GpuFault {}

/// An error and its causes on one line, without wgpu's headings ("Validation Error", "Caused
/// by:") and blank lines.
fn full_message(error: &wgpu::Error) -> String {
    let mut text = error.to_string();
    let mut source = std::error::Error::source(error);
    while let Some(cause) = source {
        let line = cause.to_string();
        if !text.contains(&line) {
            text.push_str(": ");
            text.push_str(&line);
        }
        source = cause.source();
    }
    let headings = ["Validation Error", "Caused by:", "Out of Memory"];
    let lines = text.lines().map(str::trim).filter(|l| !l.is_empty() && !headings.contains(l));
    lines.collect::<Vec<_>>().join(": ")
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
            // Volumes need the adapter's largest 3D textures, not WebGPU's default 2048; images
            // may be as large as the adapter allows (a scene's views stay within the 8192
            // every device holds).
            required_limits: wgpu::Limits {
                max_texture_dimension_3d: limits.max_texture_dimension_3d,
                max_texture_dimension_2d: limits.max_texture_dimension_2d,
                max_buffer_size: limits.max_buffer_size,
                ..wgpu::Limits::default()
            },
            ..Default::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&descriptor))
            .map_err(|e| GpuError(format!("cannot open a device on {}: {e}", info.name)))?;
        let mut gpu = Gpu::from_device(device, queue);
        gpu.adapter = format!("{} ({:?})", info.name, info.backend);
        if info.device_type == wgpu::DeviceType::Cpu && info.backend == wgpu::Backend::Gl {
            // Said wherever the adapter is printed: the picture may be wrong here.
            gpu.adapter += " — Mesa's OpenGL software driver, on which scenes with meshes cannot render \
                            (OpenGL ES renders into no r32float image) and light volumes came out wrong; \
                            vrsc is tested on lavapipe (apt-get install mesa-vulkan-drivers)";
        }
        gpu.software = info.device_type == wgpu::DeviceType::Cpu;
        Ok(gpu)
    }

    /// Wraps an application's own device and queue; errors nobody captures are kept for
    /// [`Gpu::take_fault`] from now on, instead of wgpu's panic.
    pub(crate) fn from_device(device: wgpu::Device, queue: wgpu::Queue) -> Gpu {
        let uncaptured: Arc<Mutex<Vec<GpuFault>>> = Arc::default();
        let kept = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
            if let Ok(mut faults) = kept.lock() {
                faults.push(GpuFault::new("rendering", &error));
            }
        }));
        Gpu { device, queue, adapter: "application device".into(), software: false, uncaptured }
    }

    /// Runs `work` (resource or pipeline creation, encoding, a submission) with its wgpu
    /// errors captured: validation, out of memory and internal errors come back as the
    /// [`GpuFault`] of `doing`, the first one wgpu reported.
    pub fn capture<T>(&self, doing: &str, work: impl FnOnce() -> T) -> Result<T, GpuFault> {
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let value = work();
        // Scopes pop innermost first.
        let errors = [validation, memory, internal].map(|scope| pollster::block_on(scope.pop()));
        match errors.iter().flatten().next() {
            Some(error) => Err(GpuFault::new(doing, error)),
            None => Ok(value),
        }
    }

    /// The oldest error that escaped every capture since the last call (work another thread
    /// submitted, say), and forgets the others: the first is the cause.
    pub fn take_fault(&self) -> Option<GpuFault> {
        let mut faults = self.uncaptured.lock().ok()?;
        let first = (!faults.is_empty()).then(|| faults.remove(0));
        faults.clear();
        first
    }

    /// Waits until the GPU finished all submitted work.
    pub fn wait(&self) {
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }
}

/// A CPU adapter behind Vulkan (Mesa's lavapipe) that can draw into `surface`, if there is
/// one. Asked for the fallback adapter, wgpu may hand out Mesa's OpenGL llvmpipe instead; the
/// renderer is tested on lavapipe, and on the GL one a compute pass (the light volumes) came
/// out wrong with no error, so the software choice takes Vulkan's whenever it is there (and
/// the adapter's description says so when only the GL one is).
fn vulkan_software_adapter(instance: &wgpu::Instance, surface: Option<&wgpu::Surface<'_>>) -> Option<wgpu::Adapter> {
    pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN)).into_iter().find(|a| {
        a.get_info().device_type == wgpu::DeviceType::Cpu && surface.is_none_or(|s| a.is_surface_supported(s))
    })
}

/// The adapter to render with: a high-performance one (only a CPU one when `software`), able to
/// present to `surface` when there is one; a software adapter when nothing else is found.
pub fn request_adapter(
    instance: &wgpu::Instance,
    surface: Option<&wgpu::Surface<'_>>,
    software: bool,
) -> Result<wgpu::Adapter, GpuError> {
    if software && let Some(lavapipe) = vulkan_software_adapter(instance, surface) {
        return Ok(lavapipe);
    }
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
