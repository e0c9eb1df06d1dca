//! The names Python can pass, read from the core's tables: a method or layout argument is
//! checked against the table as it is extracted, and the lists Python shows come from the same
//! tables.

use crate::accel::{AccelKind, ACCELS};
use crate::layout::LayoutKind;
use crate::traverse::{Method, METHODS};
use pyo3::prelude::*;

/// An exit-method argument (`method="aman2022"`), checked against the method table.
pub(crate) struct MethodArg(pub Method);

impl<'a, 'py> FromPyObject<'a, 'py> for MethodArg {
    type Error = PyErr;
    fn extract(obj: pyo3::Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let name: String = obj.extract()?;
        Ok(MethodArg(Method::from_name(&name)?))
    }
}

/// A layout argument (`layout="tet32"`), checked against the layout table.
pub(crate) struct LayoutArg(pub LayoutKind);

impl<'a, 'py> FromPyObject<'a, 'py> for LayoutArg {
    type Error = PyErr;
    fn extract(obj: pyo3::Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let name: String = obj.extract()?;
        Ok(LayoutArg(LayoutKind::from_name(&name)?))
    }
}

/// An acceleration-structure argument (`accel="reshetov_bvh"`), checked against the table.
pub(crate) struct AccelArg(pub AccelKind);

impl<'a, 'py> FromPyObject<'a, 'py> for AccelArg {
    type Error = PyErr;
    fn extract(obj: pyo3::Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let name: String = obj.extract()?;
        Ok(AccelArg(AccelKind::from_name(&name)?))
    }
}

/// Acceleration structures: the tet walk first (the default).
#[pyfunction]
pub(crate) fn accels() -> Vec<&'static str> {
    ACCELS.to_vec()
}

/// Exit methods, in the order of the papers.
#[pyfunction]
pub(crate) fn methods() -> Vec<&'static str> {
    METHODS.to_vec()
}

/// Traversal layouts, with their bytes per tet.
#[pyfunction]
pub(crate) fn layouts() -> Vec<(&'static str, usize)> {
    LayoutKind::ALL
        .iter()
        .map(|k| (k.name(), k.bytes_per_tet()))
        .collect()
}

/// The SIMD levels this CPU runs, lowest first, and the one a cast uses now (the highest,
/// capped by `TETRACE_SIMD`; an unknown name there is a ValueError).
#[pyfunction]
pub(crate) fn simd_levels() -> PyResult<(Vec<&'static str>, &'static str)> {
    let levels = crate::simd::Simd::supported_levels();
    let now = crate::simd::Simd::from_env()?;
    Ok((levels.into_iter().map(|s| s.name()).collect(), now.name()))
}
