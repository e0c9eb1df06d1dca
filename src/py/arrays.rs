//! numpy arrays in and out: contiguity and shape checks with messages naming the argument.

use numpy::{Element, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pub(crate) fn slice<'a, T: Element, D: numpy::ndarray::Dimension>(
    a: &'a numpy::PyReadonlyArray<'_, T, D>,
    name: &str,
) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name} must be C-contiguous")))
}

pub(crate) fn check_cols<T: Element>(
    a: &PyReadonlyArray2<'_, T>,
    cols: usize,
    name: &str,
) -> PyResult<usize> {
    let s = a.shape();
    if s[1] != cols {
        return Err(PyValueError::new_err(format!(
            "{name} must have shape (N, {cols}), got {s:?}"
        )));
    }
    Ok(s[0])
}

/// Reinterprets a flat slice of 3k (or 4k, 9k) values as k fixed-size rows.
pub(crate) fn rows<T: Copy, const K: usize>(flat: &[T]) -> Vec<[T; K]> {
    flat.chunks_exact(K)
        .map(|c| std::array::from_fn(|i| c[i]))
        .collect()
}
