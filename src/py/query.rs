//! The one ray-query binding's work: a query of the table (`scene::queries`) run over a
//! request's rays with the GIL released, its columns handed to numpy without a copy.

use super::errors::interruptible_with_progress;
use super::request::{Borrowed, PyRayRequest, WithRays};
use crate::geom::real::Real;
use crate::scene::queries::{Column, JobVisitor, RayJob};
use crate::scene::Scene;
use numpy::{Element, IntoPyArray, PyArrayMethods};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// One query over one request (what `NativeScene.query` visits the query table with).
pub(crate) struct Job<'a, 'py> {
    pub py: Python<'py>,
    pub scene: &'a Scene,
    pub request: &'a PyRayRequest,
    pub progress: Option<Py<PyAny>>,
}

impl<'py> JobVisitor for Job<'_, 'py> {
    type Out = PyResult<Bound<'py, PyDict>>;
    fn visit<J: RayJob>(self) -> Self::Out {
        let (py, request) = (self.py, self.request);
        request.with_rays(
            py,
            Run::<J> {
                job: self,
                kind: std::marker::PhantomData,
            },
        )
    }
}

struct Run<'a, 'py, J> {
    job: Job<'a, 'py>,
    kind: std::marker::PhantomData<J>,
}

impl<'py, J: RayJob> WithRays for Run<'_, 'py, J> {
    type Out = Bound<'py, PyDict>;
    fn run<R: Real + Element>(self, rays: Borrowed<'_, R>, n: usize) -> PyResult<Self::Out> {
        let Job {
            py,
            scene,
            request,
            progress,
        } = self.job;
        let rays = rays.rays(scene)?;
        let mut out = J::output::<R>(n, &request.ask)?;
        let (ask, opts) = (&request.ask, &request.opts);
        interruptible_with_progress(py, progress, || J::run(scene, ask, &rays, &mut out, opts))?;
        columns_dict(py, J::columns(out)?)
    }
}

/// The columns as a dict of numpy arrays (the vectors become the arrays without a copy).
pub(crate) fn columns_dict<'py>(
    py: Python<'py>,
    columns: Vec<Column>,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    for c in columns {
        let (name, width) = (c.name, c.width);
        let array = column_array(py, c.values, width).ok_or_else(|| {
            PyRuntimeError::new_err(format!("internal error: column {name} has no numpy type"))
        })??;
        out.set_item(name, array)?;
    }
    Ok(out)
}

/// A column's vector as a numpy array of `width` columns per row (1: flat), or None when its
/// type is none of the plain number types the queries answer with.
fn column_array<'py>(
    py: Python<'py>,
    values: Box<dyn std::any::Any + Send>,
    width: usize,
) -> Option<PyResult<Bound<'py, PyAny>>> {
    fn shaped<'py, T: Element>(
        py: Python<'py>,
        v: Vec<T>,
        width: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        let rows = v.len() / width.max(1);
        let a = v.into_pyarray(py);
        Ok(if width == 1 {
            a.into_any()
        } else {
            a.reshape([rows, width])?.into_any()
        })
    }
    macro_rules! try_types {
        ($($t:ty),*) => {{
            let mut values = values;
            $(
                match values.downcast::<Vec<$t>>() {
                    Ok(v) => return Some(shaped(py, *v, width)),
                    Err(other) => values = other,
                }
            )*
            let _ = values;
            None
        }};
    }
    try_types!(f32, f64, i32, i64, u8, u32, bool)
}
