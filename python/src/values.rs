//! Uniform values between Python and the runtime. A value is converted to the kind and length
//! of the uniform's declared type (so `1` sets an `f32`, and a nested list of columns or a
//! flat list in column order sets a matrix); anything that does not fit is handed to the
//! runtime as what it is, so its refusal reads exactly as the CLI's ("uniform `x` is a vec3f,
//! not f32").

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt, PyList, PyTuple};
use vrs_runtime::Value;

/// A Python scalar, flattened out of nested sequences (lists, tuples, numpy arrays).
enum Scalar {
    Bool(bool),
    Int(i64),
    Float(f64),
}

/// Flattens `value` into scalars; an error names anything that is not a number or a bool.
fn flatten(name: &str, value: &Bound<'_, PyAny>, out: &mut Vec<Scalar>) -> PyResult<()> {
    // numpy arrays and scalars become Python lists and numbers first.
    if value.hasattr("tolist")? && !value.is_instance_of::<PyList>() {
        return flatten(name, &value.call_method0("tolist")?, out);
    }
    if value.is_instance_of::<PyBool>() {
        out.push(Scalar::Bool(value.extract()?));
    } else if value.is_instance_of::<PyInt>() {
        let int: i64 = value
            .extract()
            .map_err(|_| PyValueError::new_err(format!("uniform `{name}`: the integer {value} is out of range")))?;
        out.push(Scalar::Int(int));
    } else if value.is_instance_of::<PyFloat>() {
        out.push(Scalar::Float(value.extract()?));
    } else if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        for item in value.try_iter()? {
            flatten(name, &item?, out)?;
        }
    } else {
        let ty = value.get_type().name().map(|n| n.to_string()).unwrap_or_default();
        return Err(PyTypeError::new_err(format!("uniform `{name}` takes numbers or booleans, not {ty}")));
    }
    Ok(())
}

/// `value` as a value of the same kind and length as `current` (the uniform's value now, which
/// has its declared type), or as its own kind when it does not fit. Non-finite floats are
/// refused.
pub fn to_value(name: &str, value: &Bound<'_, PyAny>, current: &Value) -> PyResult<Value> {
    let mut scalars = Vec::new();
    flatten(name, value, &mut scalars)?;
    if scalars.iter().any(|s| matches!(s, Scalar::Float(f) if !f.is_finite())) {
        return Err(PyValueError::new_err(format!("uniform `{name}` takes finite numbers")));
    }
    let fitted = match current {
        Value::Float(v) if v.len() == scalars.len() => floats(&scalars).map(Value::Float),
        Value::Int(v) if v.len() == scalars.len() => ints(&scalars).map(Value::Int),
        Value::Uint(v) if v.len() == scalars.len() => uints(&scalars).map(Value::Uint),
        Value::Bool(v) if v.len() == scalars.len() => bools(&scalars).map(Value::Bool),
        _ => None,
    };
    Ok(fitted.unwrap_or_else(|| natural(&scalars)))
}

fn floats(scalars: &[Scalar]) -> Option<Vec<f32>> {
    scalars
        .iter()
        .map(|s| match s {
            Scalar::Float(f) => Some(*f as f32),
            Scalar::Int(i) => Some(*i as f32),
            Scalar::Bool(_) => None,
        })
        .collect()
}

fn ints(scalars: &[Scalar]) -> Option<Vec<i32>> {
    scalars.iter().map(|s| if let Scalar::Int(i) = s { i32::try_from(*i).ok() } else { None }).collect()
}

fn uints(scalars: &[Scalar]) -> Option<Vec<u32>> {
    scalars.iter().map(|s| if let Scalar::Int(i) = s { u32::try_from(*i).ok() } else { None }).collect()
}

fn bools(scalars: &[Scalar]) -> Option<Vec<bool>> {
    scalars.iter().map(|s| if let Scalar::Bool(b) = s { Some(*b) } else { None }).collect()
}

/// The kind the scalars have by themselves: booleans if all are, integers if all are, else
/// floats; what the runtime's type check then names.
fn natural(scalars: &[Scalar]) -> Value {
    if let Some(b) = bools(scalars) {
        return Value::Bool(b);
    }
    if scalars.iter().all(|s| matches!(s, Scalar::Int(_))) {
        return Value::Int(scalars.iter().map(|s| if let Scalar::Int(i) = s { *i as i32 } else { 0 }).collect());
    }
    let as_float = |s: &Scalar| match s {
        Scalar::Float(f) => *f as f32,
        Scalar::Int(i) => *i as f32,
        Scalar::Bool(b) => f32::from(u8::from(*b)),
    };
    Value::Float(scalars.iter().map(as_float).collect())
}

/// A uniform's value for Python: a scalar, a list for a vector, a list of columns for a
/// matrix (`matCxR`).
pub fn to_python<'py>(py: Python<'py>, ty: &str, value: &Value) -> PyResult<Bound<'py, PyAny>> {
    let items: Vec<Bound<'py, PyAny>> = match value {
        Value::Float(v) => v
            .iter()
            .map(|x| f64::from(*x).into_pyobject(py).map(|o| o.into_any()).map_err(PyErr::from))
            .collect::<PyResult<_>>()?,
        Value::Int(v) => {
            v.iter().map(|x| x.into_pyobject(py).map(|o| o.into_any()).map_err(PyErr::from)).collect::<PyResult<_>>()?
        }
        Value::Uint(v) => {
            v.iter().map(|x| x.into_pyobject(py).map(|o| o.into_any()).map_err(PyErr::from)).collect::<PyResult<_>>()?
        }
        Value::Bool(v) => v.iter().map(|x| Ok(PyBool::new(py, *x).to_owned().into_any())).collect::<PyResult<_>>()?,
    };
    if let Some(rows) = matrix_rows(ty)
        && rows > 0
        && items.len().is_multiple_of(rows)
    {
        let columns: Vec<Bound<'py, PyList>> =
            items.chunks(rows).map(|col| PyList::new(py, col)).collect::<PyResult<_>>()?;
        return Ok(PyList::new(py, columns)?.into_any());
    }
    match items.len() {
        1 => Ok(items.into_iter().next().expect("one item")),
        _ => Ok(PyList::new(py, items)?.into_any()),
    }
}

/// The rows of a matrix type `matCxRf` (or `matCxR<f32>`); `None` for other types.
fn matrix_rows(ty: &str) -> Option<usize> {
    let rest = ty.strip_prefix("mat")?;
    let (_, rows) = rest.split_once('x')?;
    rows.chars().next()?.to_digit(10).map(|d| d as usize)
}

/// A JSON value of the reflection (a default, a range end) as a Python object.
pub fn json_to_python<'py>(py: Python<'py>, json: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    use serde_json::Value as J;
    Ok(match json {
        J::Null => py.None().into_bound(py),
        J::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        J::Number(n) => match (n.as_i64(), n.as_f64()) {
            (Some(i), _) => i.into_pyobject(py)?.into_any(),
            (None, Some(f)) => f.into_pyobject(py)?.into_any(),
            (None, None) => py.None().into_bound(py),
        },
        J::String(s) => s.into_pyobject(py)?.into_any(),
        J::Array(items) => {
            let items: Vec<Bound<'py, PyAny>> = items.iter().map(|i| json_to_python(py, i)).collect::<PyResult<_>>()?;
            PyList::new(py, items)?.into_any()
        }
        J::Object(_) => json.to_string().into_pyobject(py)?.into_any(),
    })
}
