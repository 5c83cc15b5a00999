//! `vrsc.check` and `vrsc.compose`: the compiler's passes on modules and scenes, without a GPU.

use crate::diagnostics::{PyDiagnostic, collect, warnings_or_error};
use crate::errors;
use pyo3::exceptions::{PyFileNotFoundError, PyOSError};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// Runs `work` on a thread with a large stack, as the CLI does (a second line of defence
/// behind the compiler's depth limits), with the GIL released; a panic is an error, not a
/// crash of the interpreter.
pub fn on_big_stack<T: Send>(py: Python<'_>, what: &str, work: impl FnOnce() -> T + Send) -> PyResult<T> {
    let joined = py.detach(|| {
        std::thread::scope(|scope| {
            std::thread::Builder::new().stack_size(256 << 20).spawn_scoped(scope, work).map(|h| h.join())
        })
    });
    match joined {
        Ok(Ok(value)) => Ok(value),
        Ok(Err(_panic)) => Err(errors::internal(py, what)),
        Err(spawn) => Err(PyOSError::new_err(format!("cannot start a thread for {what}: {spawn}"))),
    }
}

/// An I/O error about `path` as Python's `FileNotFoundError` or `OSError`.
pub fn io_error(path: &Path, error: &std::io::Error) -> PyErr {
    let message = format!("cannot read `{}`: {error}", path.display());
    match error.kind() {
        std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
        _ => PyOSError::new_err(message),
    }
}

/// Checks one module given as text, named `name` in diagnostics; imports resolve from `dir`.
#[pyfunction]
#[pyo3(signature = (text, name="<string>", dir=None))]
pub fn check_source(py: Python<'_>, text: String, name: &str, dir: Option<PathBuf>) -> PyResult<Vec<PyDiagnostic>> {
    let list = on_big_stack(py, "checking a module", || {
        let checked = vrsc::driver::check_source(name, &text, dir.as_deref());
        collect(&checked.diags, &checked.sources)
    })?;
    warnings_or_error(py, list)
}

/// Checks module files and what they import.
#[pyfunction]
pub fn check_files(py: Python<'_>, paths: Vec<PathBuf>) -> PyResult<Vec<PyDiagnostic>> {
    let checked = on_big_stack(py, "checking modules", || {
        vrsc::driver::check_files(&paths).map(|checked| collect(&checked.diags, &checked.sources))
    })?;
    let list = checked.map_err(|e| io_error(&e.path, &e.error))?;
    warnings_or_error(py, list)
}

/// Composes every view of the scene file `path` (or only `view`), as `vrsc build` does without
/// writing anything.
#[pyfunction]
#[pyo3(signature = (path, view=None))]
pub fn compose(py: Python<'_>, path: PathBuf, view: Option<String>) -> PyResult<Vec<PyDiagnostic>> {
    let built = on_big_stack(py, "composing a scene", || {
        vrsc::compose::build::build_scene(&path, view.as_deref()).map(|built| collect(&built.diags, &built.sources))
    })?;
    let list = built.map_err(|e| io_error(&path, &e))?;
    warnings_or_error(py, list)
}
