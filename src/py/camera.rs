//! The camera's float32 rays for Python (`Camera.rays(np.float32)`): the recipe of
//! `camera.rs`, which the GPU's camera kernel follows.

use super::arrays::camera_arg;
use super::errors::guarded;
use super::request::threads_arg;
use numpy::{PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

/// A camera's float32 ray directions, (H, W, 3), made on the pool's threads by the recipe
/// the GPU's camera kernel follows (`camera.rs`): `Camera.rays(np.float32)`.
#[pyfunction]
#[pyo3(signature = (axes, xs, ys, normalize, threads=None))]
pub(crate) fn camera_directions<'py>(
    py: Python<'py>,
    axes: PyReadonlyArray2<'py, f32>,
    xs: PyReadonlyArray1<'py, f32>,
    ys: PyReadonlyArray1<'py, f32>,
    normalize: bool,
    threads: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let threads = threads_arg(threads)?;
    let cam = camera_arg(&axes, &xs, &ys, normalize)?;
    let (h, w) = (cam.height(), cam.width());
    let dirs = py.detach(|| guarded(|| crate::camera::directions(&cam, threads)))?;
    Ok(numpy::PyArray1::from_vec(py, dirs)
        .reshape([h, w, 3])?
        .into_any())
}
