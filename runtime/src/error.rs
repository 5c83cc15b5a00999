//! Errors of the runtime, each naming what it concerns (a file, a uniform, a view).

use std::fmt;
use std::path::PathBuf;

/// Why the runtime could not do what it was asked; its `Display` is a sentence for users.
#[derive(Debug)]
pub enum RuntimeError {
    /// No adapter or device.
    Gpu(crate::gpu::GpuError),
    /// A file could not be read or written.
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        error: std::io::Error,
    },
    /// A `.wgsl` + `.json` pair that does not belong together, or malformed reflection.
    Shader {
        /// The `.json` (or the file that named the pair).
        path: PathBuf,
        /// What does not match.
        message: String,
    },
    /// wgpu refused or could not make a resource, a bind group or a submission (validation,
    /// out of memory), or an error escaped every capture.
    Device(crate::gpu::GpuFault),
    /// wgpu refused the shader or pipeline (a bug in the composer if it validated).
    Pipeline {
        /// The view whose shader it is.
        view: String,
        /// wgpu's report.
        message: String,
    },
    /// A volume could not be loaded.
    Volume(crate::volume::LoadError),
    /// A transfer function could not be made (an unknown preset, an unreadable colormap).
    Tf(crate::tf::TfError),
    /// A uniform could not be set.
    Uniform {
        /// The view whose uniform it is.
        view: String,
        /// Why not.
        error: crate::uniforms::UniformError,
    },
    /// Input that is valid on its own but cannot be used here: a missing binding, a volume
    /// beyond the device's limits, an unknown phantom.
    Invalid(String),
    /// A scene did not compose; the diagnostics were rendered into the message.
    #[cfg(feature = "compiler")]
    Compose {
        /// The diagnostics, rendered with their source lines.
        rendered: String,
    },
}

impl RuntimeError {
    /// The `vrsc` exit code: 2 for I/O outside the scene's inputs and device problems, 1 for bad
    /// input (a volume or transfer function the scene names, missing or unreadable included:
    /// `vrsc build` reports those as E0719, and a render exits the same).
    pub fn exit_code(&self) -> u8 {
        match self {
            RuntimeError::Io { .. } | RuntimeError::Gpu(_) | RuntimeError::Device(_) => 2,
            _ => 1,
        }
    }
}

impl fmt::Display for RuntimeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RuntimeError::Gpu(e) => write!(f, "{e}"),
            RuntimeError::Device(e) => write!(f, "{e}"),
            RuntimeError::Io { path, error } => write!(f, "`{}`: {error}", path.display()),
            RuntimeError::Shader { path, message } => write!(f, "`{}`: {message}", path.display()),
            RuntimeError::Pipeline { view, message } => {
                write!(f, "view `{view}`: the GPU refused its shader: {message}")
            }
            RuntimeError::Volume(e) => write!(f, "{e}"),
            RuntimeError::Tf(e) => write!(f, "{e}"),
            RuntimeError::Uniform { view, error } => write!(f, "view `{view}`: {error}"),
            RuntimeError::Invalid(message) => f.write_str(message),
            #[cfg(feature = "compiler")]
            RuntimeError::Compose { rendered } => f.write_str(rendered),
        }
    }
}

impl std::error::Error for RuntimeError {}

impl From<crate::gpu::GpuError> for RuntimeError {
    fn from(e: crate::gpu::GpuError) -> RuntimeError {
        RuntimeError::Gpu(e)
    }
}

impl From<crate::gpu::GpuFault> for RuntimeError {
    fn from(e: crate::gpu::GpuFault) -> RuntimeError {
        RuntimeError::Device(e)
    }
}

impl From<crate::volume::LoadError> for RuntimeError {
    fn from(e: crate::volume::LoadError) -> RuntimeError {
        RuntimeError::Volume(e)
    }
}

impl From<crate::tf::TfError> for RuntimeError {
    fn from(e: crate::tf::TfError) -> RuntimeError {
        RuntimeError::Tf(e)
    }
}
