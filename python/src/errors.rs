//! Python exceptions for the runtime's and the compiler's errors. The classes live in
//! `vrsc/_errors.py` (so they can derive from both `vrsc.SceneError` and `KeyError` or
//! `TypeError`, which Rust-made exception types cannot); this module raises them with the text
//! the CLI would print.

use pyo3::prelude::*;
use pyo3::types::PyType;
use vrs_runtime::RuntimeError;
use vrs_runtime::uniforms::UniformError;

/// An exception of class `class` from `vrsc._errors`, made with `args`.
pub fn raise<A>(py: Python<'_>, class: &str, args: A) -> PyErr
where
    A: for<'py> IntoPyObject<'py, Target = pyo3::types::PyTuple> + Send + Sync + 'static,
{
    let found = py.import("vrsc._errors").and_then(|m| m.getattr(class)).and_then(|c| Ok(c.cast_into::<PyType>()?));
    match found {
        Ok(class) => PyErr::from_type(class, args),
        Err(e) => e,
    }
}

/// `vrsc.SceneError(message)`.
pub fn scene_error(py: Python<'_>, message: impl Into<String>) -> PyErr {
    raise(py, "SceneError", (message.into(),))
}

/// The Python exception of a runtime error: unknown names are `KeyError`s, values of the
/// wrong type `TypeError`s, both also `vrsc.SceneError`s; a scene that does not compose is a
/// `vrsc.CompileError`; everything else (volumes, transfer functions, the GPU) a
/// `vrsc.SceneError`.
pub fn runtime_error(py: Python<'_>, error: RuntimeError) -> PyErr {
    let message = error.to_string();
    match error {
        RuntimeError::Uniform { error: UniformError::Unknown { .. }, .. } => raise(py, "UnknownNameError", (message,)),
        RuntimeError::Uniform { .. } => raise(py, "UniformTypeError", (message,)),
        RuntimeError::Compose { .. } => raise(py, "CompileError", (message, Vec::<Py<PyAny>>::new())),
        _ => scene_error(py, message),
    }
}

/// A panic caught at the boundary (a bug of vrsc): a `vrsc.SceneError` rather than a crash of
/// the interpreter.
pub fn internal(py: Python<'_>, what: &str) -> PyErr {
    scene_error(py, format!("internal error of vrsc while {what} (please report it)"))
}
