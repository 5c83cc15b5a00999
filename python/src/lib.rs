//! The native half of the `vrsc` Python package (`vrsc._vrsc`): checking and composing through
//! the compiler library, rendering through the runtime. The Python half (`python/vrsc/`)
//! describes scenes, picks between source text and paths, and defines the exception classes
//! this module raises.
//!
//! Rules every function here keeps: errors come back as Python exceptions carrying the same
//! text the CLI prints; the GIL is released while the GPU works; nothing a caller passes can
//! make the runtime panic (arrays are checked before they become volumes, uniforms are typed
//! from the reflection).

mod check;
mod diagnostics;
mod errors;
mod feed;
mod gpu;
mod png;
mod scene;
mod values;

use pyo3::prelude::*;

#[pymodule]
fn _vrsc(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<diagnostics::PyDiagnostic>()?;
    m.add_class::<scene::SceneHandle>()?;
    m.add_function(wrap_pyfunction!(check::check_source, m)?)?;
    m.add_function(wrap_pyfunction!(check::check_files, m)?)?;
    m.add_function(wrap_pyfunction!(check::compose, m)?)?;
    m.add_function(wrap_pyfunction!(png::encode_png, m)?)?;
    m.add_function(wrap_pyfunction!(gpu::adapter, m)?)?;
    Ok(())
}
