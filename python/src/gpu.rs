//! One GPU device for the whole process, made when the first scene needs it: every scene
//! shares it (a device per scene would cost a driver start-up each, and its memory).

use crate::errors;
use pyo3::prelude::*;
use std::sync::OnceLock;
use vrs_runtime::{AdapterChoice, Gpu};

static GPU: OnceLock<Result<Gpu, String>> = OnceLock::new();

/// The process's device: a hardware adapter when there is one, else lavapipe;
/// `VRS_ADAPTER=software` in the environment forces the software one (as for the CLI).
/// Call with the GIL released: the first call starts the driver.
pub fn shared() -> Result<Gpu, String> {
    GPU.get_or_init(|| Gpu::headless(AdapterChoice::PreferHardware).map_err(|e| e.to_string())).clone()
}

/// The adapter vrsc renders with, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)`.
#[pyfunction]
pub fn adapter(py: Python<'_>) -> PyResult<String> {
    let gpu = py.detach(shared).map_err(|e| errors::scene_error(py, e))?;
    Ok(gpu.adapter.clone())
}
