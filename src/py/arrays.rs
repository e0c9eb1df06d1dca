//! numpy arrays in and out: contiguity and shape checks with messages naming the argument.

use numpy::{
    Element, IntoPyArray, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};

use super::errors::guarded;
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

/// `rows[index]` for an `(F + 1, 3)` float32 or float64 table and int32 indices, −1 taking
/// the last row, filled on the pool's threads: the hits' normals (`Hits.from_core`), one
/// parallel pass in place of `np.take` on one thread. The output is a Rust vector handed to
/// numpy, like the cast's columns, so that the extension's allocator keeps its block for
/// the next cast (`alloc.rs`): allocated by numpy, its 12 MB for a million rays were pages
/// faulted in afresh at every cast, 8 ms of a 130 ms cast.
#[pyfunction]
#[pyo3(signature = (rows, index, threads=None))]
pub(crate) fn take_rows<'py>(
    py: Python<'py>,
    rows: &Bound<'py, PyAny>,
    index: PyReadonlyArray1<'py, i32>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    fn typed<'py, T: Element + bytemuck::Pod + Send + Sync>(
        py: Python<'py>,
        rows: PyReadonlyArray2<'py, T>,
        index: &[i32],
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyAny>> {
        check_cols(&rows, 3, "rows")?;
        let table: &[[T; 3]] = bytemuck::cast_slice(slice(&rows, "rows")?);
        let n = index.len();
        let out = py.detach(|| {
            guarded(|| {
                let mut out: Vec<T> =
                    crate::error::try_zeroed_vec(n.saturating_mul(3), "the hits' normals")?;
                let dest: &mut [[T; 3]] = bytemuck::cast_slice_mut(&mut out);
                crate::scene::buffers::take_rows(table, index, dest, threads)?;
                Ok(out)
            })
        })?;
        Ok(out.into_pyarray(py).reshape([n, 3])?.into_any())
    }
    let ix = slice(&index, "index")?;
    if let Ok(r) = rows.extract::<PyReadonlyArray2<'py, f32>>() {
        typed(py, r, ix, threads)
    } else {
        typed(
            py,
            rows.extract::<PyReadonlyArray2<'py, f64>>()?,
            ix,
            threads,
        )
    }
}

/// The triangles' unit normals, `(F + 1, 3)` float64 with a NaN row last
/// ([`crate::scene::buffers::triangle_normals`]).
#[pyfunction]
#[pyo3(signature = (vertices, faces, threads=None))]
pub(crate) fn triangle_normals<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f64>,
    faces: PyReadonlyArray2<'py, i64>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    check_cols(&vertices, 3, "vertices")?;
    let nf = check_cols(&faces, 3, "faces")?;
    let v: &[[f64; 3]] = bytemuck::cast_slice(slice(&vertices, "vertices")?);
    let f: &[[i64; 3]] = bytemuck::cast_slice(slice(&faces, "faces")?);
    // SAFETY: uninitialized, but every row is written below before numpy or Python reads it;
    // on an error the array is dropped unread.
    let out = unsafe { PyArray2::<f64>::new(py, [nf + 1, 3], false) };
    {
        let mut w = out.readwrite();
        let dest: &mut [[f64; 3]] = bytemuck::cast_slice_mut(w.as_slice_mut()?);
        py.detach(|| guarded(|| crate::scene::buffers::triangle_normals(v, f, dest, threads)))?;
    }
    Ok(out)
}

/// A camera's float32 numbers from Python (`Camera.rays`, `RayRequest(camera=...)`): `axes`
/// (3, 3) rows right, up, forward; `xs` and `ys` each column's and row's image-plane
/// coordinate (1-D, not empty); `normalize`.
pub(crate) fn camera_arg(
    axes: &PyReadonlyArray2<'_, f32>,
    xs: &PyReadonlyArray1<'_, f32>,
    ys: &PyReadonlyArray1<'_, f32>,
    normalize: bool,
) -> PyResult<crate::camera::CameraF32> {
    if axes.shape() != [3, 3] {
        return Err(PyValueError::new_err(format!(
            "camera axes must have shape (3, 3), got {:?}",
            axes.shape()
        )));
    }
    let a = slice(axes, "camera axes")?;
    let row = |k: usize| [a[3 * k], a[3 * k + 1], a[3 * k + 2]];
    let cam = crate::camera::CameraF32 {
        right: row(0),
        up: row(1),
        forward: row(2),
        xs: slice(xs, "camera xs")?.to_vec(),
        ys: slice(ys, "camera ys")?.to_vec(),
        normalize,
    };
    cam.check()?;
    Ok(cam)
}
