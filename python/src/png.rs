//! PNG bytes of a rendered image, for notebooks (`_repr_png_`) and for saving.

use numpy::{PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

/// The PNG of an H x W x 4 `uint8` image (straight alpha, as `Scene.render` returns).
#[pyfunction]
pub fn encode_png<'py>(py: Python<'py>, image: PyReadonlyArray3<'py, u8>) -> PyResult<Bound<'py, PyBytes>> {
    let [h, w, c] = [image.shape()[0], image.shape()[1], image.shape()[2]];
    if c != 4 {
        return Err(PyValueError::new_err(format!("expected an H x W x 4 image, got shape {:?}", image.shape())));
    }
    let (Ok(w32), Ok(h32)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(PyValueError::new_err(format!("an image of {w} x {h} pixels is too large for a PNG")));
    };
    // A copy in row order whatever the array's strides.
    let pixels: Vec<u8> = image.as_array().iter().copied().collect();
    let rgba = image::RgbaImage::from_raw(w32, h32, pixels)
        .ok_or_else(|| PyValueError::new_err("the image's pixels do not fill its shape"))?;
    let mut bytes = Vec::new();
    rgba.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| PyValueError::new_err(format!("cannot encode the PNG: {e}")))?;
    Ok(PyBytes::new(py, &bytes))
}
