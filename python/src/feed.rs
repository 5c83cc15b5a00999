//! numpy arrays as volumes: checked once (three dimensions, a numeric type the runtime keeps,
//! finite values, a usable affine), then streamed into the GPU texture straight from the
//! array's memory a z slice at a time whenever the scene loads them, so a volume is never
//! copied whole on the host.
//!
//! Axis order: `array[i, j, k]` is voxel (i, j, k), i along x, as nibabel's arrays are, so an
//! array and the NIfTI file nibabel writes from it are the same volume. A Fortran-ordered array
//! (nibabel's own layout) is read in memory order; a C-ordered one is read with its strides.

use numpy::{Element, PyArray3, PyArrayDescrMethods, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use vrs_runtime::volume::{LoadErrorKind, SampleSink, Samples, Scaling, VolumeFeed, VolumeInfo};

/// The numpy types read in place. Others (bool, 64-bit integers, half floats, byte-swapped
/// data) are converted by the Python side before they get here.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Dtype {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    F32,
    /// Kept as `f32`, a chunk at a time, as the file loaders keep `f64` files.
    F64,
}

/// Versions of feeds: unique in the process, so a renderer never takes a new array for the one
/// it loaded.
static NEXT_VERSION: AtomicU64 = AtomicU64::new(1);

/// A numpy array the scene reads its volume from.
pub struct ArrayFeed {
    array: Py<PyUntypedArray>,
    dtype: Dtype,
    info: VolumeInfo,
    version: AtomicU64,
}

impl ArrayFeed {
    /// Checks `array` and `affine` (voxel index to patient space, RAS millimetres, 4 x 4 rows).
    pub fn new(array: &Bound<'_, PyAny>, affine: [[f64; 4]; 4]) -> PyResult<ArrayFeed> {
        let array = array
            .cast::<PyUntypedArray>()
            .map_err(|_| PyTypeError::new_err(format!("a volume must be a numpy array, not {}", type_name(array))))?;
        if array.ndim() != 3 {
            return Err(PyValueError::new_err(format!(
                "a volume must be a 3D array, got shape {:?} ({} dimensions)",
                array.shape(),
                array.ndim()
            )));
        }
        let dtype = dtype_of(array)?;
        let shape = array.shape();
        let dims = shape_dims(shape)?;
        check_finite(array, dtype)?;
        let grid_to_world = affine_matrix(affine)?;
        Ok(ArrayFeed {
            array: array.clone().unbind(),
            dtype,
            info: VolumeInfo { dims, grid_to_world, scaling: Scaling::IDENTITY },
            version: AtomicU64::new(NEXT_VERSION.fetch_add(1, Ordering::Relaxed)),
        })
    }

    /// Marks the samples changed (the array was written in place): the next load reads them.
    pub fn touch(&self) {
        self.version.store(NEXT_VERSION.fetch_add(1, Ordering::Relaxed), Ordering::Relaxed);
    }
}

impl VolumeFeed for ArrayFeed {
    fn info(&self) -> VolumeInfo {
        self.info
    }

    /// Reads the array with the GIL held (one z slice per acquisition), so Python code cannot
    /// change or free it while a slice is copied.
    fn stream(&self, sink: &mut dyn SampleSink) -> Result<(), LoadErrorKind> {
        let depth = self.info.dims[2] as usize;
        for z in 0..depth {
            let chunk = Python::attach(|py| {
                let array = self.array.bind(py);
                match self.dtype {
                    Dtype::U8 => slice::<u8>(array, z, Samples::U8),
                    Dtype::I8 => slice::<i8>(array, z, Samples::I8),
                    Dtype::U16 => slice::<u16>(array, z, Samples::U16),
                    Dtype::I16 => slice::<i16>(array, z, Samples::I16),
                    Dtype::U32 => slice::<u32>(array, z, Samples::U32),
                    Dtype::I32 => slice::<i32>(array, z, Samples::I32),
                    Dtype::F32 => slice::<f32>(array, z, Samples::F32),
                    Dtype::F64 => slice::<f64>(array, z, |v| Samples::F32(v.into_iter().map(|x| x as f32).collect())),
                }
            })?;
            sink.samples(&chunk)?;
        }
        Ok(())
    }

    fn version(&self) -> u64 {
        self.version.load(Ordering::Relaxed)
    }
}

/// Slice `z` of the array, x fastest, as samples of its type.
fn slice<T: Element + Copy>(
    array: &Bound<'_, PyUntypedArray>,
    z: usize,
    wrap: impl Fn(Vec<T>) -> Samples,
) -> Result<Samples, LoadErrorKind> {
    let typed = array
        .cast::<PyArray3<T>>()
        .map_err(|_| LoadErrorKind::Header("the array's type changed after the scene took it".into()))?;
    let readonly =
        typed.try_readonly().map_err(|e| LoadErrorKind::Header(format!("the array cannot be read now: {e}")))?;
    let view = readonly.as_array();
    let plane = view.index_axis(numpy::ndarray::Axis(2), z);
    // `plane` is [x, y]; its transpose iterates y outer, x inner: the volume's order.
    Ok(wrap(plane.t().iter().copied().collect()))
}

fn type_name(value: &Bound<'_, PyAny>) -> String {
    value.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "an unknown type".into())
}

fn dtype_of(array: &Bound<'_, PyUntypedArray>) -> PyResult<Dtype> {
    let py = array.py();
    let dtype = array.dtype();
    let candidates = [
        (numpy::dtype::<u8>(py), Dtype::U8),
        (numpy::dtype::<i8>(py), Dtype::I8),
        (numpy::dtype::<u16>(py), Dtype::U16),
        (numpy::dtype::<i16>(py), Dtype::I16),
        (numpy::dtype::<u32>(py), Dtype::U32),
        (numpy::dtype::<i32>(py), Dtype::I32),
        (numpy::dtype::<f32>(py), Dtype::F32),
        (numpy::dtype::<f64>(py), Dtype::F64),
    ];
    candidates.into_iter().find(|(d, _)| dtype.is_equiv_to(d)).map(|(_, t)| t).ok_or_else(|| {
        PyValueError::new_err(format!(
            "a volume's samples must be numbers (integers or floats), not {}",
            dtype.str().map(|s| s.to_string()).unwrap_or_else(|_| "this dtype".into())
        ))
    })
}

fn shape_dims(shape: &[usize]) -> PyResult<[u32; 3]> {
    if shape.contains(&0) {
        return Err(PyValueError::new_err(format!("a volume needs samples, got an empty array of shape {shape:?}")));
    }
    let dim = |n: usize| {
        u32::try_from(n).map_err(|_| PyValueError::new_err(format!("a volume of shape {shape:?} is too large")))
    };
    Ok([dim(shape[0])?, dim(shape[1])?, dim(shape[2])?])
}

/// NaN and infinities have no place in a transfer function's window: refused with the index
/// of the first.
fn check_finite(array: &Bound<'_, PyUntypedArray>, dtype: Dtype) -> PyResult<()> {
    let first_bad = match dtype {
        Dtype::F32 => first_non_finite::<f32>(array, |v| v.is_finite())?,
        Dtype::F64 => first_non_finite::<f64>(array, |v| v.is_finite())?,
        _ => None,
    };
    match first_bad {
        Some((index, value)) => Err(PyValueError::new_err(format!(
            "a volume's samples must be finite numbers: the array holds {value} at index {index:?}"
        ))),
        None => Ok(()),
    }
}

/// Where a sample that is not finite is, and what it holds.
type BadSample = ((usize, usize, usize), String);

fn first_non_finite<T: Element + Copy + std::fmt::Display>(
    array: &Bound<'_, PyUntypedArray>,
    finite: impl Fn(T) -> bool,
) -> PyResult<Option<BadSample>> {
    let typed = array.cast::<PyArray3<T>>()?;
    let readonly = typed.try_readonly().map_err(|e| PyValueError::new_err(format!("cannot read the array: {e}")))?;
    let view = readonly.as_array();
    // The fast check in memory order first; the index only when there is something to name.
    if view.iter().all(|&v| finite(v)) {
        return Ok(None);
    }
    Ok(view.indexed_iter().find(|&(_, &v)| !finite(v)).map(|((i, j, k), v)| ((i, j, k), v.to_string())))
}

/// The affine as the runtime's matrix: finite, with a last row of (0, 0, 0, 1) and three
/// independent axes (the voxel spacings themselves are checked as every file's header is).
fn affine_matrix(rows: [[f64; 4]; 4]) -> PyResult<glam::Mat4> {
    if rows.iter().flatten().any(|v| !v.is_finite()) {
        return Err(PyValueError::new_err("the affine must hold finite numbers"));
    }
    if rows[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(PyValueError::new_err(format!("the affine's last row must be (0, 0, 0, 1), got {:?}", rows[3])));
    }
    let m = glam::DMat4::from_cols_array_2d(&rows).transpose();
    if m.determinant().abs() < 1e-30 {
        return Err(PyValueError::new_err("the affine is singular: its voxel axes do not span 3D space"));
    }
    Ok(m.as_mat4())
}
